#pragma once
// FrameRecord: one frame's facts, typed, from the sequencer that took it to
// storage, the on-line estimator and derived data. JSON exists only at the
// journal's edge: to_json() makes the journal's "frame" record (and the TIFF's
// ImageDescription), frame_record_from_json() reads it back
// (docs/formats/session.md lists the fields; formats 1 and 2 write the same
// record).
//
// Lifetime: a plain value; the frame's samples travel beside it
// (daemon::CapturedFrame, or a TIFF read back from the folder).

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "chromo/drivers/camera.hpp"
#include "chromo/drivers/led_controller.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::session {

// The LED controller's state for the frame (read at the step's start).
struct FrameLedState {
  // What the frame was taken under: the levels the controller reported
  // applied (software timing) or the armed state (hardware timing).
  drivers::DriveLevels drive{};
  drivers::DriveLevels requested_drive{};
  std::array<double, drivers::kLedTypeCount> temperature_C{};  // per channel, kAllLedTypes order
  // true: temperature_C (and the faults) were read just before this frame's
  // trigger (JSON "temperatures_at": "trigger", since 7 Dec 2026); false: the
  // step's first reading, right after its state was set (records of before).
  bool temperatures_at_trigger = false;
  std::array<std::uint32_t, drivers::kLedTypeCount> channel_faults{};
  std::uint32_t controller_faults = 0;
  int sequence_position = -1;  // in an armed sequence; -1 when none
  // Which bank each LED type was driven through (docs/polarisation.md), as
  // drive: applied (software timing) or armed (hardware timing). JSON
  // "polarisation": {"W57": "cross", ...}, only the types not unpolarised,
  // absent when all are (records of before polarisation read as unpolarised).
  drivers::PolarisationPerType polarisation{};

  bool operator==(const FrameLedState&) const = default;
};

struct FrameRecord {
  // Storage: set by the pipeline's storage thread when the frame is stored.
  std::uint64_t index = 0;  // session-wide storage order
  std::string file;         // relative to the session folder, "frames/<step>/<camera>-<sequence>.tiff"

  // Where in the plan.
  std::string step;
  int step_index = 0;
  StepRole role = StepRole::kSubject;
  std::uint32_t frame_in_step = 0;
  double exposure_us = 0;
  // The LED state; absent only in records that had none (a reader of old or
  // hand-made folders must cope; the sequencer always sets it).
  std::optional<FrameLedState> led;

  // From the camera (drivers::Frame).
  std::string camera;                 // the device's configured name
  std::uint64_t sequence = 0;         // driver's, consecutive per stream
  std::uint64_t camera_frame_id = 0;
  std::uint64_t camera_timestamp_ns = 0;
  std::int64_t host_timestamp_ns = 0;  // system clock, since the Unix epoch
  // The trigger the frame answered: the LED controller's pulse number (every
  // camera's frame of one capture has the same), 0 in records without one;
  // and the camera's own count of that trigger since its stream started
  // (chunk data), 0 when the camera sent none.
  std::uint64_t trigger_id = 0;
  std::uint64_t camera_trigger_count = 0;
  int width = 0, height = 0;
  drivers::PixelFormat pixel_format = drivers::PixelFormat::kMono8;

  bool operator==(const FrameRecord&) const = default;
};

// The "led" object of the journal's frame and step_started records.
nlohmann::json to_json(const FrameLedState& led);
// The journal's "frame" record ("type": "frame"; "t" is added by the journal).
nlohmann::json to_json(const FrameRecord& record);
// Reads a journal "frame" record. Required: index, file, step, camera, width,
// height, pixel_format; the rest defaults as in FrameRecord (led absent when
// the record has no "led" object with a "drive"). Throws std::invalid_argument
// naming the field for a missing or malformed one (an unknown LED type in
// led.drive, an unknown pixel format, a wrong JSON type).
FrameRecord frame_record_from_json(const nlohmann::json& json);

}  // namespace chromo::session
