#pragma once
// Sequencer: runs one session plan on the devices.
//
// In parts (daemon/src/capture/), each with its thread rules at its top:
// sequencer.cpp the steps loop (LED state, settle, hazard check, a step's
// captures to the pipeline); synchronised_capture.hpp one capture = every
// camera's frame of one trigger, retaken until complete; metering_policy.hpp
// each step's exposure per camera; run_control.hpp the operation's state,
// pauses, the one progress/ETA and the LED controller's calls.
//
// At the start the LED controller's output stage is switched on (states are
// applied but not emitted while it is off). Software timing, per step: (prompt: pause until resumed) → resolve the LED
// state (explicit weights, a mix, or dark) → LedController::set_state, which
// returns once the controller acknowledged it → read its status (drive levels
// and temperatures go into the step's journal record and every frame's) →
// settle_ms → configure exposure (cameras take settings only while not
// streaming: when the exposure changes the streams stop, the cameras are
// configured with the configuration's pixel format/ROI/gain and the step's
// exposure, and the streams start again) → for each frame: one synchronised
// capture (below) → the step is complete (journal "step_completed") once its
// frames are stored (FramePipeline::drain_storage); the next step does not
// wait for the on-line estimator, which prepares its tables from the
// references while the subject steps are captured.
//
// Synchronised capture (docs/camera.md): the LED controller is the trigger
// master. Per capture the sequencer asks it to fire one pulse
// (LedController::fire_trigger, 100 us); the controller numbers it (the
// capture's trigger id) and its trigger output is wired to the trigger input
// of every camera configured with trigger_input ("Line0"), which expose on
// it (hardware trigger). Cameras without trigger_input are software-
// triggered right after the pulse and their frames get the same trigger id
// (the fallback; sub-millisecond alignment then is not guaranteed). Each
// camera counts the triggers it received since its stream started and sends
// the count with the frame (GVSP chunk data, drivers::Frame::trigger_count);
// the sequencer keeps, per camera, which trigger id each count stands for
// (the count restarts with every stream start, so the map is per stream).
// A capture completes when every camera delivered a complete frame whose
// count is the awaited one; then all its frames go to the pipeline, each
// FrameRecord with trigger_id and camera_trigger_count. A camera that
// answered nothing within its longest exposure + frame_timeout_ms, a failed
// frame, or a frame with a count it was never sent (its count and the
// sequencer's disagree: its stream is restarted) spoils the capture: each
// such camera gets a "frame_lost" journal record naming it with the trigger
// id and reason (no_frame, missing_packets, ..., trigger_mismatch), the other
// cameras' frames of that trigger are discarded, a "capture_retaken" record
// and the operation's message say so, and a new trigger is fired for every
// camera. Frames of an earlier trigger arriving later are discarded
// ("frame_discarded", reason late, with the trigger id they answered), never
// stored as a later capture's; so no stored capture mixes triggers. A
// camera without the count chunk has each complete frame taken as the
// awaited trigger's (weaker: a frame later than the timeout would pass).
// After frame_attempts spoiled captures in a row the session pauses naming
// the cameras; resume retries. At the end a "trigger_summary" record gives
// the triggers fired, retakes, discarded frames and per camera the captures
// it missed and its late frames.
//
// Exposure per capture (session_plan.hpp): a white step with
// meter_white_share > 0 is metered after its settle time: per camera, a
// metering frame of the white target (not stored, not given to the pipeline)
// at a first guess, then at the exposure exposure_metering.hpp computes from
// it, until the brightest channel is within 3% of the share, the camera's
// ExposureTime range stops it (the frames are then taken at the limit and the
// journal says what share the white reached), or 6 metering frames. The
// first guess: the step's exposure_us for the first metered step; for later
// ones the previous metered exposure scaled by the LED library's prediction
// of the two whites' brightest channels (predict_white_rgb) when there is
// one. Each metering is a journal record "exposure_metered" (step, camera,
// exposure_us, white_share reached, target, frames, at_limit); the step's
// frames and those of every step naming it in exposure_from are taken at
// that exposure per camera (FrameRecord::exposure_us). Before the first
// subject step, check_hazard (when set) is given the exposures now known:
// a non-empty answer ends the session FAILED with it, before any subject
// frame (the daemon's blue-light hazard limit, session/plan_hazard.hpp).
//
// Hardware timing: the whole sequence (one state per frame) is armed on the
// controller before the first step (SequenceTrigger::kTriggerOutput); it
// advances on the controller's own trigger pulse, before the pulse leaves,
// so light and cameras cannot disagree: the daemon only fires. State 0 of
// the armed sequence is a dark resting state; pulse k moves the controller
// to state k, so capture k is taken under it. The frames' "led.drive" is the
// armed state (the status read at the step's start still shows the previous
// frame's). After a spoiled capture the rest of the sequence is armed again
// from that frame.
//
// Faults:
//  - the LED controller does not answer (DeviceError kTimeout/kDisconnected):
//    the operation is PAUSED with a message naming the controller and the
//    request; resume retries the step; cancel ends it.
//  - a camera misses a capture (above): counted lost with its reason, the
//    capture retaken for every camera up to frame_attempts times, then
//    PAUSED (message names the cameras); resume retries. A camera that does
//    not answer while being configured pauses likewise.
//  - storage fails (disk full): the session ends FAILED at once, with the
//    reason; frames already stored stay intact.
// Cancel is honoured at every frame boundary and during waits; the LEDs are
// switched to dark at the end whatever the outcome.
//
// Thread rules: run() on the session's own thread; everything else it talks
// to (registry, control, pipeline) is thread-safe.

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "chromo/daemon/internal/devices/device_set.hpp"
#include "chromo/daemon/internal/capture/frame_pipeline.hpp"
#include "chromo/daemon/internal/operations/operations.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::daemon {

struct SequencerContext {
  std::string id;
  session::SessionPlan plan;
  session::Journal* journal = nullptr;
  FramePipeline* pipeline = nullptr;
  OperationRegistry* operations = nullptr;
  OperationControl* control = nullptr;
  NamedDevice<drivers::LedController>* led = nullptr;
  std::vector<NamedDevice<drivers::Camera>*> cameras;
  // Drive levels of a named mix; throws std::invalid_argument when unknown.
  // The weights of a named mix for a step in the given polarisation state.
  std::function<drivers::DriveLevels(const std::string& mix, drivers::Polarisation state)> resolve_mix;
  std::function<void(session::StepRole)> place_in_sphere;  // optional (DeviceSet::place_in_sphere)
  // Optional: the white target's camera response (R, G, B, any common scale)
  // under these drive levels, predicted from the LED library and the camera
  // sensitivity; the first guess of a metered exposure after the first.
  std::function<std::optional<std::array<double, 3>>(const drivers::DriveLevels&)> predict_white_rgb;
  // Optional: "" when the plan's blue-light dose with these exposures (per
  // step, the longest over the cameras) is within the limit, else the refusal.
  std::function<std::string(const std::map<std::string, double>& exposure_us_of_step)> check_hazard;
  // Optional: every complete frame a camera delivers, before it is sorted
  // (the live view's preview_hub.hpp); runs on the camera's stream thread.
  std::function<void(const std::string& camera, const drivers::Frame&, double exposure_us)> on_frame_seen;
  std::uint32_t frame_timeout_ms = 3000;
  std::uint32_t frame_attempts = 3;
};

struct SequencerOutcome {
  session::OperationState state = session::OperationState::kSucceeded;
  std::string error;
};

// Runs the plan to its end, a cancel, or a failure; never throws.
SequencerOutcome run_sequence(SequencerContext& context);

}  // namespace chromo::daemon
