#pragma once
// GigE Vision wire constants and big-endian helpers of the device side
// (GVCP: control on UDP 3956, GVSP: stream). Values from the GigE Vision
// specification as Aravis names them (arvgvcpprivate.h, arvgvspprivate.h);
// docs/protocols/gige-vision.md lists what the device implements.
#include <cstddef>
#include <cstdint>

namespace chromo::simulators::gige {

inline constexpr int kGvcpPort = 3956;
inline constexpr std::uint8_t kCommandKey = 0x42;          // first byte of every GVCP command
inline constexpr std::uint8_t kFlagAckRequired = 0x01;
inline constexpr std::uint8_t kFlagExtendedIds = 0x10;     // PACKETRESEND with 64-bit block id
inline constexpr std::size_t kGvcpHeaderBytes = 8;
inline constexpr std::size_t kGvcpMaxDataBytes = 540;      // a command's payload at most
inline constexpr std::size_t kMemoryAccessMaxBytes = 536;  // READMEM/WRITEMEM data at most

enum Command : std::uint16_t {
  kDiscoveryCmd = 0x0002, kDiscoveryAck = 0x0003,
  kPacketResendCmd = 0x0040,
  kReadRegCmd = 0x0080, kReadRegAck = 0x0081,
  kWriteRegCmd = 0x0082, kWriteRegAck = 0x0083,
  kReadMemCmd = 0x0084, kReadMemAck = 0x0085,
  kWriteMemCmd = 0x0086, kWriteMemAck = 0x0087,
};

// GVCP status codes (the 16-bit status field of an acknowledge).
enum Status : std::uint16_t {
  kStatusSuccess = 0x0000,
  kStatusNotImplemented = 0x8001,
  kStatusInvalidParameter = 0x8002,
  kStatusInvalidAddress = 0x8003,
  kStatusWriteProtect = 0x8004,
  kStatusBadAlignment = 0x8005,
  kStatusAccessDenied = 0x8006,
  kStatusBusy = 0x8007,
  kStatusPacketUnavailable = 0x800C,
  kStatusInvalidHeader = 0x800E,
};

// Bootstrap registers (GigE Vision device, first 64 KiB of the address space).
namespace bootstrap {
inline constexpr std::uint32_t kVersion = 0x0000;
inline constexpr std::uint32_t kDeviceMode = 0x0004;          // bit 31: big-endian registers
inline constexpr std::uint32_t kMacHigh = 0x0008;
inline constexpr std::uint32_t kMacLow = 0x000C;
inline constexpr std::uint32_t kSupportedIpConfig = 0x0010;
inline constexpr std::uint32_t kCurrentIpConfig = 0x0014;
inline constexpr std::uint32_t kCurrentIp = 0x0024;
inline constexpr std::uint32_t kCurrentSubnetMask = 0x0034;
inline constexpr std::uint32_t kCurrentGateway = 0x0044;
inline constexpr std::uint32_t kManufacturerName = 0x0048;    // 32 bytes
inline constexpr std::uint32_t kModelName = 0x0068;           // 32 bytes
inline constexpr std::uint32_t kDeviceVersion = 0x0088;       // 32 bytes
inline constexpr std::uint32_t kManufacturerInfo = 0x00A8;    // 48 bytes
inline constexpr std::uint32_t kSerialNumber = 0x00D8;        // 16 bytes
inline constexpr std::uint32_t kUserDefinedName = 0x00E8;     // 16 bytes, writable
inline constexpr std::uint32_t kDiscoveryDataBytes = 0x00F8;  // DISCOVERY_ACK carries 0x0000-0x00F7
inline constexpr std::uint32_t kXmlUrl0 = 0x0200;             // 512 bytes
inline constexpr std::uint32_t kXmlUrl1 = 0x0400;             // 512 bytes
inline constexpr std::uint32_t kNetworkInterfaces = 0x0600;
inline constexpr std::uint32_t kMessageChannels = 0x0900;
inline constexpr std::uint32_t kStreamChannels = 0x0904;
inline constexpr std::uint32_t kGvcpCapability = 0x0934;
inline constexpr std::uint32_t kHeartbeatTimeout = 0x0938;    // ms
inline constexpr std::uint32_t kTickFrequencyHigh = 0x093C;
inline constexpr std::uint32_t kTickFrequencyLow = 0x0940;
inline constexpr std::uint32_t kTimestampControl = 0x0944;    // bit 1: latch, bit 0: reset
inline constexpr std::uint32_t kTimestampValueHigh = 0x0948;
inline constexpr std::uint32_t kTimestampValueLow = 0x094C;
inline constexpr std::uint32_t kControlChannelPrivilege = 0x0A00;  // bit 1 control, bit 0 exclusive
inline constexpr std::uint32_t kStreamPort = 0x0D00;          // SCP0: host port (low 16 bits)
inline constexpr std::uint32_t kStreamPacketSize = 0x0D04;    // SCPS0: packet size (low 16 bits), bit 31 fire test
inline constexpr std::uint32_t kStreamPacketDelay = 0x0D08;   // SCPD0
inline constexpr std::uint32_t kStreamDestination = 0x0D18;   // SCDA0: host IPv4 address
inline constexpr std::uint32_t kStreamSourcePort = 0x0D1C;    // SCSP0: the device's stream source port
inline constexpr std::uint32_t kEnd = 0x10000;
inline constexpr std::uint32_t kCapabilityWriteMemory = 1u << 1;
inline constexpr std::uint32_t kCapabilityPacketResend = 1u << 2;
inline constexpr std::uint32_t kCapabilityUserDefinedName = 1u << 31;
inline constexpr std::uint32_t kCapabilitySerialNumber = 1u << 30;
inline constexpr std::uint32_t kPrivilegeControl = 1u << 1;
inline constexpr std::uint32_t kPrivilegeExclusive = 1u << 0;
}  // namespace bootstrap

// GVSP: 8-byte header {status:16, block_id:16, format:8 (bit 7 extended ids), packet_id:24}.
inline constexpr std::size_t kGvspHeaderBytes = 8;
inline constexpr std::size_t kIpUdpOverheadBytes = 28;  // SCPS counts the IP and UDP headers
inline constexpr std::uint8_t kGvspLeader = 0x01;
inline constexpr std::uint8_t kGvspTrailer = 0x02;
inline constexpr std::uint8_t kGvspPayload = 0x03;
inline constexpr std::uint16_t kPayloadTypeImage = 0x0001;
inline constexpr std::uint16_t kPayloadTypeChunkFlag = 0x4000;  // "extended chunk": the block ends in chunks

inline void put16(std::uint8_t* at, std::uint16_t value) {
  at[0] = static_cast<std::uint8_t>(value >> 8);
  at[1] = static_cast<std::uint8_t>(value);
}
inline void put32(std::uint8_t* at, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) at[i] = static_cast<std::uint8_t>(value >> (24 - 8 * i));
}
inline std::uint16_t get16(const std::uint8_t* at) { return static_cast<std::uint16_t>(at[0] << 8 | at[1]); }
inline std::uint32_t get32(const std::uint8_t* at) {
  return static_cast<std::uint32_t>(at[0]) << 24 | static_cast<std::uint32_t>(at[1]) << 16 |
         static_cast<std::uint32_t>(at[2]) << 8 | at[3];
}

}  // namespace chromo::simulators::gige
