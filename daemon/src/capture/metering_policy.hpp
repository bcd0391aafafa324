#pragma once
// MeteringPolicy: each step's exposure per camera (sequencer.hpp,
// "Exposure per capture"). It meters a white step's exposure (metering
// frames of the white target until its brightest channel is at the step's
// share of full scale: exposure_metering.hpp decides each next exposure),
// a subject step's ratio g to its white (Step::subject_fill), keeps the dark
// level the metering subtracts (from the dark step's frames), and answers
// what exposure each step is taken at: metered, from exposure_from, times a
// subject's ratio, or a linearity white's; and, for the blue-light hazard
// check, every step's exposure as far as known. Metering frames are taken
// through SynchronisedCapture and never stored; each metering is a journal
// record ("exposure_metered", "subject_metered").
//
// Thread rules: the session's thread only (the sequencer's).

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "chromo/daemon/internal/capture/exposure_metering.hpp"
#include "synchronised_capture.hpp"

namespace chromo::daemon {

class MeteringPolicy {
 public:
  // Meters through `capture`'s cameras, opened before (one state per
  // camera, in its order).
  MeteringPolicy(RunControl& run, SynchronisedCapture& capture);

  // Meters the white of `step` (meter_white_share > 0) lit at `levels`; its
  // exposures become exposures_of(step) and of the steps naming it in
  // exposure_from. False when cancelled.
  bool meter_white(const session::Step& step, std::size_t step_index, const drivers::DriveLevels& levels);
  // Meters the subject of `step` (subject_fill > 0): one frame at its
  // white's exposure; per camera the ratio g that puts the brightest
  // channel's subject_percentile at subject_fill of full scale
  // (session::subject_exposure_ratio, the dark level subtracted). False
  // when cancelled.
  bool meter_subject(const session::Step& step, std::size_t step_index);
  // A stored frame of the dark step: its mean level per channel joins the
  // dark level of camera `camera`. A frame whose levels cannot be read is
  // ignored (the pipeline refuses it anyway).
  void observe_dark(std::size_t camera, const drivers::Frame& frame);

  // Each camera's exposure for `step`: metered (its own or exposure_from's),
  // else the plan's; a subject-metered step's multiplied by its ratio once
  // metered. std::logic_error when the step it takes it from is not metered yet.
  std::vector<double> exposures_of(const session::Step& step) const;
  // Every step's exposure as far as known (metered steps: the longest over
  // the cameras; a subject-metered step not metered yet at its maximum
  // ratio, which bounds the dose the metering may reach).
  std::map<std::string, double> known_exposures() const;

 private:
  struct CameraMetering {
    FrameLevels white_seen;                   // levels of the last white metering frame
    SubjectLevels subject_seen;               // levels of the last subject metering frame
    std::array<double, 3> white_like_from{};  // its subject_levels ceiling per channel (share of full scale)
    std::array<double, 3> dark{};             // mean dark level per channel (share of full scale)
    std::uint32_t dark_frames = 0;
  };
  // One metering frame per camera at the configured exposures; its levels
  // (white or, with subject_percentile > 0, subject) into cameras_. False when cancelled.
  bool take_metering_frame(const session::Step& step, std::size_t step_index, double subject_percentile);
  std::vector<double> linearity_exposures(const session::Step& step) const;
  double max_subject_ratio(const session::Step& step) const;

  RunControl& run_;
  SynchronisedCapture& capture_;
  const session::SessionPlan& plan_;
  std::vector<CameraMetering> cameras_;
  std::map<std::string, std::vector<double>> metered_;  // metered white step → exposure per camera
  // metered white step → per camera the white's level per channel at its metered exposure (share of full scale)
  std::map<std::string, std::vector<std::array<double, 3>>> white_level_;
  std::map<std::string, std::vector<double>> subject_ratio_;  // subject-metered step → g per camera
  std::vector<double> last_metered_exposure_;
  std::optional<std::array<double, 3>> last_metered_prediction_;
  double last_metered_share_ = 1;
};

}  // namespace chromo::daemon
