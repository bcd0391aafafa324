#pragma once
// The Ocean Optics USB2000+ (and Flame) command set over USB bulk transfers,
// as documented in docs/protocols/spectrometer.md. Constants only: the driver
// (drivers/spectrometer/ocean_optics_messages.cpp) and the simulator
// (simulators/spectrometer/) each encode and parse the bytes themselves.

#include <cstdint>

namespace chromo::drivers::ocean_optics {

inline constexpr std::uint16_t kVendorId = 0x2457;
inline constexpr std::uint16_t kProductIdUsb2000Plus = 0x101E;

// Endpoints (USB2000+ at high speed).
inline constexpr std::uint8_t kEndpointCommandOut = 0x01;  // EP1 out: every command
inline constexpr std::uint8_t kEndpointQueryIn = 0x81;     // EP1 in: information and status replies
inline constexpr std::uint8_t kEndpointSpectrumIn = 0x82;  // EP2 in: spectrum packets

// Commands (first byte sent to kEndpointCommandOut).
inline constexpr std::uint8_t kInitialize = 0x01;          // no reply
inline constexpr std::uint8_t kSetIntegrationTime = 0x02;  // + u32 µs little endian; no reply
inline constexpr std::uint8_t kQueryInformation = 0x05;    // + slot; kInformationReplySize bytes on EP1 in
inline constexpr std::uint8_t kRequestSpectrum = 0x09;     // spectrum on EP2 in
inline constexpr std::uint8_t kQueryStatus = 0xFE;         // kStatusReplySize bytes on EP1 in

// Replies.
inline constexpr int kInformationReplySize = 17;  // 0x05, slot, 15 ASCII bytes NUL-terminated
inline constexpr int kStatusReplySize = 16;
inline constexpr int kSpectrumPacketSize = 512;
inline constexpr std::uint8_t kSpectrumSyncByte = 0x69;  // the one byte after the last pixel

// Information (EEPROM) slots.
inline constexpr std::uint8_t kSlotSerialNumber = 0;
inline constexpr std::uint8_t kSlotWavelengthCoefficient0 = 1;  // slots 1-4: c0..c3
inline constexpr std::uint8_t kSlotStrayLight = 5;
inline constexpr std::uint8_t kSlotNonlinearityCoefficient0 = 6;  // slots 6-13: k0..k7
inline constexpr std::uint8_t kSlotNonlinearityOrder = 14;
inline constexpr int kMaxNonlinearityOrder = 7;

// USB2000+ properties.
inline constexpr int kUsb2000PlusPixelCount = 2048;
inline constexpr std::uint32_t kUsb2000PlusMinIntegrationUs = 1000;
inline constexpr std::uint32_t kUsb2000PlusMaxIntegrationUs = 65000000;  // data sheet: 1 ms to 65 s
inline constexpr double kUsb2000PlusSaturationCounts = 65535;

// Status reply byte offsets.
inline constexpr int kStatusPixelCount = 0;        // u16 LE
inline constexpr int kStatusIntegrationTimeUs = 2; // u32 LE
inline constexpr int kStatusLampEnable = 6;
inline constexpr int kStatusTriggerMode = 7;
inline constexpr int kStatusAcquisitionStatus = 8; // non-zero: a spectrum is ready
inline constexpr int kStatusPacketsInSpectrum = 9;
inline constexpr int kStatusUsbSpeed = 14;         // 0x00 full speed, 0x80 high speed

}  // namespace chromo::drivers::ocean_optics
