#pragma once
// The plan advisor's description of a capture plan: what it needs to know of
// a plan to predict its accuracy and its duration, and nothing else.
//
// A plan is a list of captures. Each capture is one illumination state of
// the sphere (a drive level per LED type, 0-1 of full drive, the light being
// the LED library's spectrum per unit drive times that level, summed),
// photographed as the subject and as the white reference target, with the
// exposure set so that the white's brightest camera channel reaches
// `white_fill` of full scale, averaged over `frames` frames (the white over
// `white_frames`). One dark (the camera's offset) of `dark_frames` frames
// serves all captures.
//
// The estimator's channels are listed explicitly: each is one camera channel
// (R, G or B) of one capture's albedo, or of the difference of two captures
// (`minus`: the method's blue-only channel is (W57+blue) − W57 in B,
// normalised by the same difference of the white references). An empty
// channel list means every capture's R, G and B.
//
// This is the advisor's own small type, not the session plan: a session plan
// (session_plan.hpp) or a generalised channel plan converts into it with a
// few lines (drive levels, exposure share, frames, channel list).
//
// Files: plan_from_json() reads the JSON form of docs/formats/plan-advisor.md
// (the edge; the process passes this struct).

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/calibration/led_library.hpp"
#include "chromo/spectral/led_type.hpp"

namespace chromo::planning {

struct PlannedCapture {
  std::string name;                                     // unique in the plan, [A-Za-z0-9_+.'-]{1,64}
  std::array<double, spectral::kLedTypeCount> drive{};  // per LED type (led_type_index), each 0-1, not all 0
  double white_fill = 0.85;  // expected white signal of the brightest channel / full well, (0, 1]
  int frames = 1;            // subject frames averaged, 1-1000
  int white_frames = 1;      // white-reference frames averaged, 1-1000
  int settle_ms = 50;        // LED settling before the first frame, 0-60000
};

struct PlannedChannel {
  std::string capture;  // a capture's name
  int camera_channel = 0;  // 0 = R, 1 = G, 2 = B
  std::string minus;    // empty, or a second capture: the channel is (capture − minus)
  std::string name() const;  // "D65'.R", "W57+blue-W57.B"
};

struct PlanDescription {
  std::string name;
  std::vector<PlannedCapture> captures;  // 1-32, in capture order
  std::vector<PlannedChannel> channels;  // empty: every capture's R, G, B
  int dark_frames = 1;                   // 1-1000

  // False with the first offending field named ("captures[2].white_fill: must
  // be in (0, 1]", "channels[0].minus: no capture named 'W56'").
  bool IsValid(std::string* error) const;
  // The channel list in use (channels, or every capture's R, G, B).
  std::vector<PlannedChannel> effective_channels() const;
  int capture_index(const std::string& name) const;  // -1 when absent
};

inline constexpr int kMaxPlannedCaptures = 32;
inline constexpr int kMaxPlannedChannels = 64;
inline constexpr int kMaxPlannedFrames = 1000;

// The built-in plans, their mixes solved from `library` with the session mix
// solver (calibration::solve_session_mix, objective "camera") as a session
// would get them:
//   "standard"        D65', W57, W57+blue; channels D65'.R, G, B and
//                     (W57+blue − W57).B (the seed method's four: the
//                     sessions' standard plan)
//   "standard-blue"   D65' and the blue LED alone; channels D65'.R, G, B and
//                     blue.B (the blue channel well exposed)
//   "multispectral"   each LED type alone at full drive; 18 channels
//   "d65"             D65' alone; R, G, B
//   "w57", "w40", "w27"  one broadband alone (W57 at its level in the w57+blue
//                     solve, W40 and W27 at full drive); R, G, B
//   "d65+blue", "w57+blue", "w40+blue", "w27+blue"  the broadband and the
//                     broadband with the blue LED added at its level in the
//                     w57+blue solve; channels R, G, B of the broadband and
//                     (broadband+blue − broadband).B (the seed's broadband
//                     study, docs/estimation.md "The seed's broadband study")
// A suffix "@N" (e.g. "standard@4") sets every capture's frames to N. The
// names used before one name per plan, "method" and "method-blue", are read
// as "standard" and "standard-blue" (the plan's name is then the new one).
// std::invalid_argument naming the plan for an unknown name.
PlanDescription builtin_plan(const std::string& name, const calibration::LedLibrary& library);
std::vector<std::string> builtin_plan_names();

// Reads the JSON form (docs/formats/plan-advisor.md). std::invalid_argument
// naming the field for anything malformed or invalid (IsValid included).
PlanDescription plan_from_json(const nlohmann::json& json);
nlohmann::json to_json(const PlanDescription& plan);

}  // namespace chromo::planning
