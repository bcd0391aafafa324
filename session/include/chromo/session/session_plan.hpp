#pragma once
// SessionPlan: a named sequence of steps, each an LED state held while every
// camera takes its frames. The daemon's own form of the API's SessionPlan
// (sessions.proto); stored as JSON in the session folder (plan.json).
//
// The standard session of the method (standard_plan()): dark; then the white
// reference and the subject, each under D65', W57 alone and W57+blue. The
// blue-only response is (W57+blue) − W57, computed later from the stored frames.
//
// Exposure per capture (docs/daemon.md "Exposure per capture"): a white step
// with meter_white_share > 0 is metered: before its frames the sequencer
// takes metering frames of the white target under the step's light and sets,
// per camera, the exposure that puts the white's brightest colour channel at
// that share of full scale (exposure_us is only the first guess). A step with
// exposure_from = NAME takes its frames at the exposure the earlier white step
// NAME metered for each camera, so a subject and its white reference share one
// exposure. Metering needs software timing (hardware-timed plans arm every
// state before the first frame).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "chromo/drivers/led_controller.hpp"

namespace chromo::session {

enum class Timing { kSoftware, kHardware };
enum class StepRole { kDark, kWhite, kSubject };

struct Illumination {
  enum class Kind { kDark, kWeights, kMix } kind = Kind::kDark;
  drivers::DriveLevels weights{};  // kWeights
  std::string mix;                 // kMix: "d65", "w57[:R]", "w57+blue[:R]"
};

struct Step {
  std::string name;
  StepRole role = StepRole::kSubject;
  Illumination illumination;
  std::uint32_t settle_ms = 0;
  double exposure_us = 20000;
  std::uint32_t frames_per_camera = 1;
  std::string prompt;  // non-empty: pause before the step until resumed
  double meter_white_share = 0;  // (0, 1]: meter this white step (0: exposure_us as given)
  std::string exposure_from;     // the earlier metered white step whose exposure this step uses
  // Subject exposure metering (docs/daemon.md "Exposure per capture"; a
  // subject step with exposure_from): > 0, before its frames the sequencer
  // takes one metering frame of the subject at its white's exposure and
  // multiplies that exposure by g (session::subject_exposure_ratio) so the
  // subject_percentile of its brightest channel sits at subject_fill of full
  // scale, g in [1, max_subject_exposure_ratio]; the white is scaled by g in
  // the albedo (method_measurement.hpp).
  double subject_fill = 0;                 // 0 (off) or (0, 1)
  double subject_percentile = 0.99;        // (0, 1]
  double max_subject_exposure_ratio = 8;   // [1, 64]
  std::string subject_ratio_from;          // an earlier subject-metered step whose g this step takes
  // A white step after the subjects: the white of the subject step named
  // here (its illumination) at that subject's white's exposure divided by
  // its g, the second exposure that checks the camera's linearity over the
  // ratio g (IlluminatedCapture::white_linearity; docs/daemon.md "Subject
  // exposure"). Names an earlier subject-metered step (subject_metered()).
  std::string linearity_of;
  // The light's polarisation (docs/polarisation.md), for every LED type of the
  // step's state; JSON "polarisation", absent = unpolarised. A plan's lit steps
  // are either cross or unpolarised; parallel steps may join either.
  drivers::Polarisation polarisation = drivers::Polarisation::kUnpolarised;
  bool metered() const { return meter_white_share > 0 || !exposure_from.empty(); }
  bool subject_metered() const { return subject_fill > 0 || !subject_ratio_from.empty(); }
};

struct SessionPlan {
  std::string name;
  Timing timing = Timing::kSoftware;
  std::vector<Step> steps;

  // Names the first offending field, e.g. "steps[2].exposure_us: must be in (0, 10000000]".
  bool IsValid(std::string* error) const;
  std::uint64_t frames_per_camera_total() const;
};

struct StandardPlanOptions {
  Timing timing = Timing::kSoftware;
  double exposure_us = 20000;
  std::uint32_t frames_per_camera = 1;  // frames of every subject step
  // Frames of the dark and white reference steps (0: frames_per_camera).
  // The albedo divides each pixel by its white reference, so the white's own
  // noise adds to every pixel's; averaging more reference frames removes it
  // without lengthening the time the subject must hold still
  // (docs/daemon.md "Reference frames").
  std::uint32_t reference_frames = 0;
  std::uint32_t settle_ms = 50;
  bool operator_prompts = false;  // pause for "place the white target" / "place the subject"
  // > 0: exposure per capture: the whites of D65' and W57+blue are metered to
  // this share of full scale, the W57 white and every subject take the
  // exposure of their illumination's metered white (W57 shares W57+blue's, so
  // the blue-only difference is formed at one exposure). 0: exposure_us for all.
  double meter_white_share = 0;
  // > 0: the W57+blue mix is "w57+blue:R" and W57 "w57:R" with R = blue_ratio
  // (the blue LED's camera-B response R times W57's); 0: "w57+blue" and "w57".
  double blue_ratio = 0;
  // > 0 (with meter_white_share > 0): each subject metered to this fill
  // (Step::subject_fill); W57+blue's subject is then taken before W57's and
  // W57 takes its ratio (the blue-only difference at one exposure); after the
  // subjects, each subject's white again at its white's exposure ÷ g
  // (white_d65_linearity, white_w57+blue_linearity, white_w57_linearity:
  // Step::linearity_of), the white target back in the sphere.
  double subject_fill = 0;
  double subject_percentile = 0.99;
  double max_subject_exposure_ratio = 8;
  // A sphere with polariser banks (docs/polarisation.md): every lit step
  // cross-polarised (the skin model's diffuse light), then one parallel
  // capture of the broadband light (white_d65_parallel, subject_d65_parallel:
  // parallel − cross is the surface layer). false: the unpolarised plan of before.
  bool polarised = false;
};
SessionPlan standard_plan(const StandardPlanOptions& options = {});

// The built-in multispectral plan ("multispectral"): dark; then for each of
// the six LED types alone at full drive (weights: that type 1, the others
// 0) its white reference and the subject. 6 illumination states × R, G, B =
// 18 channels for the estimator (build_measurement). With
// with_method_states (plan "multispectral+method") the method's three mixes
// (d65, w57, w57+blue) follow, each with its white: 9 states, 27 channels.
// Steps: all white references first, then the subjects (the subject holds
// still from its first exposure to its last), as in standard_plan().
SessionPlan multispectral_plan(const StandardPlanOptions& options = {}, bool with_method_states = false);

// Names of the built-in plans: "standard", "multispectral", "multispectral+method".
std::vector<std::string> builtin_plan_names();
// A built-in plan by name (std::nullopt for another name).
std::optional<SessionPlan> builtin_plan(const std::string& name, const StandardPlanOptions& options = {});

// A plan's timing summary for `chromo session plans`: the illumination states
// that have a subject step (captures), the estimator's channels (the
// method's four for its standard session, else R, G, B per capture), and
// the capture time, split as the issue asks:
// subject_time_s from the first subject exposure's start to the last one's
// end (settle, exposure × frames of every subject step; the time the
// subject must hold still), reference_time_s the same sum over the dark and
// white steps (reported apart: they need no subject). A capture may later
// carry its own exposure and frame count (the per-step fields already do):
// the sums read them per step.
struct PlanTiming {
  int captures = 0;
  int channels = 0;
  double subject_time_s = 0;
  double reference_time_s = 0;
  std::uint64_t frames_per_camera = 0;
};
PlanTiming plan_timing(const SessionPlan& plan);

// A plan file (JSON, the "plan" object of docs/formats/session.md, or an
// object holding it under "plan"): parsed and validated. Throws
// std::invalid_argument naming the file and the first bad field
// ("steps[2].exposure_us: ...").
SessionPlan read_plan_file(const std::string& path);

// Bounds shared with the API's validation.
inline constexpr std::size_t kMaxNameBytes = 64;
inline constexpr std::size_t kMaxTextBytes = 4096;
inline constexpr std::size_t kMaxSteps = 256;
inline constexpr std::uint32_t kMaxFramesPerCamera = 1000;
inline constexpr std::uint32_t kMaxSettleMs = 60000;
inline constexpr double kMaxExposureUs = 10e6;
// No camera exposes shorter than a microsecond (GigE Vision cameras: 1-100 µs);
// 1e-300 passed validation once and failed only at the camera.
inline constexpr double kMinExposureUs = 1;
// "" when `text` holds no control character, else what is wrong ("control
// character 0x1b at byte 4"): C0 controls (NUL, ESC, ...), DEL and the C1
// controls as UTF-8 (U+0080-U+009F), which a terminal may act on when the
// text is printed; tab and newline only when `multiline`.
std::string control_character_error(const std::string& text, bool multiline = false);
// [A-Za-z0-9_+.-]{1,64}
bool is_valid_name(const std::string& name);
// "d65", "w57", "w57+blue", "w57+blue:R" or "w57:R" with R in (0, 100]
// ("w57:R": W57 alone at its level in the "w57+blue:R" mix).
bool is_valid_mix(const std::string& mix);

// The illumination state of a step, which pairs a white reference with its
// subject step: the one rule of the capture builder, the rendered session
// and the plan advisor.
//   key:  the mix without its blue ratio ("d65", "w57", "w57+blue"), or the
//         LED weights ("weights:0,0,0,0,0,1"); "" for a dark or unlit step;
//         ":parallel" appended for a parallel-polarised step, so a white
//         reference pairs with subjects of its own polarisation state (cross
//         and unpolarised steps are the method's captures and never meet in
//         one plan)
//   name: the mix without its ratio, or the step's name without its role's
//         prefix ("subject_", "white_"); "" when the key is; " parallel"
//         appended for a parallel step
struct IlluminationState {
  std::string key;
  std::string name;
};
IlluminationState illumination_state(const Step& step);
// A capture's name among a measurement's channel names: D65', W57 and
// W57+blue for the method's mixes ("D65' parallel" for its parallel
// capture), else the state's name.
std::string capture_name(const IlluminationState& state);

nlohmann::json to_json(const SessionPlan& plan);
// Drive levels as the plan's JSON writes weights: {"W57": 0.8, ..., "B": 0.4},
// every LED type; reading takes a missing type as 0 (the object is checked by
// read_plan_file where it comes from an operator).
nlohmann::json drive_levels_to_json(const drivers::DriveLevels& levels);
drivers::DriveLevels drive_levels_from_json(const nlohmann::json& weights);
// Throws std::invalid_argument naming the field.
SessionPlan plan_from_json(const nlohmann::json& json);
std::string role_name(StepRole role);
std::string timing_name(Timing timing);
// "unpolarised", "cross", "parallel" (the plan's JSON values); nullopt for another text.
std::optional<drivers::Polarisation> parse_polarisation(const std::string& text);

}  // namespace chromo::session
