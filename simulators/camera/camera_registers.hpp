#pragma once
// The camera simulator's own registers (device-specific block above the
// GigE Vision bootstrap registers) and the GenICam description that names
// them. docs/protocols/gige-vision.md has the table; keep the two in step.
#include <cstdint>
#include <string>

namespace chromo::simulators::camera_registers {

inline constexpr std::uint32_t kBase = 0x10000;
inline constexpr std::uint32_t kCount = 32;  // registers reserved in the block
inline constexpr std::uint32_t kSensorWidth = kBase + 0x00;       // RO, pixels
inline constexpr std::uint32_t kSensorHeight = kBase + 0x04;      // RO, pixels
inline constexpr std::uint32_t kWidth = kBase + 0x08;
inline constexpr std::uint32_t kHeight = kBase + 0x0C;
inline constexpr std::uint32_t kOffsetX = kBase + 0x10;
inline constexpr std::uint32_t kOffsetY = kBase + 0x14;
inline constexpr std::uint32_t kPixelFormat = kBase + 0x18;       // PFNC code
inline constexpr std::uint32_t kAcquisitionMode = kBase + 0x20;   // 1 Continuous, 2 SingleFrame
inline constexpr std::uint32_t kAcquisitionStart = kBase + 0x24;  // command: write 1
inline constexpr std::uint32_t kAcquisitionStop = kBase + 0x28;   // command: write 1
inline constexpr std::uint32_t kFramePeriodUs = kBase + 0x2C;     // free-run period, 1000-10000000 us
inline constexpr std::uint32_t kExposureUs = kBase + 0x30;        // 10-10000000 us
inline constexpr std::uint32_t kGainCentiDb = kBase + 0x34;       // 0-2400 (hundredths of a dB)
inline constexpr std::uint32_t kTriggerMode = kBase + 0x38;       // 0 Off, 1 On (FrameStart)
inline constexpr std::uint32_t kTriggerSource = kBase + 0x3C;     // 0 Line0, 1 Software
inline constexpr std::uint32_t kTriggerActivation = kBase + 0x40; // 0 RisingEdge
inline constexpr std::uint32_t kTriggerSoftware = kBase + 0x44;   // command: write 1
inline constexpr std::uint32_t kAcquisitionActive = kBase + 0x48; // RO, 1 while acquiring
inline constexpr std::uint32_t kChunkModeActive = kBase + 0x4C;   // 0/1; not while acquiring
inline constexpr std::uint32_t kChunkSelector = kBase + 0x50;     // 0 TriggerCount (the only chunk)
inline constexpr std::uint32_t kChunkEnable = kBase + 0x54;       // 0/1, of the selected chunk; not while acquiring

// Chunk data (GVSP payload type 0x4001): [image][image id, length][count u64
// big-endian][TriggerCount id, length]; ids and lengths big-endian u32.
inline constexpr std::uint32_t kImageChunkId = 0x00000001;
inline constexpr std::uint32_t kTriggerCountChunkId = 0x54524743;  // "TRGC"
inline constexpr std::uint32_t kTriggerCountChunkBytes = 8;
inline constexpr std::uint32_t kChunkTrailerBytes = 8;  // id, length
// Bytes the chunks add to a frame: the image's trailer, the count and its trailer.
inline constexpr std::uint32_t kChunkOverheadBytes = 2 * kChunkTrailerBytes + kTriggerCountChunkBytes;

inline constexpr std::uint32_t kModeContinuous = 1, kModeSingleFrame = 2;
inline constexpr std::uint32_t kSourceLine0 = 0, kSourceSoftware = 1;

// The GenICam (GenApi 1.0 schema) description of the registers above plus
// the bootstrap strings, with the sensor size in the limits.
std::string genicam_xml(const std::string& model_name);

}  // namespace chromo::simulators::camera_registers
