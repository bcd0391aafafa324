#include "chromo/daemon/internal/api/api_conversions.hpp"

#include <google/protobuf/util/time_util.h>

#include <fstream>
#include <sstream>

namespace chromo::daemon {

// The plan and drive-level conversions (chromo/proto/plan_messages.hpp) join the daemon's own.
using proto::from_proto;
using proto::to_proto;

namespace pb = chromosphere::v1;
using grpc::Status;
using grpc::StatusCode;

namespace {
google::protobuf::Timestamp timestamp(std::chrono::system_clock::time_point time) {
  return google::protobuf::util::TimeUtil::NanosecondsToTimestamp(
      std::chrono::duration_cast<std::chrono::nanoseconds>(time.time_since_epoch()).count());
}
}  // namespace

void to_proto(const DeviceReport& report, pb::Device* out) {
  out->set_name(report.name);
  out->set_kind(report.kind == DeviceKind::kLedController ? pb::DEVICE_KIND_LED_CONTROLLER
                : report.kind == DeviceKind::kCamera      ? pb::DEVICE_KIND_CAMERA
                                                          : pb::DEVICE_KIND_SPECTROMETER);
  out->set_backend(report.backend);
  out->set_address(report.address);
  out->set_health(report.health == DeviceReport::Health::kOk            ? pb::DEVICE_HEALTH_OK
                  : report.health == DeviceReport::Health::kUnreachable ? pb::DEVICE_HEALTH_UNREACHABLE
                                                                        : pb::DEVICE_HEALTH_FAULT);
  out->set_detail(report.detail);
  for (const auto& [key, value] : report.info) (*out->mutable_info())[key] = value;
}

void to_proto(const std::string& controller, const drivers::LedStatus& status, pb::LedStatus* out) {
  out->set_controller(controller);
  to_proto(status.applied.drive, out->mutable_applied()->mutable_drive());
  out->mutable_applied()->set_pwm_frequency_hz(status.applied.pwm_frequency_hz);
  if (status.applied.zone) out->mutable_applied()->set_zone(*status.applied.zone);
  out->set_output_enabled(status.output_enabled);
  for (double t : status.temperature_C) out->add_temperature_c(t);
  for (auto f : status.channel_faults) out->add_channel_faults(f);
  out->set_controller_faults(status.controller_faults);
  out->set_sequence_position(status.sequence_position);
}

Status from_proto(const pb::LedState& state, const std::string& field, drivers::LedState* out) {
  out->drive = from_proto(state.drive());
  if (Status s = proto::check_levels(out->drive, field + ".drive"); !s.ok()) return s;
  if (!(state.pwm_frequency_hz() >= 0 && state.pwm_frequency_hz() <= 1e7))
    return {StatusCode::INVALID_ARGUMENT, field + ".pwm_frequency_hz: must be in [0, 10000000]"};
  out->pwm_frequency_hz = state.pwm_frequency_hz();
  if (state.has_zone()) {
    if (state.zone() < 0 || state.zone() > 255) return {StatusCode::INVALID_ARGUMENT, field + ".zone: must be in [0, 255]"};
    out->zone = state.zone();
  }
  return Status::OK;
}

void to_proto(const session::OperationRecord& record, pb::Operation* out) {
  out->set_id(record.id);
  out->set_kind(record.kind == session::OperationKind::kSession ? pb::OPERATION_KIND_SESSION : pb::OPERATION_KIND_CALIBRATION);
  out->set_name(record.name);
  out->set_state(static_cast<pb::OperationState>(static_cast<int>(record.state) + 1));
  out->set_progress(record.progress);
  out->set_eta_seconds(record.eta_seconds);
  out->set_message(record.message);
  out->set_error(record.error);
  *out->mutable_created() = timestamp(record.created);
  *out->mutable_updated() = timestamp(record.updated);
  out->set_folder(record.folder);
  out->set_step_index(record.step_index);
  out->set_step_count(record.step_count);
  auto* counters = out->mutable_counters();
  counters->set_expected(record.expected_frames);
  counters->set_received(record.counters.received);
  counters->set_stored(record.counters.stored);
  counters->set_estimated(record.counters.estimated);
  counters->set_estimator_skipped(record.counters.estimator_skipped);
  counters->set_lost(record.counters.lost);
  counters->set_resent_packets(record.counters.resent_packets);
  counters->set_estimator_queue_depth(record.counters.estimator_queue_depth);
  counters->set_max_estimator_queue_depth(record.counters.max_estimator_queue_depth);
  counters->set_estimator_read_back(record.counters.estimator_read_back);
  for (const auto& [reason, count] : record.counters.lost_reasons) (*counters->mutable_lost_reasons())[reason] = count;
  for (const auto& [reason, count] : record.counters.skipped_reasons) (*counters->mutable_skipped_reasons())[reason] = count;
}

void summary_to_proto(const session::OperationRecord& record, pb::SessionSummary* out) {
  out->set_id(record.id);
  out->set_name(record.name);
  out->set_folder(record.folder);
  to_proto(record, out->mutable_operation());
  out->set_subject(record.subject);
  out->set_study(record.study);
  out->set_operator_name(record.operator_name);
}

void to_proto(const session::SessionProvenance& p, pb::SessionProvenance* out) {
  out->set_recorded(p.recorded);
  if (!p.recorded) return;
  auto* library = out->mutable_led_library();
  library->set_kind(p.led_library.kind);
  library->set_file(p.led_library.file);
  library->set_created_utc(p.led_library.created_utc);
  library->set_age_at_start_s(p.led_library.age_at_start_s);
  for (const auto& [name, mix] : p.mixes) {
    auto& used = (*out->mutable_mixes())[name];
    proto::to_proto(mix.drive, used.mutable_weights());
    used.set_origin(mix.origin);
  }
  out->set_camera_sensitivity(p.camera_sensitivity);
  for (const auto& [camera, source] : p.camera_sensitivity_of) (*out->mutable_camera_sensitivity_of())[camera] = source;
  for (const auto& [camera, width_mm] : p.camera_field_width_mm) (*out->mutable_camera_field_width_mm())[camera] = width_mm;
  out->set_white_reflectance(p.white_reflectance);
  out->set_plan(p.plan);
  out->set_operator_name(p.operator_name);
  out->set_study(p.study);
  out->set_estimator_version(p.estimator_version);
  for (const auto& [key, value] : p.estimator_options) (*out->mutable_estimator_options())[key] = value;
}

void to_proto(const session::SessionInfo& info, bool include_frames, pb::SessionDetail* out) {
  summary_to_proto(info.record, out->mutable_summary());
  to_proto(info.plan, out->mutable_plan());
  out->set_subject(info.subject);
  to_proto(info.provenance, out->mutable_provenance());
  for (std::size_t i = 0; i < info.steps.size(); ++i) {
    auto* step = out->add_steps();
    step->set_index(static_cast<int>(i));
    step->set_name(info.steps[i].name);
    step->set_role(proto::role_to_proto(info.steps[i].role));
    step->set_completed(info.steps[i].completed);
    step->set_frames_stored(info.steps[i].frames_stored);
  }
  auto* timeline = out->mutable_timeline();
  timeline->set_capture_s(info.timeline.capture_s);
  timeline->set_subject_s(info.timeline.subject_s);
  timeline->set_derived_s(info.timeline.derived_s);
  timeline->set_estimation_s(info.timeline.estimation_s);
  timeline->set_total_s(info.timeline.total_s);
  if (!include_frames) return;
  for (const auto& frame : info.frames) {
    auto* f = out->add_frames();
    f->set_index(frame.index);
    f->set_step(frame.step);
    f->set_camera(frame.camera);
    f->set_sequence(frame.sequence);
    f->set_camera_frame_id(frame.camera_frame_id);
    f->set_camera_timestamp_ns(frame.camera_timestamp_ns);
    f->set_trigger_id(frame.trigger_id);
    f->set_file(frame.file);
    f->set_status("complete");
    f->set_exposure_us(frame.exposure_us);
    if (frame.led) {
      to_proto(frame.led->drive, f->mutable_drive());
      for (double t : frame.led->temperature_C) f->add_temperature_c(t);
      for (drivers::Polarisation p : frame.led->polarisation) f->add_polarisation(proto::polarisation_to_proto(p));
    }
  }
}

namespace {
// A results record's (or one camera entry's) headline numbers.
void results_summary_to_proto(const nlohmann::json& r, const std::string& method, const std::string& model,
                              std::uint64_t frames_read_back, pb::ResultsSummary* summary) {
  summary->set_method(method);
  summary->set_model(model);
  summary->set_pixels(r.value("pixels", std::uint64_t{0}));
  summary->set_pixels_per_second(r.value("pixels_per_second", 0.0));
  summary->set_estimate_seconds(r.value("estimate_seconds", 0.0));
  summary->set_frames_read_back(frames_read_back);
  summary->set_map_pixel_mm(r.value("map_pixel_mm", 0.0));
  if (r.contains("flag_counts") && r["flag_counts"].is_object())
    for (const auto& [name, count] : r["flag_counts"].items())
      if (count.is_number_unsigned()) (*summary->mutable_flag_counts())[name] = count.get<std::uint64_t>();
  if (r.contains("relit_delta_e94") && r["relit_delta_e94"].is_object())
    for (const auto& [name, stats] : r["relit_delta_e94"].items()) {
      pb::DeltaEStatistics s;
      s.set_mean(stats.value("mean", 0.0));
      s.set_median(stats.value("median", 0.0));
      s.set_p95(stats.value("p95", 0.0));
      s.set_max(stats.value("max", 0.0));
      s.set_pixels(stats.value("pixels", std::uint64_t{0}));
      if (stats.contains("photograph_noise") && stats["photograph_noise"].is_object())
        s.set_photograph_noise_mean(stats["photograph_noise"].value("mean", 0.0));
      if (stats.contains("beyond_noise_rms") && stats["beyond_noise_rms"].is_number())
        s.set_beyond_noise_rms(stats["beyond_noise_rms"].get<double>());
      if (stats.contains("block_means") && stats["block_means"].is_object())
        s.set_block_means_mean(stats["block_means"].value("mean", 0.0));
      (*summary->mutable_relit_delta_e94())[name] = s;
    }
  if (r.contains("highlights") && r["highlights"].is_object()) {
    summary->set_highlight_detection(r["highlights"].value("detection", ""));
    summary->set_highlight_pixels(r["highlights"].value("pixels", std::uint64_t{0}));
  }
}
// A results record's "cameras" (a record from before several cameras has none).
void cameras_to_proto(const nlohmann::json& r, const std::filesystem::path& folder, const std::string& method,
                      const std::string& model, std::uint64_t read_back, pb::Results* out) {
  if (!r.contains("cameras") || !r["cameras"].is_array()) return;
  for (const auto& entry : r["cameras"]) {
    if (!entry.is_object()) continue;
    auto* camera = out->add_cameras();
    camera->set_camera(entry.value("name", ""));
    if (entry.value("state", "") != "ok") {
      camera->set_state(pb::RESULTS_STATE_UNAVAILABLE);
      camera->set_reason(entry.value("reason", ""));
      continue;
    }
    camera->set_state(pb::RESULTS_STATE_AVAILABLE);
    camera->set_maps_file((folder / entry.value("maps_file", "")).string());
    camera->set_report_file((folder / entry.value("report_file", "")).string());
    camera->set_camera_sensitivity(entry.value("camera_sensitivity", ""));
    if (entry.contains("shared_with") && entry["shared_with"].is_string())
      camera->set_shared_with(entry["shared_with"].get<std::string>());
    if (entry.contains("common_view") && entry["common_view"].is_object()) {
      const auto& view = entry["common_view"];
      camera->set_common_view_reference(view.value("reference", ""));
      camera->set_common_view_reason(view.value("reason", ""));
      if (view.contains("file")) camera->set_common_view_file((folder / view.value("file", "")).string());
      camera->set_common_view_residual_px(view.value("residual_px", 0.0));
      if (view.contains("homography"))
        for (const auto& v : view["homography"]) camera->add_common_view_homography(v.get<double>());
    }
    results_summary_to_proto(entry, method, model, read_back, camera->mutable_summary());
  }
}
}  // namespace

void results_to_proto(const session::SessionInfo& info, pb::Results* out) {
  out->set_session_id(info.record.id);
  to_proto(info.provenance, out->mutable_provenance());
  out->set_folder(info.record.folder);
  for (const auto& frame : info.frames) out->add_frame_files(frame.file);
  if (!session::is_final(info.record.state)) {
    out->set_state(pb::RESULTS_STATE_PENDING);
    out->set_reason("the session is " + session::state_name(info.record.state));
    return;
  }
  const std::filesystem::path folder = info.record.folder;
  if (!info.results.is_null() && info.results.value("state", "") == "available") {
    out->set_state(pb::RESULTS_STATE_AVAILABLE);
    out->set_maps_file((folder / info.results.value("maps_file", "")).string());
    out->set_report_file((folder / info.results.value("report_file", "")).string());
    std::ifstream in(out->report_file());
    std::stringstream buffer;
    buffer << in.rdbuf();
    if (buffer.str().size() <= (1u << 20)) out->set_summary_json(buffer.str());
    // Headline numbers: from the results record (written with the report).
    const auto& r = info.results;
    const std::string method = r.value("method", ""), model = r.value("model", "");
    const auto read_back = r.value("frames_read_back", std::uint64_t{0});
    results_summary_to_proto(r, method, model, read_back, out->mutable_summary());
    cameras_to_proto(r, folder, method, model, read_back, out);
    return;
  }
  out->set_state(pb::RESULTS_STATE_UNAVAILABLE);
  if (info.record.state != session::OperationState::kSucceeded)
    out->set_reason("the session ended " + session::state_name(info.record.state) +
                    (info.record.error.empty() ? "" : ": " + info.record.error) + "; its stored frames are in the folder");
  else
    out->set_reason(info.results.is_null() ? "no on-line estimator in this daemon: frames and derived albedo are stored"
                                           : info.results.value("reason", "estimation did not produce maps"));
  if (!info.results.is_null()) cameras_to_proto(info.results, folder, "", "", 0, out);
}

void to_proto(const Event& event, pb::Event* out) {
  out->set_sequence(event.sequence);
  *out->mutable_time() = timestamp(event.time);
  switch (event.kind) {
    case Event::Kind::kOperation: to_proto(event.operation, out->mutable_operation()); break;
    case Event::Kind::kLog: out->set_log(event.log); break;
    case Event::Kind::kFrame: {
      auto* frame = out->mutable_frame();
      frame->set_session_id(event.session_id);
      frame->set_step(event.step);
      frame->set_camera(event.camera);
      frame->set_index(event.frame_index);
      break;
    }
  }
}

}  // namespace chromo::daemon
