#pragma once
// Frames of a session → the estimator's captures (session/method_measurement.hpp). The one place where session frames
// become a measurement: the on-line estimator feeds frames as they arrive,
// `chromo estimate SESSION_DIR` feeds the stored ones (read_session_captures),
// so both give bit-identical captures for the same frames (a TIFF holds the
// frame's samples unchanged).
//
// Which step is which: the dark step (role dark), and per illumination state
// one white and one subject step, paired by their illumination
// (illumination_state(), session_plan.hpp): the same mix ("d65", "w57",
// "w57+blue"; "w57:R" and "w57+blue:R" with any blue ratio R) or the same LED
// drive weights.
// A plan without a dark, with a subject state that has no white (or a white
// no subject), with an unlit white or subject step, or with a state twice, is
// refused: the constructor throws std::invalid_argument saying what is
// missing. Every plan gives Captures (captures()), in plan order with
// the default recipe (R, G, B of every capture: the multispectral plans, an
// operator's); the standard plan (subjects under exactly d65, w57 and
// w57+blue, and d65:parallel on a polarised sphere: is_standard_plan())
// gives D65', W57, W57+blue in that order with standard_recipe(), D65'
// parallel as Captures::parallel with the sources' surface factors.
//
// Cameras: every camera's frames are kept apart, under any plan: each camera
// has its own sums per step, so its dark, white references, exposures and
// subject captures are its own, and captures(camera) never holds another
// camera's frame. cameras() lists them in the order their
// first frame came; the overloads without a camera are the first camera's
// (camera()).
//
// One sum: a camera's frames are summed per step exactly as they came, once,
// in a SessionFrameSums (frame_sums.hpp: the accumulator derived data is
// written from). The builder either owns it (add_frame with the samples:
// `chromo estimate`, tests) or reads the one the storage thread fills
// (constructed with stored_sums, add_summed_frame with the record alone:
// chromod's on-line estimator, so a frame is summed once and a skipped frame
// is caught up from its journal record, not its TIFF). Either way the
// builder counts each step's frames and their illuminants itself, and reads
// a step's sum only once all its frames are in (an incomplete step's image
// is empty): the storage thread adds no more to it by then. A sum that holds
// other than the frames the builder counted (the storage thread refused one)
// makes captures() throw naming the step.
//
// The mean is taken when the captures are made (each image carries its frame
// count and exposure; a step's frames must share one exposure, else
// add_frame throws naming the step): BayerRG frames binned 2×2 (R,
// mean of the two G, B per cell: half resolution, colours without
// interpolation), RGB8 used as is, mono formats refused. Values are in units
// of the format's full scale (255, 4095, 65535).
//
// Illuminant of a step: Σ_type drive(type)·spectrum_per_unit_drive(type) of
// the LED library, with drive the levels the controller reported applied
// (FrameRecord::led->drive), averaged over the step's frames.
//
// Thread rules: one thread at a time per builder (the stored sums it reads
// may be filled by another thread meanwhile: SessionFrameSums' rules).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "chromo/calibration/led_library.hpp"
#include "chromo/session/frame_sums.hpp"
#include "chromo/session/illuminant_mean.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/session/session_provenance.hpp"
#include "chromo/session/method_measurement.hpp"

namespace chromo::session {

struct CameraSensitivitySource {
  spectral::CameraSensitivity sensitivity;
  std::string source;  // "builtin:nikon_d5100" or a CSV path
};

// A measured LED library of one polarisation state and where it came from.
struct StateLedLibrary {
  calibration::LedLibrary library;
  std::string source;  // the file it was loaded from (for the report)
};

struct CaptureSources {
  calibration::LedLibrary led_library;
  std::string led_library_source;  // where it came from (for the report)
  spectral::CameraSensitivity camera;  // every camera's unless camera_of names it
  std::string camera_source;       // "builtin:nikon_d5100" or a CSV path
  double white_reflectance = 0.99;
  // Per camera (by the frames' camera name): its own spectral sensitivity.
  std::map<std::string, CameraSensitivitySource> camera_of;
  CameraSensitivitySource sensitivity_of(const std::string& camera_name) const;
  // A sphere with polariser banks (docs/polarisation.md "Calibration per
  // state"): the measured library of kCross / kParallel light. A frame's LED
  // type lit in a state found here takes its illuminant from that library,
  // in any other state from led_library.
  std::map<drivers::Polarisation, StateLedLibrary> led_library_of_state;
  const calibration::LedLibrary& library_for(drivers::Polarisation state) const;
  // The polariser films as the estimator knows them (surface_factors.hpp):
  // given, a polarised session's surface maps are extinction-corrected and
  // its cross captures lose their highlights' surface light; none, both are
  // as captured and the report says the films were not given.
  std::optional<SurfaceFactors> surface_factors;
};

// A session's results keep the libraries its illuminants came from, so that
// `chromo estimate SESSION_DIR` reproduces its maps from the folder alone:
// led_library.json and, per polarisation state, led_library-<state>.json
// ("led_library-cross.json"). The file name of a state's library:
std::string session_state_library_file(drivers::Polarisation state);
// Loads every led_library-<state>.json of `results_folder` into
// sources.led_library_of_state (none: unchanged). Throws
// std::invalid_argument naming the file when one is unreadable.
void load_session_state_libraries(const std::filesystem::path& results_folder, CaptureSources& sources);
// For summary.json: {"cross": source, "parallel": source} of the states in
// sources.led_library_of_state ({} when none: every frame lit from led_library).
std::map<std::string, std::string> state_library_sources(const CaptureSources& sources);

// `led_library` naming the built-in nominal library (a daemon without a
// library of its own: never another daemon's or the user's newest).
inline constexpr const char* kNominalLedLibrary = "nominal";

// The sources chromod uses: the LED library at `led_library` (empty: the
// newest measured one in calibration::led_library_directory(), else the
// nominal built-in one; kNominalLedLibrary: the nominal one), the camera "builtin:NAME" or a CSV of
// wavelength_nm,R,G,B, ρ_white, and per camera name a sensitivity of the
// same kinds (camera_of). Throws std::invalid_argument naming the file
// (estimation.camera_sensitivities["NAME"]: … for a camera's).
CaptureSources resolve_capture_sources(const std::string& led_library, const std::string& camera,
                                       double white_reflectance,
                                       const std::map<std::string, std::string>& camera_of = {});

class SessionCaptureBuilder {
 public:
  // stored_sums null: the builder sums the frames given to add_frame itself;
  // else it reads that object's sums, which another thread fills with every
  // frame before the builder is told of it (add_summed_frame).
  SessionCaptureBuilder(const SessionPlan& plan, CaptureSources sources,
                        std::shared_ptr<const SessionFrameSums> stored_sums = nullptr);
  SessionCaptureBuilder(SessionCaptureBuilder&&) = default;
  SessionCaptureBuilder& operator=(SessionCaptureBuilder&&) = default;

  // One frame: samples as the camera sent them (16-bit samples in host
  // order), described by its record (step, camera, geometry, pixel format, the
  // applied LED levels), added to its camera's sums. Throws
  // std::invalid_argument naming the step and camera for a frame that cannot
  // be used (mono, odd size, size change, unknown step, no LED levels on a
  // lit step, an exposure unlike the step's other frames); nothing is added
  // then. std::logic_error on a builder reading stored sums.
  void add_frame(const FrameRecord& record, std::span<const std::uint8_t> samples);
  // One frame whose samples the stored sums already hold: counted, its
  // illuminant added; throws as add_frame (but for the size change, which
  // captures() finds), std::logic_error on a builder without stored sums.
  void add_summed_frame(const FrameRecord& record);
  // The builder reads stored sums (add_summed_frame, not add_frame).
  bool reads_stored_sums() const { return reads_stored_sums_; }

  // The cameras that delivered frames, in the order of their first frame.
  const std::vector<std::string>& cameras() const { return cameras_; }
  // The first of them ("" before any frame).
  const std::string& camera() const;

  // The camera's dark and white steps have all their frames (a camera with
  // no frames has none).
  bool references_complete(const std::string& camera) const;
  // Every step of the plan has all the camera's frames.
  bool complete(const std::string& camera) const;
  // What the camera still misses, e.g. "subject_w57: 0 of 1 frames" (empty when complete).
  std::string missing(const std::string& camera) const;
  bool references_complete() const { return references_complete(camera()); }
  bool complete() const { return complete(camera()); }
  std::string missing() const { return missing(camera()); }

  // Where the camera's spectral sensitivity came from (CaptureSources::camera_source).
  std::string sensitivity_source(const std::string& camera) const;

  // The plan's subjects are under exactly the standard plan's three mixes
  // (and D65' parallel on a polarised sphere): its captures carry standard_recipe().
  bool is_standard_plan() const { return standard_plan_; }

  // The camera's captures (its frames only), as the header says. Throws
  // std::logic_error unless references_complete(camera) (subjects then empty).
  Captures captures(const std::string& camera) const;
  Captures captures() const { return captures(camera()); }

 private:
  struct StepSum {
    std::string step;
    std::uint32_t expected = 0;
    std::uint32_t frames = 0;  // one camera's frames of the step counted so far (their samples: sums_)
    IlluminantMean illuminant;  // of the step's frames
    double exposure_us = 0;  // of the step's frames (all alike)
  };
  // Keys: "dark", "white:d65", "subject:d65", "white:w57", ..., "linearity:d65" (a linearity white)
  using StepSums = std::map<std::string, StepSum>;
  // Checks the frame (throws as add_frame) and returns its step's sum of its camera, and its illuminant.
  std::pair<StepSum*, spectral::Spectrum> checked_step(const FrameRecord& record, StepSums& fresh_camera);
  // Counts a checked frame (its samples are in sums_ by now).
  void count_frame(const FrameRecord& record, StepSum& s, const spectral::Spectrum& illuminant, StepSums& fresh_camera);
  RgbImage mean_image(const std::string& camera, const StepSum& s) const;
  // The camera's capture of an illumination state (its white, subject, linearity white, illuminant).
  IlluminatedCapture capture_of(const std::string& camera, const StepSums& steps, const std::string& state,
                                const std::string& name) const;
  // The state's linearity white ("linearity:<state>", Step::linearity_of) once all its frames are in.
  std::optional<RgbImage> linearity_white(const std::string& camera, const StepSums& steps, const std::string& state) const;
  // The camera's sums (the plan's empty ones for a camera without frames).
  const StepSums& sums_of(const std::string& camera) const;

  CaptureSources sources_;
  std::shared_ptr<SessionFrameSums> own_sums_;     // the builder's own (no stored sums), else null
  std::shared_ptr<const SessionFrameSums> sums_;   // own_sums_ or the stored sums
  bool reads_stored_sums_ = false;
  StepSums plan_steps_;                        // the plan's steps, no frames
  std::map<std::string, StepSums> by_camera_;  // each camera's own sums
  std::vector<std::string> cameras_;
  std::map<std::string, std::string> key_of_step_;
  // Illumination states with a subject step, in plan order.
  struct State {
    std::string key;           // illumination_state().key
    std::string capture_name;  // capture_name(): D65', W57, W57+blue or the state's name
    std::string subject_step;
  };
  std::vector<State> states_;
  bool standard_plan_ = false;
};

// Adds the session folder's stored frames (journal frame records, TIFFs)
// whose storage index is not in `already_added` and whose record `wanted`
// accepts (empty: every frame); returns how many it added. Throws
// std::invalid_argument naming the file for an unreadable frame.
// unusable (optional): a frame the builder refuses is recorded there under
// its camera (the first reason per camera) instead of thrown, so one
// camera's unusable frames do not stop the others'.
std::size_t add_stored_frames(SessionCaptureBuilder& builder, const std::filesystem::path& folder,
                              const std::set<std::uint64_t>& already_added = {},
                              const std::function<bool(const FrameRecord&)>& wanted = {},
                              std::map<std::string, std::string>* unusable = nullptr);

// A frame filter that takes the first camera it sees and then only its frames
// (the single-camera estimation's choice of camera: the first to deliver).
std::function<bool(const FrameRecord&)> first_camera_only();

// The plan of a session folder (session.json); std::invalid_argument naming
// the folder when it is not a session.
SessionPlan read_session_plan(const std::filesystem::path& folder);
// What the session was made with (session.json's provenance; recorded false
// for an older session); std::invalid_argument naming the file and key when
// it is not a session or the provenance is malformed.
SessionProvenance read_session_provenance(const std::filesystem::path& folder);

// The stored frames of a session folder's first camera (its journal's frame
// records, TIFFs) through a SessionCaptureBuilder, any plan. Throws
// std::invalid_argument naming the folder and what is wrong (not a session,
// frames missing, unreadable TIFF).
Captures read_session_captures(const std::filesystem::path& folder, const CaptureSources& sources);

// Every camera's stored frames of a session folder in one builder (the
// per-camera estimation, maps/camera_results.hpp). Throws
// std::invalid_argument naming the folder (not a session, no frame stored,
// an unreadable TIFF, or the frames of a one-camera session incomplete); a
// camera of several with missing frames is left to the caller
// (complete(camera), missing(camera)).
// unusable: as add_stored_frames (a session of several cameras; with one
// camera its refused frame is thrown).
SessionCaptureBuilder read_stored_session(const std::filesystem::path& folder, const CaptureSources& sources,
                                          std::map<std::string, std::string>* unusable = nullptr);

}  // namespace chromo::session
