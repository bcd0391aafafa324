// chromod's counters as Prometheus text (metrics.hpp, docs/observability.md).
#include "chromo/daemon/internal/api/metrics.hpp"

#include <fmt/format.h>
#include <google/protobuf/util/time_util.h>

#include "chromosphere/v1/cameras.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"

namespace chromo::daemon::web {
namespace {

namespace pb = chromosphere::v1;

// A label value with Prometheus' escapes (backslash, double quote, newline).
std::string label(const std::string& value) {
  std::string out;
  for (const char c : value) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

// One metric family: its HELP and TYPE lines, then its samples.
struct Family {
  std::string text;
  Family(const std::string& name, const std::string& type, const std::string& help) {
    text = fmt::format("# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
    this->name = name;
  }
  void sample(const std::string& labels, double value) {
    text += labels.empty() ? fmt::format("{} {}\n", name, value) : fmt::format("{}{{{}}} {}\n", name, labels, value);
  }
  std::string name;
};

std::string state_name(pb::OperationState state) {
  std::string name = pb::OperationState_Name(state);
  name = name.substr(std::string("OPERATION_STATE_").size());
  for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

void camera_families(const pb::ListCamerasResponse& cameras, std::string& out) {
  using Field = std::uint64_t (pb::CameraStreamCounters::*)() const;
  const struct {
    const char* name;
    Field field;
    const char* help;
  } counters[] = {
      {"chromo_camera_frames_completed_total", &pb::CameraStreamCounters::completed, "Frames the camera delivered whole."},
      {"chromo_camera_frames_failed_total", &pb::CameraStreamCounters::failed, "Frames delivered with a failure status."},
      {"chromo_camera_frames_lost_total", &pb::CameraStreamCounters::lost_before_driver,
       "Frames of which no packet arrived (gaps in the camera's frame ids)."},
      {"chromo_camera_resend_requests_total", &pb::CameraStreamCounters::resend_requests, "Packets asked for again."},
      {"chromo_camera_resent_packets_total", &pb::CameraStreamCounters::resent_packets, "Packets resent that arrived."},
      {"chromo_camera_missing_packets_total", &pb::CameraStreamCounters::missing_packets, "Packets never received."},
      {"chromo_camera_reconnects_total", &pb::CameraStreamCounters::reconnects, "Reconnections after a lost link."},
  };
  Family up("chromo_camera_up", "gauge", "1 when the camera is open and answers, 0 otherwise.");
  for (const auto& camera : cameras.cameras())
    up.sample(fmt::format("camera=\"{}\"", label(camera.name())), camera.error().empty() ? 1 : 0);
  out += up.text;
  for (const auto& counter : counters) {
    Family family(counter.name, "counter", std::string(counter.help) + " Since chromod opened the camera.");
    for (const auto& camera : cameras.cameras())
      family.sample(fmt::format("camera=\"{}\"", label(camera.name())),
                    static_cast<double>((camera.stream().*counter.field)()));
    out += family.text;
  }
}

void session_families(const pb::ListOperationsResponse& sessions, std::chrono::system_clock::time_point now,
                      std::string& out) {
  using Field = std::uint64_t (pb::FrameCounters::*)() const;
  const struct {
    const char* name;
    const char* type;
    Field field;
    const char* help;
  } counters[] = {
      {"chromo_session_frames_expected", "gauge", &pb::FrameCounters::expected, "Frames the session's plan asks for."},
      {"chromo_session_frames_received_total", "counter", &pb::FrameCounters::received,
       "Frames the cameras delivered with a complete image."},
      {"chromo_session_frames_stored_total", "counter", &pb::FrameCounters::stored,
       "Frames stored (journal entry fsynced)."},
      {"chromo_session_frames_lost_total", "counter", &pb::FrameCounters::lost, "Frames lost by the camera link."},
      {"chromo_session_resent_packets_total", "counter", &pb::FrameCounters::resent_packets,
       "Packets the cameras resent during the session."},
      {"chromo_session_frames_estimated_total", "counter", &pb::FrameCounters::estimated,
       "Frames the on-line estimator consumed."},
      {"chromo_session_frames_estimator_skipped_total", "counter", &pb::FrameCounters::estimator_skipped,
       "Frames the on-line estimator skipped (read back from storage later)."},
      {"chromo_session_estimator_read_back_total", "counter", &pb::FrameCounters::estimator_read_back,
       "Skipped frames the estimator read back from storage."},
      {"chromo_session_estimator_queue_depth", "gauge", &pb::FrameCounters::estimator_queue_depth,
       "Frames waiting for the on-line estimator now."},
      {"chromo_session_estimator_queue_depth_max", "gauge", &pb::FrameCounters::max_estimator_queue_depth,
       "The most frames that waited for the estimator in this session."},
  };
  auto labels = [](const pb::Operation& session) {
    return fmt::format("session=\"{}\",state=\"{}\"", label(session.id()), state_name(session.state()));
  };
  int running = 0;
  for (const auto& session : sessions.operations()) running += session.state() == pb::OPERATION_STATE_RUNNING;
  Family active("chromo_sessions_running", "gauge", "Sessions running now.");
  active.sample("", running);
  out += active.text;
  for (const auto& counter : counters) {
    Family family(counter.name, counter.type, counter.help);
    for (const auto& session : sessions.operations())
      family.sample(labels(session), static_cast<double>((session.counters().*counter.field)()));
    out += family.text;
  }
  Family throughput("chromo_session_estimator_frames_per_second", "gauge",
                    "Frames the on-line estimator consumed per second of the session (created to last update, or now while running).");
  for (const auto& session : sessions.operations()) {
    using google::protobuf::util::TimeUtil;
    const auto created = TimeUtil::TimestampToMilliseconds(session.created());
    const auto until = session.state() == pb::OPERATION_STATE_RUNNING
                           ? std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count()
                           : TimeUtil::TimestampToMilliseconds(session.updated());
    const double seconds = static_cast<double>(until - created) / 1000.0;
    throughput.sample(labels(session), seconds > 0 ? static_cast<double>(session.counters().estimated()) / seconds : 0);
  }
  out += throughput.text;
}

}  // namespace

std::string prometheus_text(const pb::ListCamerasResponse& cameras, const pb::ListOperationsResponse& sessions,
                            std::chrono::system_clock::time_point now) {
  std::string text;
  camera_families(cameras, text);
  session_families(sessions, now, text);
  return text;
}

std::string collect_metrics(const std::shared_ptr<grpc::Channel>& channel, const std::string& token) {
  auto context = [&token] {
    auto c = std::make_unique<grpc::ClientContext>();
    c->AddMetadata("authorization", "Bearer " + token);
    c->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    return c;
  };
  pb::ListCamerasResponse cameras;
  if (auto status = pb::CameraService::NewStub(channel)->ListCameras(context().get(), {}, &cameras); !status.ok())
    throw std::runtime_error("ListCameras: " + status.error_message());
  pb::ListOperationsRequest request;
  request.set_kind(pb::OPERATION_KIND_SESSION);
  request.set_limit(kMetricsSessions);
  pb::ListOperationsResponse sessions;
  if (auto status = pb::OperationService::NewStub(channel)->ListOperations(context().get(), request, &sessions); !status.ok())
    throw std::runtime_error("ListOperations: " + status.error_message());
  return prometheus_text(cameras, sessions, std::chrono::system_clock::now());
}

}  // namespace chromo::daemon::web
