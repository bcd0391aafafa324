// chromo session run|watch|list|show|cancel|pause|resume|delete: capture sessions on chromod.
#include <unistd.h>

#include <algorithm>
#include <optional>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <google/protobuf/util/time_util.h>

#include "chromo/proto/plan_messages.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "chromosphere/v1/sessions.grpc.pb.h"
#include "commands.hpp"
#include "plan_advice.hpp"
#include "chromo/session/session_plan.hpp"
#include "daemon_client.hpp"
#include "provenance_text.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

namespace {

struct SessionOptions {
  DaemonAddress address;
  std::string plan_file, subject, name, id, operator_name, study, override_reason;
  bool preflight = false;
  std::string polarised = "auto";  // --polarised: auto (the daemon's capture.polarised_plan), on, off
  bool hardware = false, prompts = false, detach = false, frames = false;
  double exposure_us = 0;
  unsigned frames_per_camera = 0;
  unsigned reference_frames = 0;
  double subject_fill = 0;
};


void run(SessionOptions& options, int& exit_status) {
  DaemonConnection daemon(options.address);
  pb::StartSessionRequest request;
  if (!options.plan_file.empty()) {
    // A built-in plan by name (the standard-plan options apply), else a plan file.
    session::StandardPlanOptions builtin_options;
    builtin_options.timing = options.hardware ? session::Timing::kHardware : session::Timing::kSoftware;
    if (options.exposure_us > 0) builtin_options.exposure_us = options.exposure_us;
    if (options.frames_per_camera > 0) builtin_options.frames_per_camera = options.frames_per_camera;
    if (options.reference_frames > 0) builtin_options.reference_frames = options.reference_frames;
    if (options.subject_fill > 0) builtin_options.subject_fill = options.subject_fill;
    builtin_options.operator_prompts = options.prompts;
    std::optional<session::SessionPlan> plan = session::builtin_plan(options.plan_file, builtin_options);
    if (!plan) {
      try {
        plan = session::read_plan_file(options.plan_file);
      } catch (const std::invalid_argument& error) {
        std::cerr << "chromo: --plan " << error.what() << "\n";
        exit_status = kExitBadInput;
        return;
      }
    }
    proto::to_proto(*plan, request.mutable_plan());
  } else {
    request.set_standard(true);
    request.set_timing(options.hardware ? pb::TIMING_HARDWARE : pb::TIMING_SOFTWARE);
    request.set_exposure_us(options.exposure_us);
    request.set_frames_per_camera(options.frames_per_camera);
    request.set_reference_frames(options.reference_frames);
    request.set_subject_fill(options.subject_fill);
    request.set_operator_prompts(options.prompts);
    request.set_polarised(options.polarised == "on"    ? pb::POLARISED_PLAN_ON
                          : options.polarised == "off" ? pb::POLARISED_PLAN_OFF
                                                       : pb::POLARISED_PLAN_CONFIGURED);
  }
  request.set_subject(options.subject);
  request.set_operator_name(options.operator_name);
  request.set_study(options.study);
  request.set_preflight(options.preflight || !options.override_reason.empty());
  request.set_preflight_override_reason(options.override_reason);
  request.set_name(options.name);
  pb::Operation started;
  auto status = pb::SessionService::NewStub(daemon.channel())->StartSession(daemon.context().get(), request, &started);
  if (!status.ok()) {
    exit_status = report_failure("session run", status);
    return;
  }
  std::cout << "session " << started.id() << " started\n";
  if (options.detach) return;
  exit_status = watch_operation(daemon, started.id());
}

template <typename Request, typename Call>
void control(SessionOptions& options, int& exit_status, const char* verb, Call call) {
  DaemonConnection daemon(options.address);
  Request request;
  request.set_id(options.id);
  pb::Operation operation;
  auto stub = pb::OperationService::NewStub(daemon.channel());
  auto status = call(*stub, daemon.context().get(), request, &operation);
  if (!status.ok()) {
    exit_status = report_failure(std::string("session ") + verb, status);
    return;
  }
  std::cout << operation.id() << "  " << progress_line(operation) << "\n";
}

void show(SessionOptions& options, int& exit_status) {
  DaemonConnection daemon(options.address);
  pb::GetSessionRequest request;
  request.set_id(options.id);
  request.set_include_frames(options.frames);
  pb::SessionDetail detail;
  auto status = pb::SessionService::NewStub(daemon.channel())->GetSession(daemon.context().get(), request, &detail);
  if (!status.ok()) {
    exit_status = report_failure("session show", status);
    return;
  }
  const auto& operation = detail.summary().operation();
  std::cout << fmt::format("session {}  ({})\nstate    {}{}\nsubject  {}\nfolder   {}\n", detail.summary().id(),
                           detail.summary().name(), state_text(operation.state()),
                           operation.error().empty() ? (operation.message().empty() ? "" : ": " + operation.message())
                                                     : ": " + operation.error(),
                           detail.subject(), detail.summary().folder());
  std::cout << provenance_text(detail.provenance());
  std::cout << fmt::format("frames   {} stored, {} lost\nsteps:\n", operation.counters().stored(), operation.counters().lost());
  for (const auto& step : detail.steps())
    std::cout << fmt::format("  {:2} {:<20} {:<8} {:>4} frames  {}\n", step.index(), step.name(),
                             pb::StepRole_Name(step.role()).substr(std::string("STEP_ROLE_").size()), step.frames_stored(),
                             step.completed() ? "completed" : "not completed");
  // Where the time went (journal record times; "-" for a phase not reached).
  const auto& timeline = detail.timeline();
  auto seconds = [](double s) { return s < 0 ? std::string("-") : fmt::format("{:.1f} s", s); };
  std::cout << fmt::format("timeline capture {} (subject {}), then derived data {} and maps {} after the last frame; "
                           "total {}\n",
                           seconds(timeline.capture_s()), seconds(timeline.subject_s()), seconds(timeline.derived_s()),
                           seconds(timeline.estimation_s()), seconds(timeline.total_s()));
  for (const auto& frame : detail.frames())
    std::cout << fmt::format("  frame {:4} {:<18} {:<6} seq {:<5} {} exposure {} us\n", frame.index(), frame.step(),
                             frame.camera(), frame.sequence(), frame.file(), frame.exposure_us());
}

// `chromo session plans`: the built-in plans, then plan files (FILE
// arguments, and every *.json in --plan-dir), with their capture count,
// the estimator's channels, the capture time (subject: first to last subject
// exposure; references apart), the predicted accuracy when the plan
// advisor provides one and the planned blue-light hazard dose (plan_advice.hpp). A bad plan file: its field named,
// exit 2, nothing else printed.
void list_plans(const std::vector<std::string>& files, const std::string& plan_dir, int& exit_status) {
  std::vector<std::pair<std::string, session::SessionPlan>> plans;
  for (const std::string& name : session::builtin_plan_names()) plans.emplace_back("built-in", *session::builtin_plan(name));
  std::vector<std::string> paths = files;
  if (!plan_dir.empty()) {
    std::error_code ec;
    if (!std::filesystem::is_directory(plan_dir, ec)) {
      std::cerr << "chromo: session plans: --plan-dir " << plan_dir << ": not a directory\n";
      exit_status = kExitBadInput;
      return;
    }
    std::vector<std::string> found;
    for (const auto& entry : std::filesystem::directory_iterator(plan_dir))
      if (entry.path().extension() == ".json") found.push_back(entry.path().string());
    std::sort(found.begin(), found.end());
    paths.insert(paths.end(), found.begin(), found.end());
  }
  for (const std::string& path : paths) {
    try {
      plans.emplace_back(path, session::read_plan_file(path));
    } catch (const std::invalid_argument& error) {
      std::cerr << "chromo: session plans: " << error.what() << "\n";
      exit_status = kExitBadInput;
      return;
    }
  }
  std::cout << fmt::format("{:<24} {:>8} {:>8} {:>10} {:>12} {:>7} {:>10} {:>12}  {}\n", "plan", "captures", "channels",
                           "subject_s", "references_s", "frames", "pred_dE94", "blue_dose", "source");
  for (const auto& [source, plan] : plans) {
    const session::PlanTiming t = session::plan_timing(plan);
    // Both predictions solve the plan's mixes from the lab's library; a mix
    // the solver reports unusable leaves them "-", with the reason below.
    std::string predicted = "-", dose = "-", note;
    try {
      if (const auto delta_e = predicted_relit_delta_e94(plan)) predicted = fmt::format("{:.2f}", *delta_e);
      const session::PlanHazard hazard = planned_blue_light_hazard(plan);
      dose = fmt::format("{:.4g}", hazard.dose_J_per_m2_sr);
      if (!hazard.within_limit()) note = "\n  beyond the default blue-light limit: chromod refuses it";
    } catch (const std::invalid_argument& error) {
      note = std::string("\n  no prediction: ") + error.what();
    }
    std::cout << fmt::format("{:<24} {:>8} {:>8} {:>10.2f} {:>12.2f} {:>7} {:>10} {:>12}  {}{}\n", plan.name,
                             t.captures, t.channels, t.subject_time_s, t.reference_time_s, t.frames_per_camera,
                             predicted, dose, source, note);
  }
  std::cout << fmt::format("blue_dose: IEC 62471 blue-light L_B*t for the subject's eyes, J/(m2 sr), planned exposures, "
                           "chromod's default scale (hazard.* in docs/config.md); limit {:.4g}\n",
                           session::BlueLightHazardOptions{}.limit_J_per_m2_sr);
}

}  // namespace

// Streams the operation to its end with a live progress line (redrawn in
// place on a terminal, one line per change otherwise). Exit 0 only on success.
int watch_operation(const DaemonConnection& daemon, const std::string& id) {
  auto context = daemon.context(true);
  pb::WatchOperationRequest request;
  request.set_id(id);
  auto reader = pb::OperationService::NewStub(daemon.channel())->WatchOperation(context.get(), request);
  const bool terminal = ::isatty(STDOUT_FILENO);
  pb::Operation operation, last;
  std::string previous;
  while (reader->Read(&operation)) {
    last = operation;
    std::string line = progress_line(operation);
    if (line == previous) continue;
    previous = line;
    if (terminal)
      std::cout << "\r\033[K" << line << std::flush;
    else
      std::cout << line << "\n";
  }
  if (terminal) std::cout << "\n";
  auto status = reader->Finish();
  if (!status.ok()) return report_failure("watch " + id, status);
  const bool calibration = last.kind() == pb::OPERATION_KIND_CALIBRATION;
  std::cout << fmt::format("{} {} {}", calibration ? "calibration" : "session", last.id(), state_text(last.state()));
  if (!last.error().empty()) std::cout << ": " << last.error();
  if (calibration) {
    std::cout << fmt::format("\n{}\nfolder: {}\n", last.message(), last.folder());
    return last.state() == pb::OPERATION_STATE_SUCCEEDED ? kExitOk : kExitFailure;
  }
  std::cout << fmt::format("\nframes: {} stored, {} lost, {} estimated, {} skipped by the estimator\nfolder: {}\n",
                           last.counters().stored(), last.counters().lost(), last.counters().estimated(),
                           last.counters().estimator_skipped(), last.folder());
  for (const auto& [reason, count] : last.counters().lost_reasons()) std::cout << "  lost (" << reason << "): " << count << "\n";
  return last.state() == pb::OPERATION_STATE_SUCCEEDED ? kExitOk : kExitFailure;
}

namespace {

// `session list`: one line per session known to the daemon, newest first.
void list_sessions(const SessionOptions& options, int& exit_status) {
  DaemonConnection daemon(options.address);
  pb::ListSessionsResponse response;
  auto status = pb::SessionService::NewStub(daemon.channel())->ListSessions(daemon.context().get(), {}, &response);
  if (!status.ok()) {
    exit_status = report_failure("session list", status);
    return;
  }
  // One line per session; subject and study (cut at 24 characters) tell them apart.
  auto cell = [](const std::string& text) {
    if (text.empty()) return std::string("-");
    if (text.size() <= 24) return text;
    std::size_t cut = 23;
    while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // not inside a UTF-8 character
    return text.substr(0, cut) + "…";
  };
  std::cout << fmt::format("{:<40} {:<12} {:>6}  {:<24} {:<24} {:<24} {}\n", "id", "state", "frames", "subject",
                           "study", "operator", "folder");
  for (const auto& s : response.sessions())
    std::cout << fmt::format("{:<40} {:<12} {:>6}  {:<24} {:<24} {:<24} {}\n", s.id(),
                             state_text(s.operation().state()), s.operation().counters().stored(), cell(s.subject()),
                             cell(s.study()), cell(s.operator_name()), s.folder());
}

// `session delete`: a finished session's folder and the cache entries only it used.
void delete_session(const SessionOptions& options, int& exit_status) {
  DaemonConnection daemon(options.address);
  pb::DeleteSessionRequest request;
  request.set_id(options.id);
  pb::DeleteSessionResponse response;
  auto status = pb::SessionService::NewStub(daemon.channel())->DeleteSession(daemon.context().get(), request, &response);
  if (!status.ok()) {
    exit_status = report_failure("session delete", status);
    return;
  }
  std::cout << fmt::format("session {} deleted: {} files, {} bytes", response.id(), response.files_removed(),
                           response.bytes_removed());
  for (const auto& entry : response.cache_entries_removed()) std::cout << ", cache " << entry;
  std::cout << "\n";
}

// `session run` and its options (the standard plan's unless --plan).
void add_run_command(CLI::App& session, const std::shared_ptr<SessionOptions>& options, int& exit_status) {
  auto* run_command = session.add_subcommand("run", "start a session (the standard one unless --plan) and follow it");
  add_daemon_options(*run_command, options->address);
  run_command->add_option("--plan", options->plan_file, "a built-in plan (standard, multispectral, multispectral+method; see `chromo session plans`) or a plan file (JSON, docs/formats/session.md \"plan\")");
  run_command->add_option("--subject", options->subject, "free text stored with the session");
  run_command->add_option("--operator", options->operator_name, "who runs it (free text, recorded in its provenance)");
  run_command->add_option("--study", options->study, "the study it belongs to (free text, shown in session list)");
  run_command->add_flag("--preflight", options->preflight,
                        "run the lab's checks first (chromo doctor's) and refuse to start on a failed one");
  run_command->add_option("--override-reason", options->override_reason,
                          "start despite failed preflight checks, for this reason (written to the audit log; implies --preflight)");
  run_command->add_option("--name", options->name, "session name ([A-Za-z0-9_+.-])");
  run_command->add_option("--exposure-us", options->exposure_us, "standard plan: exposure (default 20000)");
  run_command->add_option("--frames", options->frames_per_camera, "standard plan: frames per camera and subject step (default 1)");
  run_command->add_option("--reference-frames", options->reference_frames,
                          "built-in plans: frames per camera of each dark and white reference step (default: the "
                          "daemon's capture.reference_frames; references are not subject time)")
      ->check(CLI::Range(1u, 1000u));
  run_command->add_option("--subject-fill", options->subject_fill,
                          "standard plan with exposure per capture: meter each subject so its 99th percentile (white-"
                          "like parts of the view left out) sits at this share of full scale, its white scaled by the "
                          "exposure ratio g and checked at its white's exposure / g after the subjects (default: the "
                          "daemon's capture.subject_fill)")
      ->check(CLI::Range(0.05, 0.98));
  run_command->add_flag("--hardware-timed", options->hardware, "standard plan: the controller advances on the camera's exposure");
  run_command->add_flag("--prompts", options->prompts, "standard plan: pause for the operator before white and subject");
  run_command->add_option("--polarised", options->polarised,
                          "standard plan: cross-polarised with a parallel D65' capture (docs/polarisation.md): on, off, "
                          "or auto (the daemon's capture.polarised_plan: polarised when the controller has polariser "
                          "banks on every LED type)")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  run_command->add_flag("--detach", options->detach, "print the id and return at once");
  run_command->callback([&exit_status, options] { run(*options, exit_status); });
}

// `session cancel`, `pause`, `resume`: one control request each.
void add_control_commands(CLI::App& session, const std::shared_ptr<SessionOptions>& options, int& exit_status) {
  auto add_control = [&](const char* verb, const char* help, auto call, auto request_tag) {
    auto* command = session.add_subcommand(verb, help);
    add_daemon_options(*command, options->address);
    command->add_option("id", options->id, "session id")->required();
    command->callback([&exit_status, options, verb, call] {
      control<typename decltype(request_tag)::type>(*options, exit_status, verb, call);
    });
  };
  add_control("cancel", "abandon the step in progress; stored frames stay; LEDs off",
              [](auto& stub, auto* context, const auto& request, auto* out) { return stub.CancelOperation(context, request, out); },
              std::type_identity<pb::CancelOperationRequest>{});
  add_control("pause", "finish the current step, then wait",
              [](auto& stub, auto* context, const auto& request, auto* out) { return stub.PauseOperation(context, request, out); },
              std::type_identity<pb::PauseOperationRequest>{});
  add_control("resume", "continue a paused session (retries a step a device interrupted)",
              [](auto& stub, auto* context, const auto& request, auto* out) { return stub.ResumeOperation(context, request, out); },
              std::type_identity<pb::ResumeOperationRequest>{});
}

}  // namespace

void add_session_command(CLI::App& app, int& exit_status) {
  auto* session = app.add_subcommand("session", "capture sessions on chromod");
  session->require_subcommand(1);
  auto options = std::make_shared<SessionOptions>();
  add_run_command(*session, options, exit_status);

  auto* plans_command = session->add_subcommand(
      "plans", "the built-in plans and plan files: captures, channels, capture time (no daemon needed)");
  auto plan_files = std::make_shared<std::vector<std::string>>();
  auto plan_dir = std::make_shared<std::string>();
  plans_command->add_option("files", *plan_files, "plan files (JSON, docs/formats/session.md \"plan\")");
  plans_command->add_option("--plan-dir", *plan_dir, "also every *.json plan file in this directory");
  plans_command->callback([&exit_status, plan_files, plan_dir] { list_plans(*plan_files, *plan_dir, exit_status); });

  auto* watch_command = session->add_subcommand("watch", "follow a session's progress to its end");
  add_daemon_options(*watch_command, options->address);
  watch_command->add_option("id", options->id, "session id")->required();
  watch_command->callback([&exit_status, options] { exit_status = watch_operation(DaemonConnection(options->address), options->id); });

  auto* list = session->add_subcommand("list", "sessions known to the daemon, newest first");
  add_daemon_options(*list, options->address);
  list->callback([&exit_status, options] { list_sessions(*options, exit_status); });

  auto* show_command = session->add_subcommand("show", "a session's state, steps and (with --frames) every frame");
  add_daemon_options(*show_command, options->address);
  show_command->add_option("id", options->id, "session id")->required();
  show_command->add_flag("--frames", options->frames, "list every stored frame");
  show_command->callback([&exit_status, options] { show(*options, exit_status); });

  auto* delete_command = session->add_subcommand(
      "delete", "delete a finished session: its folder (frames, results, products) and the cache entries only it used");
  add_daemon_options(*delete_command, options->address);
  delete_command->add_option("id", options->id, "session id")->required();
  delete_command->callback([&exit_status, options] { delete_session(*options, exit_status); });

  add_control_commands(*session, options, exit_status);
}

}  // namespace chromo::cli
