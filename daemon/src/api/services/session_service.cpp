// SessionService: sessions: start one (a plan or the standard plan), list, read back (sessions.proto).
#include <string>
#include <vector>

#include "chromosphere/v1/sessions.grpc.pb.h"
#include "chromo/daemon/internal/operations/lab_checks.hpp"
#include "services.hpp"

namespace chromo::daemon::services {
namespace {

class SessionServiceImpl final : public pb::SessionService::Service {
 public:
  SessionServiceImpl(Daemon& daemon, Guard& guard) : daemon_(daemon), guard_(guard) {}
  Status StartSession(ServerContext* context, const pb::StartSessionRequest* request, pb::Operation* response) override {
    return guard_.audited(context, "start_session", [&](nlohmann::json& details) {
      details["subject_bytes"] = request->subject().size();
      if (request->subject().size() > session::kMaxTextBytes) return invalid("subject: longer than 4096 bytes");
      if (auto bad = session::control_character_error(request->subject()); !bad.empty()) return invalid("subject: " + bad);
      for (const auto& [field, text] : {std::pair{"operator_name", &request->operator_name()}, {"study", &request->study()},
                                        {"preflight_override_reason", &request->preflight_override_reason()}}) {
        if (text->size() > session::kMaxTextBytes) return invalid(std::string(field) + ": longer than 4096 bytes");
        if (auto bad = session::control_character_error(*text); !bad.empty()) return invalid(std::string(field) + ": " + bad);
      }
      if (!request->name().empty() && !session::is_valid_name(request->name()))
        return invalid("name: must match [A-Za-z0-9_+.-]{1,64}");
      session::SessionPlan plan;
      if (request->plan_source_case() == pb::StartSessionRequest::kPlan) {
        if (Status s = from_proto(request->plan(), "plan", &plan); !s.ok()) return s;
      } else if (request->plan_source_case() == pb::StartSessionRequest::kStandard && request->standard()) {
        session::StandardPlanOptions options = daemon_.standard_plan_options();
        if (Status s = standard_plan_options_of(*request, &options); !s.ok()) return s;
        plan = session::standard_plan(options);
      } else {
        return invalid("plan_source: set standard = true or give a plan");
      }
      if (!request->name().empty()) plan.name = request->name();
      if (Status s = preflight(*request, details); !s.ok()) return s;
      const auto record =
          daemon_.start_session(std::move(plan), request->subject(), {request->operator_name(), request->study()});
      details["session"] = record.id;
      to_proto(record, response);
      return Status::OK;
    });
  }
  Status GetStandardPlan(ServerContext* context, const pb::GetStandardPlanRequest* request, pb::SessionPlan* response) override {
    return guard_(context, [&] {
      session::StandardPlanOptions options = daemon_.standard_plan_options();
      if (Status s = standard_plan_options_of(*request, &options); !s.ok()) return s;
      const session::SessionPlan plan = session::standard_plan(options);
      to_proto(plan, response);
      try {
        daemon_.check_plan_runs_here(plan);
      } catch (const std::exception& refusal) {  // StartSession's refusal, shown before Start
        response->set_start_refusal(refusal.what());
      }
      return Status::OK;
    });
  }
  Status ListSessions(ServerContext* context, const pb::ListSessionsRequest* request, pb::ListSessionsResponse* response) override {
    return guard_(context, [&] {
      if (request->limit() > 10000) return invalid("limit: at most 10000");
      std::uint32_t count = 0;
      for (const auto& record : daemon_.operations().list()) {
        if (record.kind != session::OperationKind::kSession) continue;
        if (request->limit() && count++ >= request->limit()) break;
        summary_to_proto(record, response->add_sessions());
      }
      return Status::OK;
    });
  }
  Status DeleteSession(ServerContext* context, const pb::DeleteSessionRequest* request,
                       pb::DeleteSessionResponse* response) override {
    return guard_.audited(context, "delete_session", [&](nlohmann::json& details) {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      details["session"] = request->id();
      if (!daemon_.operations().get(request->id()))
        return Status(StatusCode::NOT_FOUND, "id: no session \"" + request->id() + "\"");
      const auto deleted = daemon_.delete_session(request->id());
      details["files_removed"] = deleted.files;
      details["bytes_removed"] = deleted.bytes;
      details["cache_entries_removed"] = deleted.cache_entries;
      response->set_id(request->id());
      response->set_files_removed(deleted.files);
      response->set_bytes_removed(deleted.bytes);
      for (const auto& name : deleted.cache_entries) response->add_cache_entries_removed(name);
      return Status::OK;
    });
  }
  Status GetSession(ServerContext* context, const pb::GetSessionRequest* request, pb::SessionDetail* response) override {
    return guard_(context, [&] {
      if (Status s = check_id("id", request->id()); !s.ok()) return s;
      auto info = daemon_.session(request->id());
      if (!info) return Status(StatusCode::NOT_FOUND, "id: no session \"" + request->id() + "\"");
      to_proto(*info, request->include_frames(), response);
      return Status::OK;
    });
  }

 private:
  // With request.preflight: the lab's checks (lab_checks.hpp, as chromo doctor
  // runs them) into the audit details; FAILED_PRECONDITION naming each failed
  // check and its fix unless an override reason is given.
  Status preflight(const pb::StartSessionRequest& request, nlohmann::json& details) {
    if (!request.preflight()) return Status::OK;
    std::vector<std::string> failed_ids, warning_ids;
    std::string failures;
    for (const auto& check : daemon_.check_lab()) {
      if (check.status == CheckStatus::warning) warning_ids.push_back(check.id);
      if (check.status != CheckStatus::failed) continue;
      failed_ids.push_back(check.id);
      failures += (failures.empty() ? "" : "; ") + check.id + ": " + check.finding + (check.fix.empty() ? "" : " (fix: " + check.fix + ")");
    }
    details["preflight"] = {{"failed", failed_ids}, {"warnings", warning_ids}};
    if (failed_ids.empty()) return Status::OK;
    if (request.preflight_override_reason().empty())
      return Status(StatusCode::FAILED_PRECONDITION,
                    "preflight: " + failures + ". Fix them, or give preflight_override_reason to start anyway");
    details["preflight"]["override_reason"] = request.preflight_override_reason();
    return Status::OK;
  }
  // `options` comes with the configuration's capture choices (Daemon::standard_plan_options).
  // The standard plan's fields of a StartSession or GetStandardPlan request onto `options`.
  template <typename Request>
  static Status standard_plan_options_of(const Request& request, session::StandardPlanOptions* options) {
    if (Status s = standard_options(request.timing(), request.exposure_us(), request.frames_per_camera(),
                                    request.reference_frames(), request.subject_fill(), request.operator_prompts(),
                                    request.fixed_exposure(), options);
        !s.ok())
      return s;
    return polarised_option(request.polarised(), options);
  }
  static Status standard_options(int timing, double exposure_us, std::uint32_t frames, std::uint32_t reference_frames,
                                 double subject_fill, bool prompts, bool fixed_exposure,
                                 session::StandardPlanOptions* options) {
    if (!pb::Timing_IsValid(timing)) return invalid("timing: unknown value " + std::to_string(timing));
    options->timing = timing == pb::TIMING_HARDWARE ? session::Timing::kHardware : session::Timing::kSoftware;
    if (fixed_exposure || options->timing == session::Timing::kHardware) options->meter_white_share = 0;
    if (exposure_us != 0) {
      if (!(exposure_us >= session::kMinExposureUs && exposure_us <= session::kMaxExposureUs))
        return invalid("exposure_us: must be in [1, 10000000] (0: metered), got " + nlohmann::json(exposure_us).dump());
      options->exposure_us = exposure_us;
    }
    if (frames != 0) {
      if (frames > session::kMaxFramesPerCamera) return invalid("frames_per_camera: must be in [1, 1000]");
      options->frames_per_camera = frames;
    }
    if (reference_frames != 0) {
      if (reference_frames > session::kMaxFramesPerCamera) return invalid("reference_frames: must be in [1, 1000]");
      options->reference_frames = reference_frames;
    }
    if (subject_fill != 0) {
      if (!(subject_fill > 0 && subject_fill < 1))
        return invalid("subject_fill: must be in (0, 1) (0: the configuration's capture.subject_fill), got " +
                       std::to_string(subject_fill));
      if (options->meter_white_share == 0)
        return invalid("subject_fill: a subject is metered against its metered white: it needs "
                       "capture.exposure_per_capture on, software timing and no fixed_exposure");
      options->subject_fill = subject_fill;
    }
    if (options->meter_white_share == 0) options->subject_fill = 0;  // the configuration's, without metered whites
    options->operator_prompts = prompts;
    return Status::OK;
  }
  // The request's choice over the configuration's (POLARISED_PLAN_CONFIGURED keeps it).
  static Status polarised_option(int polarised, session::StandardPlanOptions* options) {
    if (!pb::PolarisedPlan_IsValid(polarised)) return invalid("polarised: unknown value " + std::to_string(polarised));
    if (polarised == pb::POLARISED_PLAN_ON) options->polarised = true;
    if (polarised == pb::POLARISED_PLAN_OFF) options->polarised = false;
    return Status::OK;
  }
  Daemon& daemon_;
  Guard& guard_;
};

}  // namespace

std::unique_ptr<grpc::Service> make_session_service(Daemon& daemon, Guard& guard) {
  return std::make_unique<SessionServiceImpl>(daemon, guard);
}

}  // namespace chromo::daemon::services
