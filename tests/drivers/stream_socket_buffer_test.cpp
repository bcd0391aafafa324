// The stream socket's receive buffer is sized before the first frame: a burst
// the kernel's default buffer drops is held whole by the sized one.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fstream>
#include <vector>

#include <gtest/gtest.h>

#include "../../drivers/camera/stream_socket_buffer.hpp"

namespace chromo::testing {
namespace {

using drivers::detail::size_udp_receive_buffer;

std::size_t read_sysctl(const char* path) {
  std::ifstream in(path);
  std::size_t value = 0;
  in >> value;
  return value;
}

// A UDP socket on 127.0.0.1 with a kernel-chosen port; closed on destruction.
struct LoopbackUdpSocket {
  int fd = -1;
  std::uint16_t port = 0;
  LoopbackUdpSocket() {
    fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
    socklen_t length = sizeof address;
    getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
    port = ntohs(address.sin_port);
  }
  ~LoopbackUdpSocket() { close(fd); }
  int receive_buffer() const {
    int size = 0;
    socklen_t length = sizeof size;
    getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &size, &length);
    return size;
  }
  // Sends `count` datagrams of `bytes` to `port` on loopback, nobody reading.
  static void burst(std::uint16_t port, int count, std::size_t bytes) {
    const int sender = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    to.sin_port = htons(port);
    const std::vector<char> payload(bytes, 'x');
    for (int i = 0; i < count; ++i)
      sendto(sender, payload.data(), payload.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
    close(sender);
  }
  int drain() const {
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    std::vector<char> buffer(65536);
    int received = 0;
    while (recv(fd, buffer.data(), buffer.size(), 0) > 0) ++received;
    return received;
  }
};

TEST(StreamSocketBuffer, SizesTheUdpSocketBoundToThePort) {
  const std::size_t rmem_max = read_sysctl("/proc/sys/net/core/rmem_max");
  LoopbackUdpSocket stream;
  const std::size_t wanted = std::min<std::size_t>(1u << 20, rmem_max);
  const std::size_t applied = size_udp_receive_buffer(stream.port, wanted);
  EXPECT_EQ(applied, static_cast<std::size_t>(stream.receive_buffer()));
  EXPECT_GE(applied, wanted);  // Linux reports twice the request (bookkeeping overhead)
  // No socket on that port (ours is the only one bound to stream.port).
  EXPECT_EQ(size_udp_receive_buffer(static_cast<std::uint16_t>(stream.port ^ 1u), wanted), 0u);
  EXPECT_EQ(size_udp_receive_buffer(0, wanted), 0u);
}

TEST(StreamSocketBuffer, ABurstTheDefaultBufferDropsIsHeldWholeWhenSized) {
  // 300 datagrams of 1400 bytes: a 420 kB frame sent while the receiving
  // thread sleeps (what loses a camera's first frame under load).
  constexpr int kDatagrams = 300;
  constexpr std::size_t kBytes = 1400;
  const std::size_t rmem_max = read_sysctl("/proc/sys/net/core/rmem_max");
  if (rmem_max < (4u << 20)) GTEST_SKIP() << "net.core.rmem_max " << rmem_max << " is below 4 MiB";
  LoopbackUdpSocket sized;
  ASSERT_GT(size_udp_receive_buffer(sized.port, 4u << 20), 0u);
  LoopbackUdpSocket::burst(sized.port, kDatagrams, kBytes);
  EXPECT_EQ(sized.drain(), kDatagrams);

  if (read_sysctl("/proc/sys/net/core/rmem_default") * 2 >= kDatagrams * 4096u)
    GTEST_SKIP() << "net.core.rmem_default holds the whole burst here";
  LoopbackUdpSocket default_sized;
  LoopbackUdpSocket::burst(default_sized.port, kDatagrams, kBytes);
  EXPECT_LT(default_sized.drain(), kDatagrams);
}

}  // namespace
}  // namespace chromo::testing
