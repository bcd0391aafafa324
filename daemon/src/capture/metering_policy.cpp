// MeteringPolicy: see metering_policy.hpp.
#include "metering_policy.hpp"

#include <algorithm>

#include "chromo/session/method_measurement.hpp"  // session::subject_exposure_ratio

namespace chromo::daemon {

namespace {

// The step whose metered subject/white ratio g a step's exposure takes: its
// own when it meters the subject, else its subject_ratio_from ("" for none).
const std::string& subject_ratio_step(const session::Step& step) {
  return step.subject_fill > 0 ? step.name : step.subject_ratio_from;
}

constexpr int kMaxMeteringFrames = 6;

}  // namespace

MeteringPolicy::MeteringPolicy(RunControl& run, SynchronisedCapture& capture)
    : run_(run), capture_(capture), plan_(run.context().plan), cameras_(capture.camera_count()) {}

void MeteringPolicy::observe_dark(std::size_t camera, const drivers::Frame& frame) {
  try {  // the dark level the metering subtracts (the mean over the dark step's frames)
    CameraMetering& metering = cameras_.at(camera);
    const FrameLevels levels = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format);
    const double n = metering.dark_frames++;
    for (int c = 0; c < 3; ++c) metering.dark[c] = (metering.dark[c] * n + levels.mean[c]) / (n + 1);
  } catch (const std::exception&) {
    // A frame the pipeline will refuse anyway; the metering then assumes no dark level.
  }
}

bool MeteringPolicy::take_metering_frame(const session::Step& step, std::size_t step_index,
                                         double subject_percentile) {
  std::optional<Capture> capture = capture_.take(step, step_index, 0);
  if (!capture) return false;
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    const drivers::Frame& frame = capture->frames[k];
    CameraMetering& metering = cameras_[k];
    try {
      if (subject_percentile > 0)
        metering.subject_seen = subject_levels(frame.data, frame.width, frame.height, frame.pixel_format,
                                               subject_percentile, metering.white_like_from);
      else
        metering.white_seen = frame_levels(frame.data, frame.width, frame.height, frame.pixel_format, FrameRegion::kLit);
    } catch (const std::exception& failure) {
      throw std::runtime_error("camera \"" + capture_.camera_name(k) + "\": " + failure.what());
    }
  }
  return true;
}

std::vector<double> MeteringPolicy::exposures_of(const session::Step& step) const {
  if (!step.linearity_of.empty()) return linearity_exposures(step);
  const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
  if (!metered_at.empty()) {
    auto found = metered_.find(metered_at);
    if (found == metered_.end()) throw std::logic_error("step " + step.name + ": no exposure metered at step " + metered_at);
    std::vector<double> exposure = found->second;
    const std::string& ratio_at = subject_ratio_step(step);
    if (auto ratio = subject_ratio_.find(ratio_at); !ratio_at.empty() && ratio != subject_ratio_.end())
      for (std::size_t k = 0; k < exposure.size(); ++k) exposure[k] *= ratio->second[k];
    return exposure;
  }
  return std::vector<double>(cameras_.size(), step.exposure_us);
}

std::map<std::string, double> MeteringPolicy::known_exposures() const {
  std::map<std::string, double> out;
  for (const auto& step : plan_.steps) {
    if (!step.linearity_of.empty()) {  // once metered; before, its subject's bound (≥ its white's: g ≥ 1)
      try {
        const std::vector<double> exposure = linearity_exposures(step);
        out[step.name] = *std::max_element(exposure.begin(), exposure.end());
      } catch (const std::logic_error&) {
        if (auto subject = out.find(step.linearity_of); subject != out.end()) out[step.name] = subject->second;
      }
      continue;
    }
    const std::string& metered_at = step.meter_white_share > 0 ? step.name : step.exposure_from;
    auto found = metered_.find(metered_at);
    if (metered_at.empty() || found == metered_.end()) continue;
    const std::vector<double> exposure = exposures_of(step);
    double longest = *std::max_element(exposure.begin(), exposure.end());
    const std::string& ratio_at = subject_ratio_step(step);
    if (!ratio_at.empty() && !subject_ratio_.count(ratio_at)) longest *= max_subject_ratio(step);
    out[step.name] = longest;
  }
  return out;
}

// A linearity white (Step::linearity_of): its subject's white's exposure ÷
// that subject's g, per camera (the subject metered before it).
std::vector<double> MeteringPolicy::linearity_exposures(const session::Step& step) const {
  const auto subject = std::find_if(plan_.steps.begin(), plan_.steps.end(),
                                    [&](const session::Step& s) { return s.name == step.linearity_of; });
  if (subject == plan_.steps.end())
    throw std::logic_error("step " + step.name + ": no step " + step.linearity_of + " to check the linearity of");
  const std::string& ratio_at = subject_ratio_step(*subject);
  const auto ratio = subject_ratio_.find(ratio_at);
  const auto white = metered_.find(subject->exposure_from);
  if (ratio == subject_ratio_.end() || white == metered_.end())
    throw std::logic_error("step " + step.name + ": " + step.linearity_of + " is not metered yet");
  std::vector<double> exposure = white->second;
  for (std::size_t k = 0; k < exposure.size(); ++k) exposure[k] /= ratio->second[k];
  return exposure;
}

double MeteringPolicy::max_subject_ratio(const session::Step& step) const {
  if (step.subject_fill > 0) return step.max_subject_exposure_ratio;
  for (const auto& s : plan_.steps)
    if (s.name == step.subject_ratio_from) return s.max_subject_exposure_ratio;
  return 1;
}

bool MeteringPolicy::meter_subject(const session::Step& step, std::size_t step_index) {
  const std::vector<double> white = exposures_of(step);
  if (!capture_.ensure_exposure(white)) return false;
  const std::vector<std::array<double, 3>>& white_level = white_level_.at(step.exposure_from);
  for (std::size_t k = 0; k < cameras_.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double dark = cameras_[k].dark[c];
      cameras_[k].white_like_from[c] = dark + kSubjectWhiteLikeShare * (white_level[k][c] - dark);
    }
  if (!take_metering_frame(step, step_index, step.subject_percentile)) return false;
  std::vector<double> ratio(cameras_.size(), 1.0);
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    const SubjectLevels& seen = cameras_[k].subject_seen;
    const std::array<double, 3>& dark = cameras_[k].dark;
    int brightest = 0;
    for (int c = 1; c < 3; ++c)
      if (seen.level[c] - dark[c] > seen.level[brightest] - dark[brightest]) brightest = c;
    ratio[k] = session::subject_exposure_ratio(seen.level[brightest], dark[brightest], step.subject_fill,
                                               step.max_subject_exposure_ratio);
    run_.context().journal->append({{"type", "subject_metered"},
                                    {"step", step.name},
                                    {"camera", capture_.camera_name(k)},
                                    {"white_exposure_us", white[k]},
                                    {"exposure_us", white[k] * ratio[k]},
                                    {"exposure_ratio", ratio[k]},
                                    {"capped", ratio[k] >= step.max_subject_exposure_ratio},
                                    {"channel", brightest},
                                    {"percentile", step.subject_percentile},
                                    {"level", seen.level[brightest]},
                                    {"white_like_from", cameras_[k].white_like_from[brightest]},
                                    {"white_like_share", seen.white_like_share},
                                    {"target_fill", step.subject_fill}});
  }
  subject_ratio_[step.name] = ratio;
  return true;
}

bool MeteringPolicy::meter_white(const session::Step& step, std::size_t step_index, const drivers::DriveLevels& levels) {
  const SequencerContext& c = run_.context();
  const std::optional<std::array<double, 3>> predicted = c.predict_white_rgb ? c.predict_white_rgb(levels) : std::nullopt;
  std::vector<double> exposure(cameras_.size(), step.exposure_us);
  std::vector<MeteringTarget> targets(cameras_.size());
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    const drivers::CameraInfo info = capture_.camera_info(k);
    targets[k].white_share = step.meter_white_share;
    targets[k].dark = cameras_[k].dark;
    if (info.exposure_min_us > 0) targets[k].min_exposure_us = info.exposure_min_us;
    targets[k].max_exposure_us = info.exposure_max_us > 0 ? std::min(info.exposure_max_us, session::kMaxExposureUs)
                                                          : session::kMaxExposureUs;
    if (predicted && last_metered_prediction_ && !last_metered_exposure_.empty()) {
      const double now = *std::max_element(predicted->begin(), predicted->end());
      const double before = *std::max_element(last_metered_prediction_->begin(), last_metered_prediction_->end());
      if (now > 0 && before > 0)
        exposure[k] = last_metered_exposure_[k] * (before / now) * (step.meter_white_share / last_metered_share_);
    }
    exposure[k] = std::clamp(exposure[k], targets[k].min_exposure_us, targets[k].max_exposure_us);
  }
  const std::vector<double> first_guess = exposure;
  std::vector<bool> done(cameras_.size(), false), at_limit(cameras_.size(), false);
  std::vector<int> frames(cameras_.size(), 0);
  std::vector<double> reached(cameras_.size(), 0), measured_at(cameras_.size(), 0);
  for (int attempt = 0; attempt < kMaxMeteringFrames; ++attempt) {
    if (!capture_.ensure_exposure(exposure)) return false;
    if (!take_metering_frame(step, step_index, 0)) return false;
    bool all_done = true;
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      if (done[k]) continue;
      ++frames[k];
      const FrameLevels& seen = cameras_[k].white_seen;
      reached[k] = seen.mean[seen.brightest_channel()];
      const MeteringDecision d = next_metering_exposure(exposure[k], seen, targets[k]);
      if (d.at_limit) at_limit[k] = true;
      measured_at[k] = exposure[k];
      done[k] = d.done;
      // Within the tolerance: the last small correction is applied too.
      if (!d.at_limit) exposure[k] = d.next_exposure_us;
      all_done = all_done && done[k];
    }
    if (all_done) break;
  }
  for (std::size_t k = 0; k < cameras_.size(); ++k) {
    c.journal->append({{"type", "exposure_metered"},
                       {"step", step.name},
                       {"camera", capture_.camera_name(k)},
                       {"exposure_us", exposure[k]},
                       {"first_guess_us", first_guess[k]},
                       {"white_share", reached[k]},
                       {"white_share_measured_at_us", measured_at[k]},
                       {"target_share", step.meter_white_share},
                       {"metering_frames", frames[k]},
                       {"converged", static_cast<bool>(done[k])},
                       {"at_limit", static_cast<bool>(at_limit[k])}});
    if (at_limit[k])
      run_.report_message("step " + step.name + ": camera \"" + capture_.camera_name(k) + "\": the white reaches " +
                          std::to_string(reached[k]) + " of full scale at the exposure limit " +
                          std::to_string(exposure[k]) + " us (target " + std::to_string(step.meter_white_share) + ")");
  }
  metered_[step.name] = exposure;
  std::vector<std::array<double, 3>>& white_level = white_level_[step.name];
  white_level.assign(cameras_.size(), {});
  for (std::size_t k = 0; k < cameras_.size(); ++k) {  // the last frame's levels, on the exposure set
    const double scale = measured_at[k] > 0 ? exposure[k] / measured_at[k] : 1.0;
    for (int c = 0; c < 3; ++c) {
      const double dark = cameras_[k].dark[c];
      white_level[k][c] = dark + scale * (cameras_[k].white_seen.mean[c] - dark);
    }
  }
  last_metered_exposure_ = exposure;
  last_metered_prediction_ = predicted;
  last_metered_share_ = step.meter_white_share;
  return true;
}

}  // namespace chromo::daemon
