#include "gvsp_transmission.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <thread>
#include <utility>

#include "gige_protocol.hpp"

namespace chromo::simulators::gige {

void build_gvsp_packet(const GvspBlock& block, std::uint32_t packet_id, std::vector<std::uint8_t>& out) {
  const auto& payload = *block.image.payload;
  auto header = [&](std::uint8_t format, std::size_t body) {
    out.assign(kGvspHeaderBytes + body, 0);
    put16(&out[0], kStatusSuccess);
    put16(&out[2], block.block_id);
    put32(&out[4], packet_id & 0x00FFFFFFu);
    out[4] = format;
  };
  if (packet_id == 0) {
    header(kGvspLeader, 36);
    std::uint8_t* p = &out[kGvspHeaderBytes];
    put16(p + 2, block.image.has_chunks ? kPayloadTypeImage | kPayloadTypeChunkFlag : kPayloadTypeImage);
    put32(p + 4, static_cast<std::uint32_t>(block.image.timestamp_ticks >> 32));
    put32(p + 8, static_cast<std::uint32_t>(block.image.timestamp_ticks));
    put32(p + 12, block.image.pixel_format);
    put32(p + 16, block.image.width);
    put32(p + 20, block.image.height);
    put32(p + 24, block.image.offset_x);
    put32(p + 28, block.image.offset_y);
  } else if (packet_id == block.last_packet_id()) {
    header(kGvspTrailer, 8);
    put16(&out[kGvspHeaderBytes + 2], block.image.has_chunks ? kPayloadTypeImage | kPayloadTypeChunkFlag
                                                              : kPayloadTypeImage);
    put32(&out[kGvspHeaderBytes + 4], block.image.height);
  } else {
    const std::size_t begin = static_cast<std::size_t>(packet_id - 1) * block.data_bytes_per_packet;
    const std::size_t size = std::min<std::size_t>(block.data_bytes_per_packet, payload.size() - begin);
    header(kGvspPayload, size);
    std::memcpy(&out[kGvspHeaderBytes], payload.data() + begin, size);
  }
}

std::vector<std::uint8_t> gvsp_unavailable_packet(std::uint16_t block_id, std::uint32_t packet_id) {
  std::vector<std::uint8_t> out(kGvspHeaderBytes, 0);
  put16(&out[0], kStatusPacketUnavailable);
  put16(&out[2], block_id);
  put32(&out[4], packet_id & 0x00FFFFFFu);
  out[4] = kGvspPayload;
  return out;
}

TransmissionCounts transmit_with_faults(std::uint32_t last_packet_id, const GvspFaultOptions& faults,
                                        const std::function<double()>& roll,
                                        const std::function<void(std::uint32_t)>& send) {
  using Clock = std::chrono::steady_clock;
  TransmissionCounts counts;
  std::vector<std::pair<Clock::time_point, std::uint32_t>> held;  // delayed packets, in due order
  constexpr std::uint32_t kNone = 0xFFFFFFFFu;  // no packet waiting to be swapped
  std::uint32_t swapped = kNone;
  auto send_due = [&](bool all) {
    for (auto it = held.begin(); it != held.end();) {
      if (all) std::this_thread::sleep_until(it->first);
      if (all || it->first <= Clock::now()) {
        send(it->second);
        it = held.erase(it);
      } else {
        ++it;
      }
    }
  };
  for (std::uint32_t id = 0; id <= last_packet_id; ++id) {
    send_due(false);
    const double loss = roll(), delay = roll(), reorder = roll();
    if (loss < faults.loss_probability) {
      ++counts.dropped;
      continue;
    }
    if (delay < faults.delay_probability) {
      ++counts.delayed;
      held.emplace_back(Clock::now() + std::chrono::microseconds(faults.delay_us), id);
      continue;
    }
    if (swapped == kNone && id != last_packet_id && reorder < faults.reorder_probability) {
      ++counts.reordered;
      swapped = id;
      continue;
    }
    send(id);
    if (swapped != kNone) {
      send(swapped);
      swapped = kNone;
    }
  }
  if (swapped != kNone) send(swapped);
  send_due(true);
  return counts;
}

}  // namespace chromo::simulators::gige
