// Sizes the receive buffer of a GigE Vision stream socket before its first
// frame arrives. Internal to the Aravis backend.
//
// Aravis 0.8 applies the stream's "socket-buffer-size" only when its stream
// thread processes the first packet of the first frame. Until then the socket
// has the kernel's default (net.core.rmem_default, 208 KiB on Debian): a first
// frame larger than that, sent in one burst while the receiving thread is not
// scheduled, overflows it and loses its last packets (measured: a 128 KiB
// BayerRG16 frame in 99 packets of 1400 bytes lost packets 93-98 under load;
// the kernel accounts ~2.3 KiB per datagram). Aravis does not expose the
// socket, so the backend finds it by its local UDP port.
#pragma once

#include <cstddef>
#include <cstdint>

namespace chromo::drivers::detail {

// Sets SO_RCVBUF of this process' UDP socket bound to local_port to
// buffer_bytes (the kernel caps it at net.core.rmem_max). Returns the size the
// kernel reports afterwards (it doubles the request for bookkeeping), or 0
// when no such socket was found or the call failed.
std::size_t size_udp_receive_buffer(std::uint16_t local_port, std::size_t buffer_bytes);

}  // namespace chromo::drivers::detail
