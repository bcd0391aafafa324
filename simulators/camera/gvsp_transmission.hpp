#pragma once
// GVSP packets of one image block (leader, payload, trailer) and the order in
// which a block's first transmission goes out under fault injection
// (gige_vision_device.hpp, docs/protocols/gige-vision.md). Private to the
// device side.
#include <netinet/in.h>

#include <cstdint>
#include <functional>
#include <vector>

#include "chromo/simulators/camera/gige_vision_device.hpp"

namespace chromo::simulators::gige {

// A sent block, kept for resends.
struct GvspBlock {
  std::uint16_t block_id = 0;
  GvspImageBlock image;                  // payload never null
  std::uint32_t data_bytes_per_packet = 0;  // SCPS − 36 at send time
  std::uint32_t payload_packets = 0;
  sockaddr_in destination{};
  std::uint32_t last_packet_id() const { return payload_packets + 1; }  // the trailer
};

// Packet `packet_id` of `block` (0 leader, 1..n payload, n+1 trailer) into `out`.
void build_gvsp_packet(const GvspBlock& block, std::uint32_t packet_id, std::vector<std::uint8_t>& out);
// A header-only packet with status PACKET_UNAVAILABLE (the answer to a
// resend request for a block no longer kept).
std::vector<std::uint8_t> gvsp_unavailable_packet(std::uint16_t block_id, std::uint32_t packet_id);

struct TransmissionCounts {
  std::uint64_t dropped = 0, delayed = 0, reordered = 0;
};

// Calls send(id) for packet ids 0..last_packet_id in the order the faults
// make: each id is dropped, held back `delay_us` (sent once due, after later
// packets; the call sleeps until the last held one went), swapped with the
// next id, or sent in turn. `roll` gives uniform numbers in [0, 1).
TransmissionCounts transmit_with_faults(std::uint32_t last_packet_id, const GvspFaultOptions& faults,
                                        const std::function<double()>& roll,
                                        const std::function<void(std::uint32_t)>& send);

}  // namespace chromo::simulators::gige
