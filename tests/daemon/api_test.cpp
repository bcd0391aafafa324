// The socket API over real gRPC channels: the Unix socket, TCP with the bearer
// token, TLS; validation of hostile input; health.
#include <algorithm>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>

#include <unistd.h>

#include <atomic>
#include <cstring>
#include <fstream>
#include <iostream>
#include <future>
#include <limits>
#include <map>
#include <set>
#include <thread>

#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <sstream>

#include <gmock/gmock.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include "chromo/daemon/server.hpp"
#include "../support/test_certificate.hpp"
#include "chromo/files/fnv1a.hpp"
#include "chromosphere/v1/calibration.grpc.pb.h"
#include "chromosphere/v1/estimation.grpc.pb.h"
#include "chromosphere/v1/events.grpc.pb.h"
#include "chromosphere/v1/leds.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "chromosphere/v1/sessions.grpc.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace pb = chromosphere::v1;
using grpc::StatusCode;

constexpr const char* kToken = "test-token-0123456789";

struct ApiFixture : ::testing::Test {
  testing::TestLab lab{"api"};
  std::unique_ptr<Daemon> daemon;
  std::unique_ptr<Server> server;
  std::shared_ptr<grpc::Channel> channel;

  void start() {
    daemon = lab.daemon();
    server = std::make_unique<Server>(*daemon);
    channel = grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials());
  }
  // TCP with TLS (a test certificate for localhost) instead of loopback plaintext; call before start().
  chromo::testing::TestCertificate use_tls() {
    auto certificate = chromo::testing::make_test_certificate(lab.directory);
    lab.config.tls_certificate_file = certificate.certificate_file.string();
    lab.config.tls_private_key_file = certificate.key_file.string();
    lab.config.tcp_insecure = false;
    return certificate;
  }
  void SetUp() override {
    lab.config.tcp_address = "127.0.0.1:0";
    lab.config.token = kToken;
    lab.config.tcp_insecure = true;  // loopback plaintext (TLS has its own test)
  }
  void TearDown() override {
    if (server) server->shutdown();
  }
  pb::Operation watch_to_end(const std::string& id) {
    auto stub = pb::OperationService::NewStub(channel);
    grpc::ClientContext context;
    pb::WatchOperationRequest request;
    request.set_id(id);
    auto reader = stub->WatchOperation(&context, request);
    pb::Operation operation, last;
    while (reader->Read(&operation)) last = operation;
    EXPECT_TRUE(reader->Finish().ok());
    return last;
  }
};

std::vector<nlohmann::json> audit_lines(const std::filesystem::path& sessions_dir);

grpc::Status start_session(grpc::Channel& channel, const pb::StartSessionRequest& request, pb::Operation* out) {
  grpc::ClientContext context;
  return pb::SessionService::NewStub(std::shared_ptr<grpc::Channel>(&channel, [](auto*) {}))->StartSession(&context, request, out);
}

TEST_F(ApiFixture, StandardSessionStreamsProgressAndResultsAreFetchedById) {
  start();
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(1000);
  request.set_reference_frames(2);  // the dark and the 3 whites: 2 frames each; the 3 subjects 1
  request.set_subject("api test");
  request.set_operator_name("Ana");
  request.set_study("pilot-41");
  request.set_preflight(true);  // the healthy lab: warnings (no calibration), nothing failed
  pb::Operation started;
  ASSERT_TRUE(start_session(*channel, request, &started).ok());
  EXPECT_FALSE(started.id().empty());
  auto final = watch_to_end(started.id());
  EXPECT_EQ(final.state(), pb::OPERATION_STATE_SUCCEEDED) << final.error();
  EXPECT_EQ(final.counters().stored(), 11u);
  EXPECT_EQ(final.counters().expected(), 11u);
  EXPECT_DOUBLE_EQ(final.progress(), 1.0);

  // From a new connection: the session, its frames and its results by id.
  auto other = grpc::CreateChannel("unix:" + lab.config.unix_socket, grpc::InsecureChannelCredentials());
  grpc::ClientContext context;
  pb::GetSessionRequest get;
  get.set_id(started.id());
  get.set_include_frames(true);
  pb::SessionDetail detail;
  ASSERT_TRUE(pb::SessionService::NewStub(other)->GetSession(&context, get, &detail).ok());
  EXPECT_EQ(detail.frames_size(), 11);
  EXPECT_EQ(detail.steps(0).frames_stored(), 2u);
  EXPECT_EQ(detail.steps(6).frames_stored(), 1u);
  EXPECT_EQ(detail.subject(), "api test");
  EXPECT_EQ(detail.steps(6).name(), "subject_w57+blue");
  EXPECT_TRUE(detail.steps(6).completed());
  EXPECT_EQ(detail.frames(0).temperature_c_size(), 6);

  grpc::ClientContext results_context;
  pb::GetResultsRequest results_request;
  results_request.set_session_id(started.id());
  pb::Results results;
  ASSERT_TRUE(pb::ResultsService::NewStub(other)->GetResults(&results_context, results_request, &results).ok());
  EXPECT_EQ(results.frame_files_size(), 11);
  EXPECT_EQ(results.folder(), final.folder());

  // Issue 41: what it was made with, in the detail, the results and the list.
  for (const pb::SessionProvenance* p : {&detail.provenance(), &results.provenance()}) {
    ASSERT_TRUE(p->recorded());
    EXPECT_EQ(p->led_library().kind(), "nominal");  // no calibration has run
    EXPECT_EQ(p->led_library().age_at_start_s(), -1);
    EXPECT_EQ(p->operator_name(), "Ana");
    EXPECT_EQ(p->study(), "pilot-41");
    EXPECT_EQ(p->plan(), "standard");
    EXPECT_THAT(p->estimator_version(), ::testing::StartsWith("chromosphere "));
    ASSERT_EQ(p->mixes().count("d65"), 1u);
    EXPECT_EQ(p->mixes().at("d65").origin(), "configured (mixes)");
    EXPECT_DOUBLE_EQ(p->mixes().at("d65").weights().w57(), lab.config.mixes.at("d65")[0]);
    EXPECT_EQ(p->estimator_options().at("method"), lab.config.estimation.method);
  }
  grpc::ClientContext list_context;
  pb::ListSessionsResponse list;
  ASSERT_TRUE(pb::SessionService::NewStub(other)->ListSessions(&list_context, {}, &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).subject(), "api test");
  EXPECT_EQ(list.sessions(0).study(), "pilot-41");
  EXPECT_EQ(list.sessions(0).operator_name(), "Ana");
  const auto report = nlohmann::json::parse(std::ifstream(std::filesystem::path(final.folder()) / "results" / "summary.json"));
  EXPECT_EQ(report.at("provenance").at("operator"), "Ana");
  EXPECT_EQ(report.at("provenance").at("led_library").at("kind"), "nominal");
  const auto audit = audit_lines(lab.config.sessions_dir);
  ASSERT_FALSE(audit.empty());
  EXPECT_TRUE(audit.back().at("preflight").at("failed").empty()) << audit.back().dump();
}

// Issue 41: a failed check refuses a preflighted start, naming the check and
// its fix; an override reason lets it past the preflight and goes to the audit log.
TEST_F(ApiFixture, PreflightRefusesAFailedCheckUnlessOverriddenWithAReasonTheAuditLogKeeps) {
  lab.config.storage_limit_bytes = 64 << 10;  // below one session's frames: the disk check fails
  start();
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(1000);
  request.set_preflight(true);
  pb::Operation started;
  grpc::Status status = start_session(*channel, request, &started);
  EXPECT_EQ(status.error_code(), StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("preflight: disk: "));
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("preflight_override_reason"));
  EXPECT_FALSE(std::filesystem::exists(lab.config.sessions_dir) &&
               std::any_of(std::filesystem::directory_iterator(lab.config.sessions_dir), {},
                           [](const auto& entry) { return std::filesystem::exists(entry.path() / "session.json"); }));
  request.set_preflight_override_reason(std::string("bad\x01reason"));
  status = start_session(*channel, request, &started);
  EXPECT_EQ(status.error_code(), StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("preflight_override_reason"));
  request.set_preflight_override_reason("dry run of the storage limit");
  status = start_session(*channel, request, &started);
  EXPECT_NE(status.error_message().find("preflight"), 0u) << "past the preflight: " << status.error_message();
  if (status.ok()) watch_to_end(started.id());
  const auto audit = audit_lines(lab.config.sessions_dir);
  ASSERT_GE(audit.size(), 3u);
  const auto& refused = audit[audit.size() - 3].at("preflight");
  EXPECT_EQ(refused.at("failed"), nlohmann::json::array({"disk"}));
  EXPECT_FALSE(refused.contains("override_reason"));
  const auto& overridden = audit.back().at("preflight");
  EXPECT_EQ(overridden.at("failed"), nlohmann::json::array({"disk"}));
  EXPECT_EQ(overridden.at("override_reason"), "dry run of the storage limit");
}

// The Sessions form's check before Start (issue 41): GetStandardPlan says why
// StartSession would refuse the plan on this sphere, in StartSession's words,
// and says nothing for a plan that starts.
TEST_F(ApiFixture, GetStandardPlanSaysWhyStartSessionWouldRefuseThePlanHere) {
  start();
  auto sessions = pb::SessionService::NewStub(channel);
  pb::GetStandardPlanRequest get;
  get.set_polarised(pb::POLARISED_PLAN_ON);  // this lab's sphere has no polariser banks
  pb::SessionPlan shown;
  grpc::ClientContext c1, c2;
  ASSERT_TRUE(sessions->GetStandardPlan(&c1, get, &shown).ok());
  EXPECT_THAT(shown.start_refusal(), ::testing::HasSubstr("].polarisation: cross"));
  EXPECT_THAT(shown.start_refusal(), ::testing::HasSubstr("has no polariser banks"));
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_polarised(pb::POLARISED_PLAN_ON);
  pb::Operation out;
  const grpc::Status refused = start_session(*channel, request, &out);
  EXPECT_EQ(refused.error_code(), StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(refused.error_message(), shown.start_refusal());
  get.set_polarised(pb::POLARISED_PLAN_OFF);
  ASSERT_TRUE(sessions->GetStandardPlan(&c2, get, &shown).ok());
  EXPECT_EQ(shown.start_refusal(), "");
  EXPECT_TRUE(daemon->operations().list().empty()) << "a refused plan left an operation";
}

TEST_F(ApiFixture, UnixSocketCarriesTheConfiguredPermissions) {
  lab.config.unix_socket_mode = 0600;
  start();
  struct stat info {};
  ASSERT_EQ(::stat(lab.config.unix_socket.c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0600u);
}

TEST_F(ApiFixture, HostileInputIsRefusedWithTheFieldNamedAndNothingChanges) {
  start();
  auto sessions = pb::SessionService::NewStub(channel);
  auto operations = pb::OperationService::NewStub(channel);
  auto leds = pb::LedService::NewStub(channel);
  auto expect = [](const grpc::Status& status, StatusCode code, const std::string& field) {
    EXPECT_EQ(status.error_code(), code) << status.error_message();
    EXPECT_NE(status.error_message().find(field), std::string::npos) << status.error_message();
  };
  pb::Operation out;
  {  // Out-of-range value inside a plan.
    pb::StartSessionRequest request;
    auto* plan = request.mutable_plan();
    plan->set_name("p");
    auto* step = plan->add_steps();
    step->set_name("s");
    step->set_dark(true);
    step->set_exposure_us(-5);
    step->set_frames_per_camera(1);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].exposure_us");
    step->set_exposure_us(std::nan(""));
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].exposure_us");
    // Issue 40, row 13: a positive but absurd exposure passed and failed only at the camera.
    for (double absurd : {1e-300, 0.5, std::numeric_limits<double>::denorm_min()}) {
      step->set_exposure_us(absurd);
      expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].exposure_us");
    }
    step->set_exposure_us(1000);
    step->set_prompt("look \x1b[2J here");
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].prompt");
    step->set_prompt("line one\nline two");  // a prompt may have lines
    step->set_exposure_us(-5);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].exposure_us");
    step->set_exposure_us(1000);
    step->mutable_weights()->set_blue(1.5);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].weights.blue");
    step->set_mix("d65; rm -rf /");
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].mix");
    step->clear_illumination();
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].illumination");
    step->set_dark(true);
    plan->set_timing(static_cast<pb::Timing>(99));  // an enum value the schema does not know
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.timing");
    plan->set_timing(pb::TIMING_SOFTWARE);
    plan->set_name(std::string(5000, 'n'));
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.name");
    plan->set_name("p");  // subject metering: each field's range, then where it may be
    step->set_subject_percentile(1.5);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].subject_percentile");
    step->set_subject_percentile(-0.5);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].subject_percentile");
    step->set_subject_percentile(0.99);
    step->set_max_subject_exposure_ratio(0.5);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT,
           "plan.steps[0].max_subject_exposure_ratio");
    step->set_max_subject_exposure_ratio(8);
    step->set_subject_fill(1.2);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].subject_fill");
    step->set_subject_fill(0.85);  // a dark step: only a subject taking its white's metered exposure is metered
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "plan.steps[0].subject_fill");
  }
  {  // The standard plan's subject_fill: in (0, 1), and only with metered whites.
    pb::StartSessionRequest request;
    request.set_standard(true);
    for (double bad : {1.5, 1.0, -0.2, std::nan("")}) {
      request.set_subject_fill(bad);
      expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "subject_fill");
    }
    request.set_subject_fill(0.85);
    request.set_fixed_exposure(true);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "subject_fill");
    // GetStandardPlan: the same rule, and the plan it shows meters the subjects and ends with the linearity whites.
    pb::GetStandardPlanRequest get;
    get.set_subject_fill(1.5);
    pb::SessionPlan shown;
    grpc::ClientContext c1, c2;
    expect(sessions->GetStandardPlan(&c1, get, &shown), StatusCode::INVALID_ARGUMENT, "subject_fill");
    get.set_subject_fill(0.85);
    ASSERT_TRUE(sessions->GetStandardPlan(&c2, get, &shown).ok());
    std::map<std::string, const pb::Step*> by_name;
    for (const auto& step : shown.steps()) by_name[step.name()] = &step;
    ASSERT_TRUE(by_name.count("subject_d65") && by_name.count("subject_w57") && by_name.count("white_w57_linearity"));
    EXPECT_DOUBLE_EQ(by_name.at("subject_d65")->subject_fill(), 0.85);
    EXPECT_EQ(by_name.at("subject_w57")->subject_ratio_from(), "subject_w57+blue");
    EXPECT_EQ(by_name.at("white_w57_linearity")->linearity_of(), "subject_w57");
  }
  {  // Issue 40, rows 13-14: the standard plan's exposure at 1e-300 µs, and a
     // subject holding NUL or a terminal escape (printed raw by chromo session show).
    pb::StartSessionRequest request;
    request.set_standard(true);
    request.set_exposure_us(1e-300);
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "exposure_us");
    request.set_exposure_us(0);
    for (const auto& subject : std::vector<std::string>{std::string("a\0b", 3), std::string("a\x1b[31mred"), std::string("bell\a"),
                                      std::string("c1 \xc2\x9b" "31m"), std::string("tab\there"), std::string("del\x7f")}) {
      request.set_subject(subject);
      expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "subject");
    }
    pb::GetStandardPlanRequest get;
    get.set_exposure_us(1e-300);
    pb::SessionPlan shown;
    grpc::ClientContext context;
    expect(sessions->GetStandardPlan(&context, get, &shown), StatusCode::INVALID_ARGUMENT, "exposure_us");
  }
  {  // Huge strings: over the field's bound, and over the message size limit.
    pb::StartSessionRequest request;
    request.set_standard(true);
    request.set_subject(std::string(5000, 's'));
    expect(start_session(*channel, request, &out), StatusCode::INVALID_ARGUMENT, "subject");
    request.set_subject(std::string(2 << 20, 's'));
    EXPECT_EQ(start_session(*channel, request, &out).error_code(), StatusCode::RESOURCE_EXHAUSTED);
    pb::StartSessionRequest none;
    expect(start_session(*channel, none, &out), StatusCode::INVALID_ARGUMENT, "plan_source");
  }
  {  // Unknown and malformed ids.
    grpc::ClientContext c1, c2, c3, c4;
    pb::GetOperationRequest get;
    get.set_id("20261122T000000Z-nothing-000000");
    expect(operations->GetOperation(&c1, get, &out), StatusCode::NOT_FOUND, "id");
    get.set_id("../../etc/passwd");
    expect(operations->GetOperation(&c2, get, &out), StatusCode::INVALID_ARGUMENT, "id");
    pb::CancelOperationRequest cancel;
    expect(operations->CancelOperation(&c3, cancel, &out), StatusCode::INVALID_ARGUMENT, "id");
    pb::GetSessionRequest session;
    session.set_id(std::string(300, 'a'));
    pb::SessionDetail detail;
    expect(sessions->GetSession(&c4, session, &detail), StatusCode::INVALID_ARGUMENT, "id");
  }
  {  // LED state out of range; unknown controller.
    grpc::ClientContext c1, c2, c3;
    pb::SetLedStateRequest set;
    set.mutable_state()->mutable_drive()->set_red(2.0);
    pb::LedStatus status;
    expect(leds->SetLedState(&c1, set, &status), StatusCode::INVALID_ARGUMENT, "state.drive.red");
    set.mutable_state()->mutable_drive()->set_red(0.5);
    set.set_controller("nobody");
    expect(leds->SetLedState(&c2, set, &status), StatusCode::NOT_FOUND, "controller");
    pb::SetLedStateRequest empty;
    expect(leds->SetLedState(&c3, empty, &status), StatusCode::INVALID_ARGUMENT, "state");
  }
  EXPECT_EQ(lab.emitted(), drivers::DriveLevels{});  // no refused request touched the LEDs
  {  // Wrong types: bytes that are not a StartSessionRequest.
    grpc::GenericStub generic(channel);
    grpc::ClientContext context;
    std::string garbage = "\xff\xff\xff\xff\x0f this is not protobuf";
    grpc::Slice slice(garbage);
    grpc::ByteBuffer request(&slice, 1), response;
    std::promise<grpc::Status> done;
    generic.UnaryCall(&context, "/chromosphere.v1.SessionService/StartSession", grpc::StubOptions(), &request, &response,
                      [&](grpc::Status status) { done.set_value(status); });
    EXPECT_FALSE(done.get_future().get().ok());
  }
  // Nothing was started: the sessions folder holds only the audit log, every
  // line of it a refusal.
  for (const auto& entry : std::filesystem::directory_iterator(lab.config.sessions_dir))
    EXPECT_EQ(entry.path().filename(), "audit.jsonl");
  for (const auto& line : audit_lines(lab.config.sessions_dir)) EXPECT_EQ(line["outcome"], "refused") << line.dump();
  {  // The daemon still serves.
    grpc::ClientContext context;
    pb::ListSessionsRequest list;
    pb::ListSessionsResponse sessions_list;
    EXPECT_TRUE(sessions->ListSessions(&context, list, &sessions_list).ok());
  }
}

TEST_F(ApiFixture, LedStateIsSetAndReadBackButNotDuringASession) {
  start();
  auto leds = pb::LedService::NewStub(channel);
  grpc::ClientContext c1;
  pb::SetLedStateRequest set;
  set.mutable_state()->mutable_drive()->set_w57(0.25);
  pb::LedStatus status;
  ASSERT_TRUE(leds->SetLedState(&c1, set, &status).ok());
  EXPECT_NEAR(status.applied().drive().w57(), 0.25, 1e-3);  // as the controller quantised it
  EXPECT_NEAR(lab.emitted()[0], 0.25, 1e-3);                 // what the simulator's firmware holds

  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(2000);
  request.set_frames_per_camera(20);
  pb::Operation started;
  ASSERT_TRUE(start_session(*channel, request, &started).ok());
  grpc::ClientContext c2;
  EXPECT_EQ(leds->SetLedState(&c2, set, &status).error_code(), StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(start_session(*channel, request, &started).error_code(), StatusCode::FAILED_PRECONDITION);
  grpc::ClientContext c3;
  pb::CancelOperationRequest cancel;
  cancel.set_id(started.id());
  pb::Operation cancelled;
  ASSERT_TRUE(pb::OperationService::NewStub(channel)->CancelOperation(&c3, cancel, &cancelled).ok());
  EXPECT_EQ(watch_to_end(started.id()).state(), pb::OPERATION_STATE_CANCELLED);
  grpc::ClientContext c4;
  EXPECT_EQ(pb::OperationService::NewStub(channel)->CancelOperation(&c4, cancel, &cancelled).error_code(),
            StatusCode::FAILED_PRECONDITION);
}

grpc::Status list_over_tcp(std::shared_ptr<grpc::Channel> channel, const char* authorization) {
  grpc::ClientContext context;
  if (authorization) context.AddMetadata("authorization", authorization);
  pb::ListOperationsRequest request;
  pb::ListOperationsResponse response;
  return pb::OperationService::NewStub(channel)->ListOperations(&context, request, &response);
}

TEST_F(ApiFixture, TcpNeedsTheBearerTokenOnEveryCall) {
  start();
  ASSERT_GT(server->tcp_port(), 0);
  auto tcp = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->tcp_port()), grpc::InsecureChannelCredentials());
  EXPECT_EQ(list_over_tcp(tcp, nullptr).error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(list_over_tcp(tcp, "Bearer wrong-token-0123456789").error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(list_over_tcp(tcp, "Bearer test-token-012345678").error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(list_over_tcp(tcp, "test-token-0123456789").error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(list_over_tcp(tcp, "Bearer test-token-0123456789").ok());
}

// A TLS channel to chromod's TCP port trusting `certificate_pem` (made for localhost).
std::shared_ptr<grpc::Channel> tls_channel(int port, const std::string& certificate_pem) {
  grpc::SslCredentialsOptions options;
  options.pem_root_certs = certificate_pem;
  grpc::ChannelArguments arguments;
  arguments.SetSslTargetNameOverride("localhost");
  return grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port), grpc::SslCredentials(options), arguments);
}

TEST_F(ApiFixture, TlsWithTokenWhenCertificatesAreConfigured) {
  const auto certificate = use_tls();
  start();
  auto tls = tls_channel(server->tcp_port(), certificate.certificate_pem);
  EXPECT_TRUE(list_over_tcp(tls, "Bearer test-token-0123456789").ok());
  EXPECT_EQ(list_over_tcp(tls, nullptr).error_code(), StatusCode::UNAUTHENTICATED);
  // A plaintext client cannot talk to the TLS port at all.
  auto plain = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->tcp_port()), grpc::InsecureChannelCredentials());
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(2));
  context.AddMetadata("authorization", "Bearer test-token-0123456789");
  pb::ListOperationsResponse response;
  EXPECT_FALSE(pb::OperationService::NewStub(plain)->ListOperations(&context, {}, &response).ok());
}

// A TCP connection to 127.0.0.1:port that sends nothing; -1 when refused.
int silent_connection(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// True when the server ends `fd` (EOF or reset) within `ms`.
bool closed_by_server(int fd, int ms) {
  pollfd p{fd, POLLIN, 0};
  char byte;
  return ::poll(&p, 1, ms) == 1 && ::recv(fd, &byte, 1, MSG_DONTWAIT) <= 0;
}

// Issue 40, row 3 (in part): TLS connections that never sent a byte were
// kept for gRPC's 120 s handshake timeout, so enough of them used up the
// descriptors. Now one is closed after tcp_handshake_timeout_ms.
TEST_F(ApiFixture, ATlsConnectionThatNeverHandshakesIsClosed) {
  const auto certificate = use_tls();
  lab.config.tcp_handshake_timeout_ms = 1000;
  start();
  std::vector<int> silent;
  for (int i = 0; i < 10; ++i) {
    silent.push_back(silent_connection(server->tcp_port()));
    ASSERT_GE(silent.back(), 0);
  }
  int closed = 0;  // each sees its end (EOF or reset) within 10 s: gRPC's default would keep it 120 s
  for (int fd : silent) {
    closed += closed_by_server(fd, 10000);
    ::close(fd);
  }
  EXPECT_EQ(closed, 10);
  // And a client that does its handshake is served.
  auto tls = tls_channel(server->tcp_port(), certificate.certificate_pem);
  EXPECT_TRUE(list_over_tcp(tls, "Bearer test-token-0123456789").ok());
}

// Issue 40, row 3 (the rest): a client that handshakes over TLS and then
// holds its connection without a call (or with calls refused for want of the
// token) was kept as long as it liked. It is closed after tcp_idle_timeout_ms.
TEST_F(ApiFixture, AHandshakenTlsConnectionWithoutCallsIsClosedOnceIdle) {
  const auto certificate = use_tls();
  lab.config.tcp_idle_timeout_ms = 500;
  start();
  auto tls = tls_channel(server->tcp_port(), certificate.certificate_pem);
  ASSERT_TRUE(tls->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(10)));
  EXPECT_EQ(list_over_tcp(tls, nullptr).error_code(), StatusCode::UNAUTHENTICATED);
  // The server's GOAWAY after 500 ms idle takes the channel out of READY.
  bool left_ready = false;
  for (auto state = tls->GetState(false); !left_ready;) {
    if (!tls->WaitForStateChange(state, std::chrono::system_clock::now() + std::chrono::seconds(10))) break;
    state = tls->GetState(false);
    left_ready = state != GRPC_CHANNEL_READY;
  }
  EXPECT_TRUE(left_ready) << "the idle connection was still open 10 s later";
  // A client with the token reconnects and is served.
  EXPECT_TRUE(list_over_tcp(tls, "Bearer test-token-0123456789").ok());
  // The web view's in-process channel cannot reconnect: idle longer than the
  // timeout, it still serves.
  // The Unix socket's clients reconnect as TCP's do.
  auto in_process = server->in_process_channel();
  EXPECT_TRUE(list_over_tcp(in_process, "Bearer test-token-0123456789").ok());
  EXPECT_TRUE(list_over_tcp(channel, nullptr).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_TRUE(list_over_tcp(in_process, "Bearer test-token-0123456789").ok()) << "the in-process channel was closed when idle";
  EXPECT_TRUE(list_over_tcp(channel, nullptr).ok()) << "the Unix socket's client did not reconnect";
}

// Waits up to 10 s for `done`.
template <class Done>
bool eventually(Done done) {
  for (int i = 0; i < 500 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  return done();
}

// Issue 40, row 3 (the cap): gRPC 1.51 accepted any number of TCP connections
// and, after one accept4 EMFILE, never accepted again. chromod now accepts on
// the TCP port itself: beyond max_tcp_connections a connection is closed as
// soon as it is accepted, the ones held go on being served, and once they
// leave the port serves again.
TEST_F(ApiFixture, TcpConnectionsBeyondTheCapAreClosedAtOnceAndThePortServesOnceTheyLeave) {
  const auto certificate = use_tls();
  lab.config.max_tcp_connections = 6;
  start();
  const int port = server->tcp_port();
  // A client with the token, connected first: it holds one of the six.
  auto served = tls_channel(port, certificate.certificate_pem);
  ASSERT_TRUE(list_over_tcp(served, "Bearer test-token-0123456789").ok());
  std::vector<int> held;
  for (int i = 0; i < 5; ++i) held.push_back(silent_connection(port));
  for (int fd : held) ASSERT_GE(fd, 0);
  ASSERT_TRUE(eventually([&] { return server->tcp_counters().open == 6; })) << server->tcp_counters().open;
  // Four more: each closed at once (the kernel completes the handshake; the gate closes it).
  int refused = 0;
  for (int i = 0; i < 4; ++i) {
    const int fd = silent_connection(port);
    if (fd < 0 || closed_by_server(fd, 5000)) ++refused;
    if (fd >= 0) ::close(fd);
  }
  EXPECT_EQ(refused, 4);
  EXPECT_TRUE(eventually([&] { return server->tcp_counters().refused_over_cap == 4u; }))
      << server->tcp_counters().refused_over_cap;
  // The connection held by a real client is still served.
  EXPECT_TRUE(list_over_tcp(served, "Bearer test-token-0123456789").ok());
  // A new client is not, while the six are held.
  {
    auto late = tls_channel(port, certificate.certificate_pem);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    context.AddMetadata("authorization", "Bearer test-token-0123456789");
    pb::ListOperationsResponse response;
    EXPECT_EQ(pb::OperationService::NewStub(late)->ListOperations(&context, {}, &response).error_code(),
              StatusCode::UNAVAILABLE);
  }
  // They leave: the gate closes their relays, and a new client is served.
  for (int fd : held) ::close(fd);
  ASSERT_TRUE(eventually([&] { return server->tcp_counters().open <= 1; })) << server->tcp_counters().open;
  auto after = tls_channel(port, certificate.certificate_pem);
  EXPECT_TRUE(list_over_tcp(after, "Bearer test-token-0123456789").ok());
  EXPECT_EQ(server->tcp_counters().accept_failures, 0u);
}

// The cap must fit the descriptor limit (three open files a connection, 256
// beside them): refused at start, naming the key and the limit.
TEST_F(ApiFixture, ACapTheDescriptorLimitCannotHoldIsRefusedNamingIt) {
  rlimit saved{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &saved), 0);
  lab.config.max_tcp_connections = 300;  // 3·300 + 256 = 1156 open files
  daemon = lab.daemon();
  rlimit lowered = saved;
  lowered.rlim_cur = 1024;  // Debian's default soft limit
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &lowered), 0);
  std::string error;
  try {
    Server refused(*daemon);
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &saved), 0);
  EXPECT_NE(error.find("max_tcp_connections: 300 connections need 1156 open files (3 each + 256), more than this "
                       "process's limit of 1024"),
            std::string::npos)
      << error;
  // 256 fit: 1024 open files.
  lab.config.max_tcp_connections = 256;
  daemon = lab.daemon();
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &lowered), 0);
  EXPECT_NO_THROW(server = std::make_unique<Server>(*daemon));
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &saved), 0);
}

// A raw call: `body` as the message bytes, whatever they are.
grpc::Status raw_call(std::shared_ptr<grpc::Channel> channel, const std::string& method, const std::string& body,
                      const char* authorization) {
  grpc::GenericStub generic(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (authorization) context.AddMetadata("authorization", authorization);
  grpc::Slice slice(body);
  grpc::ByteBuffer request(&slice, 1), response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, method, grpc::StubOptions(), &request, &response,
                    [&](grpc::Status status) { done.set_value(status); });
  return done.get_future().get();
}

TEST_F(ApiFixture, OverTcpTheTokenIsCheckedBeforeTheMessageIsParsed) {
  start();
  auto tcp = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->tcp_port()), grpc::InsecureChannelCredentials());
  const std::string malformed("\xff\xff\xff\xff\x0f", 5);  // not a protobuf message
  const char* method = "/chromosphere.v1.SessionService/StartSession";
  for (const char* authorization : {static_cast<const char*>(nullptr), "Bearer wrong-token-0123456789"}) {
    const grpc::Status status = raw_call(tcp, method, malformed, authorization);
    EXPECT_EQ(status.error_code(), StatusCode::UNAUTHENTICATED) << status.error_message();
    EXPECT_THAT(status.error_message(), ::testing::StartsWith("authorization: "));
  }
  // With the token, the same bytes reach the parser (and are refused there),
  // and nothing was started by any of them.
  const grpc::Status parsed = raw_call(tcp, method, malformed, "Bearer test-token-0123456789");
  EXPECT_NE(parsed.error_code(), StatusCode::UNAUTHENTICATED);
  EXPECT_NE(parsed.error_code(), StatusCode::OK);
  EXPECT_TRUE(daemon->operations().list().empty());
  // The Unix socket needs no token.
  EXPECT_EQ(raw_call(channel, "/chromosphere.v1.OperationService/ListOperations", "", nullptr).error_code(), StatusCode::OK);
}

// Threads of this process (the test's client and the daemon's server).
int thread_count() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("Threads:", 0) == 0) return std::stoi(line.substr(8));
  return -1;
}

TEST_F(ApiFixture, StreamsBeyondMaxStreamsAreRefusedAndThreadsStayBounded) {
  ASSERT_EQ(lab.config.max_streams, 64u);  // the documented default
  start();
  const int baseline = thread_count();
  std::atomic<bool> sampling{true};
  std::atomic<int> peak{0};
  std::thread sampler([&] {
    while (sampling) {
      peak = std::max(peak.load(), thread_count());
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  // 1000 subscriptions at once, plus a WatchOperation of a past session: one
  // counter for every server-streaming call.
  constexpr int kAttempts = 1000;
  auto events = pb::EventService::NewStub(channel);
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<pb::Event>>> readers;
  for (int i = 0; i < kAttempts; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    contexts.back()->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    readers.push_back(events->Subscribe(contexts.back().get(), pb::SubscribeRequest{}));
  }
  // Every accepted stream gets the next log event; a refused one ends.
  std::atomic<bool> publishing{true};
  std::thread publisher([&] {
    while (publishing) {
      Event event;
      event.kind = Event::Kind::kLog;
      event.log = "ping";
      daemon->events().publish(event);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  int accepted = 0, refused_by_limit = 0;
  std::vector<std::size_t> open;
  for (std::size_t i = 0; i < readers.size(); ++i) {
    pb::Event event;
    if (readers[i]->Read(&event)) {
      ++accepted;
      open.push_back(i);
      continue;
    }
    const grpc::Status status = readers[i]->Finish();
    EXPECT_EQ(status.error_code(), StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
    if (status.error_message().rfind("max_streams: 64 streaming calls are open", 0) == 0) ++refused_by_limit;
  }
  EXPECT_EQ(accepted, 64);
  EXPECT_GT(refused_by_limit, 0);
  // While 64 streams run: a unary call still answers, a 65th stream (of the
  // other kind) is refused naming the limit.
  pb::ListOperationsResponse listed;
  {
    grpc::ClientContext context;
    EXPECT_TRUE(pb::OperationService::NewStub(channel)->ListOperations(&context, {}, &listed).ok());
  }
  {
    grpc::ClientContext context;
    pb::WatchOperationRequest request;
    request.set_id("20260101T000000Z-none-000000");
    auto reader = pb::OperationService::NewStub(channel)->WatchOperation(&context, request);
    pb::Operation operation;
    EXPECT_FALSE(reader->Read(&operation));
    const grpc::Status status = reader->Finish();
    EXPECT_EQ(status.error_code(), StatusCode::RESOURCE_EXHAUSTED);
    EXPECT_THAT(status.error_message(), ::testing::HasSubstr("max_streams: 64"));
  }
  sampling = false;
  sampler.join();
  // Closing one frees its slot: the next subscription is served.
  contexts[open.front()]->TryCancel();
  readers[open.front()]->Finish();
  open.erase(open.begin());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  {
    grpc::ClientContext context;
    auto reader = events->Subscribe(&context, pb::SubscribeRequest{});
    pb::Event event;
    EXPECT_TRUE(reader->Read(&event));
    context.TryCancel();
    reader->Finish();
  }
  publishing = false;
  publisher.join();
  for (std::size_t i : open) contexts[i]->TryCancel();
  for (std::size_t i : open) readers[i]->Finish();
  std::cout << "threads: baseline " << baseline << ", peak " << peak << " with " << kAttempts << " stream attempts\n";
  // 64 streams + 32 unary + pollers (server.cpp's resource quota), plus the
  // test's own threads: not one per attempt.
  EXPECT_LT(peak.load(), baseline + 64 + 32 + 16);
}

// The audit log's id of a token: the top 32 bits of its FNV-1a hash, in hex.
std::string services_token_id() {
  files::Fnv1a hash;
  hash.add(kToken, std::strlen(kToken));
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(hash.h >> 32));
  return hex;
}

std::vector<nlohmann::json> audit_lines(const std::filesystem::path& sessions_dir) {
  std::vector<nlohmann::json> lines;
  std::ifstream in(sessions_dir / "audit.jsonl");
  for (std::string line; std::getline(in, line);) lines.push_back(nlohmann::json::parse(line));
  return lines;
}

TEST_F(ApiFixture, ASessionIsDeletedWithItsOwnCacheEntriesAndTheAuditLogSaysWho) {
  lab.config.estimation.cache_dir = (lab.directory / "cache").string();
  start();
  auto sessions = pb::SessionService::NewStub(channel);
  auto remove = [&](const std::string& id, pb::DeleteSessionResponse* response) {
    grpc::ClientContext context;
    return sessions->DeleteSession(&context, [&] {
      pb::DeleteSessionRequest request;
      request.set_id(id);
      return request;
    }(), response);
  };
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(1000);
  pb::Operation started;
  ASSERT_TRUE(start_session(*channel, request, &started).ok());
  pb::DeleteSessionResponse response;
  // Refused while it runs; nothing removed.
  grpc::Status status = remove(started.id(), &response);
  EXPECT_EQ(status.error_code(), StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_THAT(status.error_message(), ::testing::HasSubstr("cancel it first"));
  ASSERT_EQ(watch_to_end(started.id()).state(), pb::OPERATION_STATE_SUCCEEDED);
  const auto folder = lab.config.sessions_dir / started.id();
  ASSERT_TRUE(std::filesystem::exists(folder / "session.json"));
  // Its table (named by its results) and another session's.
  std::filesystem::create_directories(folder / "results");
  std::filesystem::create_directories(lab.directory / "cache");
  // Its forward table aa and inverse table cc, named as a several-camera
  // session names them (an index without a top-level table; each camera's
  // own summary.json, a folder that is no plain name not followed); the
  // other session's bb and dd stay.
  std::filesystem::create_directories(folder / "results" / "cam0");
  std::ofstream(folder / "results" / "summary.json")
      << R"({"cameras": [{"name": "cam0", "state": "ok", "folder": "cam0"}, {"name": "cam1", "state": "failed"},
                         {"name": "x", "state": "ok", "folder": "../../other/results"}, {"folder": 7}]})";
  std::ofstream(folder / "results" / "cam0" / "summary.json")
      << R"({"table": {"key": "00000000000000aa", "inverse_key": "00000000000000cc"}})";
  std::filesystem::create_directories(lab.config.sessions_dir / "other" / "results");
  std::ofstream(lab.config.sessions_dir / "other" / "results" / "summary.json")
      << R"({"table": {"key": "00000000000000bb", "inverse_key": "00000000000000dd"}})";
  for (const char* name : {"forward_table_00000000000000aa.bin", "forward_table_00000000000000bb.bin",
                           "inverse_table_00000000000000cc.bin", "inverse_table_00000000000000dd.bin"})
    std::ofstream(lab.directory / "cache" / name) << "table";
  for (const char* hostile : {"..", ".", "../sessions", ""}) {
    status = remove(hostile, &response);
    EXPECT_EQ(status.error_code(), StatusCode::INVALID_ARGUMENT) << hostile;
    EXPECT_THAT(status.error_message(), ::testing::StartsWith("id: ")) << hostile;
  }
  EXPECT_EQ(remove("20260101T000000Z-none-000000", &response).error_code(), StatusCode::NOT_FOUND);
  status = remove(started.id(), &response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GE(response.files_removed(), 9u);  // session.json, journal, 7 frames, ...
  EXPECT_GT(response.bytes_removed(), 7u * 160 * 120 * 2);
  ASSERT_EQ(response.cache_entries_removed_size(), 2);
  EXPECT_EQ(response.cache_entries_removed(0), "forward_table_00000000000000aa.bin");
  EXPECT_EQ(response.cache_entries_removed(1), "inverse_table_00000000000000cc.bin");
  EXPECT_FALSE(std::filesystem::exists(lab.directory / "cache" / "inverse_table_00000000000000cc.bin"));
  EXPECT_TRUE(std::filesystem::exists(lab.directory / "cache" / "inverse_table_00000000000000dd.bin"));
  EXPECT_FALSE(std::filesystem::exists(folder));
  EXPECT_FALSE(std::filesystem::exists(lab.directory / "cache" / "forward_table_00000000000000aa.bin"));
  EXPECT_TRUE(std::filesystem::exists(lab.directory / "cache" / "forward_table_00000000000000bb.bin"));
  EXPECT_TRUE(std::filesystem::exists(lab.config.sessions_dir / "other" / "results" / "summary.json"));
  {
    grpc::ClientContext context;
    pb::GetSessionRequest get;
    get.set_id(started.id());
    pb::SessionDetail detail;
    EXPECT_EQ(sessions->GetSession(&context, get, &detail).error_code(), StatusCode::NOT_FOUND);
  }
  EXPECT_EQ(remove(started.id(), &response).error_code(), StatusCode::NOT_FOUND);
  // Over TCP: the token's id, never the token.
  auto tcp = grpc::CreateChannel("127.0.0.1:" + std::to_string(server->tcp_port()), grpc::InsecureChannelCredentials());
  {
    grpc::ClientContext context;
    context.AddMetadata("authorization", std::string("Bearer ") + kToken);
    pb::CancelOperationRequest cancel;
    cancel.set_id(started.id());
    pb::Operation out;
    EXPECT_EQ(pb::OperationService::NewStub(tcp)->CancelOperation(&context, cancel, &out).error_code(), StatusCode::NOT_FOUND);
  }
  const auto lines = audit_lines(lab.config.sessions_dir);
  const std::string uid = "uid:" + std::to_string(::getuid());
  std::vector<std::string> seen;
  for (const auto& line : lines) seen.push_back(line["action"].get<std::string>() + " " + line["who"].get<std::string>() + " " + line["outcome"].get<std::string>());
  const std::vector<std::string> expected{
      "start_session " + uid + " ok", "delete_session " + uid + " refused", "delete_session " + uid + " refused",
      "delete_session " + uid + " refused", "delete_session " + uid + " refused", "delete_session " + uid + " refused",
      "delete_session " + uid + " refused", "delete_session " + uid + " ok", "delete_session " + uid + " refused",
      "cancel token:" + services_token_id() + " refused"};
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(lines[0]["session"], started.id());
  EXPECT_EQ(lines[7]["session"], started.id());
  EXPECT_EQ(lines[7]["cache_entries_removed"][0], "forward_table_00000000000000aa.bin");
  std::ifstream raw(lab.config.sessions_dir / "audit.jsonl");
  const std::string text((std::istreambuf_iterator<char>(raw)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find(kToken), std::string::npos);
}

TEST_F(ApiFixture, HealthServiceAnswersServing) {
  start();
  grpc::GenericStub generic(channel);
  grpc::ClientContext context;
  grpc::Slice empty("");  // HealthCheckRequest{service: ""} encodes to no bytes
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&](grpc::Status status) { done.set_value(status); });
  ASSERT_TRUE(done.get_future().get().ok());
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const auto& s : slices) bytes += std::string(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_EQ(bytes, std::string("\x08\x01", 2));  // status: SERVING
}

TEST_F(ApiFixture, EventStreamCarriesOperationUpdates) {
  start();
  auto events = pb::EventService::NewStub(channel);
  grpc::ClientContext context;
  pb::SubscribeRequest subscribe;
  subscribe.set_include_frames(true);
  auto reader = events->Subscribe(&context, subscribe);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(1000);
  pb::Operation started;
  ASSERT_TRUE(start_session(*channel, request, &started).ok());
  int frames = 0;
  bool ended = false;
  pb::Event event;
  while (!ended && reader->Read(&event)) {
    if (event.has_frame()) ++frames;
    if (event.has_operation() && event.operation().state() == pb::OPERATION_STATE_SUCCEEDED) ended = true;
  }
  context.TryCancel();
  EXPECT_TRUE(ended);
  EXPECT_EQ(frames, 19);  // 4 frames of the dark and each of 3 whites (capture.reference_frames), 1 of each subject
}

TEST_F(ApiFixture, CalibrationRunAndMixSolveOverTheApi) {
  start();
  auto calibration = pb::CalibrationService::NewStub(channel);
  {  // No library yet: the solver cannot run.
    grpc::ClientContext context;
    pb::SolveMixRequest solve;
    solve.set_target("d65");
    pb::SolveMixResponse response;
    EXPECT_EQ(calibration->SolveMix(&context, solve, &response).error_code(), StatusCode::FAILED_PRECONDITION);
  }
  {  // Nor is there a library to plot.
    grpc::ClientContext context;
    pb::GetLedLibraryResponse library;
    EXPECT_EQ(calibration->GetLedLibrary(&context, pb::GetLedLibraryRequest{}, &library).error_code(),
              StatusCode::FAILED_PRECONDITION);
  }
  {  // Invalid requests name the field and start nothing.
    grpc::ClientContext c1, c2;
    pb::StartCalibrationRequest bad;
    bad.add_drive_levels(0.5);
    bad.add_drive_levels(1.5);
    pb::Operation out;
    auto status = calibration->StartCalibration(&c1, bad, &out);
    EXPECT_EQ(status.error_code(), StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("drive_levels[1]"), std::string::npos) << status.error_message();
    bad.clear_drive_levels();
    bad.set_warmup_ms(700000);
    status = calibration->StartCalibration(&c2, bad, &out);
    EXPECT_EQ(status.error_code(), StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("warmup_ms"), std::string::npos) << status.error_message();
  }
  grpc::ClientContext context;
  pb::StartCalibrationRequest request;
  request.add_drive_levels(0.5);
  request.add_drive_levels(1.0);
  request.set_warmup_ms(100);
  pb::Operation started;
  ASSERT_TRUE(calibration->StartCalibration(&context, request, &started).ok());
  EXPECT_EQ(started.kind(), pb::OPERATION_KIND_CALIBRATION);
  auto final = watch_to_end(started.id());
  ASSERT_EQ(final.state(), pb::OPERATION_STATE_SUCCEEDED) << final.error();
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(final.folder()) / "led-library.json"));

  grpc::ClientContext solve_context;
  pb::SolveMixRequest solve;
  solve.set_target("w57+blue");
  solve.set_objective(pb::MIX_OBJECTIVE_SPECTRAL);
  pb::SolveMixResponse solved;
  auto status = calibration->SolveMix(&solve_context, solve, &solved);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_GT(solved.weights().w57(), 0.0);
  EXPECT_GT(solved.weights().blue(), 0.0);
  EXPECT_EQ(solved.library(), (std::filesystem::path(final.folder()) / "led-library.json").string());
  EXPECT_TRUE(solved.figures().contains("rmse"));
  EXPECT_FALSE(solved.summary().empty());
  {  // The measured library for plotting: six LED types on the grid, the solved
     // W57+blue mix puts its power where W57 and blue have theirs.
    grpc::ClientContext library_context;
    pb::GetLedLibraryResponse library;
    ASSERT_TRUE(calibration->GetLedLibrary(&library_context, pb::GetLedLibraryRequest{}, &library).ok());
    EXPECT_EQ(library.library(), solved.library());
    EXPECT_EQ(library.source(), "measured");
    ASSERT_EQ(library.wavelength_nm_size(), 81);
    EXPECT_EQ(library.wavelength_nm(0), 380.0);
    EXPECT_EQ(library.wavelength_nm(80), 780.0);
    ASSERT_EQ(library.d65_size(), 81);
    EXPECT_NEAR(library.d65(36), 100.0, 1.0);  // 560 nm
    ASSERT_EQ(library.leds_size(), 6);
    const std::vector<std::string> names = {"W57", "W40", "W27", "R", "G", "B"};
    for (int i = 0; i < 6; ++i) {
      const auto& led = library.leds(i);
      EXPECT_EQ(led.led(), names[i]);
      ASSERT_EQ(led.spectrum_per_unit_drive_size(), 81);
      EXPECT_EQ(led.drive_levels_size(), 2) << led.led();  // the ladder asked for: 0.5, 1
      EXPECT_GT(*std::max_element(led.spectrum_per_unit_drive().begin(), led.spectrum_per_unit_drive().end()), 0.0);
    }
    const auto peak_nm = [&](int led) {
      const auto& s = library.leds(led).spectrum_per_unit_drive();
      return library.wavelength_nm(static_cast<int>(std::max_element(s.begin(), s.end()) - s.begin()));
    };
    EXPECT_LT(peak_nm(5), 490.0);  // blue
    EXPECT_GT(peak_nm(3), 600.0);  // red
  }
  grpc::ClientContext bad_context;
  solve.set_target("/etc/passwd.csv");
  auto refused = calibration->SolveMix(&bad_context, solve, &solved);
  EXPECT_EQ(refused.error_code(), StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(refused.error_message().find("target"), std::string::npos);
}

// A client of gRPC's server reflection protocol (ServerReflectionInfo, a
// bidirectional stream). Debian ships no reflection client, grpc_cli or
// reflection .proto; the message types are the ones libgrpc++_reflection
// registered in protobuf's generated pool (the server's own definitions),
// used through protobuf reflection, and the call is a generic stream.
class ReflectionClient {
 public:
  explicit ReflectionClient(std::shared_ptr<grpc::Channel> channel) : stub_(std::move(channel)) {
    const auto* pool = google::protobuf::DescriptorPool::generated_pool();
    request_type_ = pool->FindMessageTypeByName("grpc.reflection.v1alpha.ServerReflectionRequest");
    response_type_ = pool->FindMessageTypeByName("grpc.reflection.v1alpha.ServerReflectionResponse");
    if (!request_type_ || !response_type_) throw std::runtime_error("reflection messages not in the generated pool");
    call_ = stub_.PrepareCall(&context_, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &queue_);
    call_->StartCall(this);
    wait();
  }
  ~ReflectionClient() {
    call_->WritesDone(this);
    wait();
    grpc::Status status;
    call_->Finish(&status, this);
    wait();
  }
  // Sends a request with one string field set; returns the response.
  std::unique_ptr<google::protobuf::Message> ask(const std::string& field, const std::string& value) {
    std::unique_ptr<google::protobuf::Message> request(factory_.GetPrototype(request_type_)->New());
    request->GetReflection()->SetString(request.get(), request_type_->FindFieldByName(field), value);
    std::string bytes;
    request->SerializeToString(&bytes);
    grpc::Slice slice(bytes);
    grpc::ByteBuffer out(&slice, 1), in;
    call_->Write(out, this);
    if (!wait()) throw std::runtime_error("reflection: write failed");
    call_->Read(&in, this);
    if (!wait()) throw std::runtime_error("reflection: the stream ended");
    std::vector<grpc::Slice> slices;
    (void)in.Dump(&slices);
    std::string answer;
    for (const auto& s : slices) answer += std::string(reinterpret_cast<const char*>(s.begin()), s.size());
    std::unique_ptr<google::protobuf::Message> response(factory_.GetPrototype(response_type_)->New());
    if (!response->ParseFromString(answer)) throw std::runtime_error("reflection: unparsable response");
    return response;
  }
  // The message-typed field `name` of `message` (reflection), or null when unset.
  static const google::protobuf::Message* field(const google::protobuf::Message& message, const std::string& name) {
    const auto* descriptor = message.GetDescriptor()->FindFieldByName(name);
    if (!descriptor || !message.GetReflection()->HasField(message, descriptor)) return nullptr;
    return &message.GetReflection()->GetMessage(message, descriptor);
  }

 private:
  bool wait() {
    void* tag = nullptr;
    bool ok = false;
    return queue_.Next(&tag, &ok) && ok;
  }
  grpc::GenericStub stub_;
  grpc::ClientContext context_;
  grpc::CompletionQueue queue_;
  std::unique_ptr<grpc::GenericClientAsyncReaderWriter> call_;
  google::protobuf::DynamicMessageFactory factory_;
  const google::protobuf::Descriptor* request_type_ = nullptr;
  const google::protobuf::Descriptor* response_type_ = nullptr;
};

TEST_F(ApiFixture, ReflectionListsTheServicesAndServesTheirSchema) {
  start();
  ReflectionClient client(channel);
  using Message = google::protobuf::Message;
  auto listed = client.ask("list_services", "");
  const Message* list = ReflectionClient::field(*listed, "list_services_response");
  ASSERT_NE(list, nullptr) << listed->DebugString();
  std::set<std::string> services;
  const auto* service_field = list->GetDescriptor()->FindFieldByName("service");
  for (int i = 0; i < list->GetReflection()->FieldSize(*list, service_field); ++i) {
    const Message& service = list->GetReflection()->GetRepeatedMessage(*list, service_field, i);
    services.insert(service.GetReflection()->GetString(service, service.GetDescriptor()->FindFieldByName("name")));
  }
  for (const char* name : {"chromosphere.v1.SessionService", "chromosphere.v1.CalibrationService",
                           "chromosphere.v1.OperationService", "chromosphere.v1.LedService",
                           "chromosphere.v1.DeviceService", "chromosphere.v1.EventService",
                           "chromosphere.v1.ResultsService", "grpc.health.v1.Health"})
    EXPECT_TRUE(services.count(name)) << name << " not listed";

  // The file declaring a service comes back as a FileDescriptorProto.
  auto described = client.ask("file_containing_symbol", "chromosphere.v1.SessionService");
  const Message* files = ReflectionClient::field(*described, "file_descriptor_response");
  ASSERT_NE(files, nullptr) << described->DebugString();
  const auto* bytes_field = files->GetDescriptor()->FindFieldByName("file_descriptor_proto");
  ASSERT_GT(files->GetReflection()->FieldSize(*files, bytes_field), 0);
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(file.ParseFromString(files->GetReflection()->GetRepeatedString(*files, bytes_field, 0)));
  EXPECT_EQ(file.name(), "chromosphere/v1/sessions.proto");
  EXPECT_EQ(file.package(), "chromosphere.v1");
  bool found = false;
  for (const auto& service : file.service()) found = found || service.name() == "SessionService";
  EXPECT_TRUE(found);

  // An unknown symbol: an error response, NOT_FOUND.
  auto unknown = client.ask("file_containing_symbol", "no.such.Service");
  const Message* error = ReflectionClient::field(*unknown, "error_response");
  ASSERT_NE(error, nullptr) << unknown->DebugString();
  EXPECT_EQ(error->GetReflection()->GetInt32(*error, error->GetDescriptor()->FindFieldByName("error_code")),
            static_cast<int>(StatusCode::NOT_FOUND));
}

}  // namespace
}  // namespace chromo::daemon
