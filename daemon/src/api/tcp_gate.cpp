#include "tcp_gate.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <unordered_map>

#include "chromo/daemon/log_line.hpp"

namespace chromo::daemon {

namespace {

constexpr std::size_t kBufferBytes = 64 * 1024;  // per direction and connection
constexpr auto kAcceptPause = std::chrono::milliseconds(100);
constexpr auto kLogEvery = std::chrono::seconds(10);

// Bytes read from one end, not yet written to the other.
struct Direction {
  std::array<char, kBufferBytes> buffer;
  std::size_t begin = 0, end = 0;
  bool eof = false;       // the reading end sent FIN
  bool shut = false;      // ... and the writing end was shut down for writing after the last byte
  bool empty() const { return begin == end; }
  bool full() const { return end == buffer.size(); }
};

// One relayed connection: the client's socket and the gate's to gRPC.
struct Relay {
  std::uint64_t id = 0;    // epoll's key: 2·id for the client's end, 2·id + 1 for the backend's
  int client = -1, backend = -1;
  bool connecting = true;  // the backend connection is not established yet
  Direction up;            // client → gRPC
  Direction down;          // gRPC → client
};

enum class Step { kGoOn, kClose };

// Reads into `d` from `from` while there is room; false on an error.
bool fill(int from, Direction& d) {
  while (!d.eof && !d.full()) {
    const ssize_t n = ::recv(from, d.buffer.data() + d.end, d.buffer.size() - d.end, 0);
    if (n > 0) {
      d.end += static_cast<std::size_t>(n);
    } else if (n == 0) {
      d.eof = true;
    } else {
      if (errno == EINTR) continue;
      return errno == EAGAIN || errno == EWOULDBLOCK;
    }
  }
  return true;
}

// Writes what `d` holds to `to`, then passes the reader's FIN on; false on an error.
bool drain(int to, Direction& d) {
  while (!d.empty()) {
    const ssize_t n = ::send(to, d.buffer.data() + d.begin, d.end - d.begin, MSG_NOSIGNAL);
    if (n > 0) {
      d.begin += static_cast<std::size_t>(n);
    } else {
      if (n < 0 && errno == EINTR) continue;
      return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
    }
  }
  d.begin = d.end = 0;
  if (d.eof && !d.shut) {
    ::shutdown(to, SHUT_WR);
    d.shut = true;
  }
  return true;
}

// Moves what can move without blocking. The connection ends on an error,
// once gRPC has closed and its last bytes reached the client (gRPC ended the
// conversation: the idle and handshake timeouts), or once both ends closed.
Step pump(Relay& relay) {
  if (relay.connecting) return Step::kGoOn;
  if (!fill(relay.client, relay.up) || !drain(relay.backend, relay.up)) return Step::kClose;
  if (!fill(relay.backend, relay.down) || !drain(relay.client, relay.down)) return Step::kClose;
  if (relay.down.eof && relay.down.empty()) return Step::kClose;
  if (relay.up.eof && relay.up.empty() && relay.down.eof) return Step::kClose;
  return Step::kGoOn;
}

bool is_loopback(const sockaddr_storage& peer) {
  if (peer.ss_family == AF_INET)
    return (ntohl(reinterpret_cast<const sockaddr_in&>(peer).sin_addr.s_addr) >> 24) == 127;
  if (peer.ss_family == AF_INET6) {
    const auto& address = reinterpret_cast<const sockaddr_in6&>(peer).sin6_addr;
    if (IN6_IS_ADDR_LOOPBACK(&address)) return true;
    return IN6_IS_ADDR_V4MAPPED(&address) && address.s6_addr[12] == 127;
  }
  return false;
}

bool is_out_of_descriptors(int error) {
  return error == EMFILE || error == ENFILE || error == ENOBUFS || error == ENOMEM;
}

// A listening socket on "host:port" (the host numeric or localhost).
int listen_on(const std::string& address, int* port) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("tcp_address: \"" + address + "\" is not host:port");
  std::string host = address.substr(0, colon);
  const std::string service = address.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | (host == "localhost" ? 0 : AI_NUMERICHOST);
  addrinfo* found = nullptr;
  if (const int status = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &found); status != 0)
    throw std::runtime_error("tcp_address: " + address + ": " + gai_strerror(status));
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> owned(found, ::freeaddrinfo);
  const int fd = ::socket(found->ai_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) throw std::runtime_error("tcp_address: " + address + ": socket: " + std::strerror(errno));
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd, found->ai_addr, found->ai_addrlen) != 0 || ::listen(fd, 128) != 0) {
    const std::string reason = std::strerror(errno);
    ::close(fd);
    throw std::runtime_error("tcp_address: cannot listen on " + address + " (" + reason + ")");
  }
  sockaddr_storage bound{};
  socklen_t size = sizeof bound;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &size);
  *port = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6&>(bound).sin6_port
                                            : reinterpret_cast<sockaddr_in&>(bound).sin_port);
  return fd;
}

// A non-blocking connection to 127.0.0.1:port, perhaps still in progress; -1 on failure.
int connect_backend(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return -1;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 && errno != EINPROGRESS) {
    ::close(fd);
    return -1;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

// Logs `message` at most once per kLogEvery for each `last` clock.
void log_now_and_then(std::chrono::steady_clock::time_point& last, const std::string& message) {
  const auto now = std::chrono::steady_clock::now();
  if (now - last < kLogEvery) return;
  last = now;
  log_line(LogLevel::kWarning, message);
}

}  // namespace

TcpGate::TcpGate(TcpGateOptions options) : options_(std::move(options)) {
  if (options_.max_connections == 0) throw std::invalid_argument("max_tcp_connections: must be at least 1");
  listen_fd_ = listen_on(options_.address, &port_);
  wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) {
    ::close(listen_fd_);
    throw std::runtime_error(std::string("tcp_address: eventfd: ") + std::strerror(errno));
  }
}

TcpGate::~TcpGate() {
  stop();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void TcpGate::start(int backend_port) {
  backend_port_ = backend_port;
  thread_ = std::thread([this] { run(); });
}

void TcpGate::stop() {
  if (!thread_.joinable()) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] ssize_t n = ::write(wake_fd_, &one, sizeof one);
  thread_.join();
}

TcpGateCounters TcpGate::counters() const {
  return {accepted_.load(), refused_over_cap_.load(), refused_not_loopback_.load(), accept_failures_.load(),
          open_.load()};
}

void TcpGate::run() {
  const int epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd < 0) {
    log_line(LogLevel::kError, std::string("TCP gate: epoll_create1: ") + std::strerror(errno) + "; TCP not served");
    return;
  }
  // Keys, not descriptors, name what an event is for: a descriptor closed and
  // reused within one batch of events is not taken for the new connection.
  constexpr std::uint64_t kWakeKey = 0, kListenKey = 1;
  auto watch = [&](int op, int fd, std::uint64_t key, std::uint32_t events) {
    epoll_event event{};
    event.events = events;
    event.data.u64 = key;
    ::epoll_ctl(epoll_fd, op, fd, &event);
  };
  watch(EPOLL_CTL_ADD, wake_fd_, kWakeKey, EPOLLIN);
  watch(EPOLL_CTL_ADD, listen_fd_, kListenKey, EPOLLIN);

  std::unordered_map<std::uint64_t, std::shared_ptr<Relay>> relays;  // by id
  std::uint64_t next_id = 1;
  auto close_relay = [&](const std::shared_ptr<Relay>& relay) {
    for (int fd : {relay->client, relay->backend}) {
      ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
      ::close(fd);
    }
    relays.erase(relay->id);
    open_.fetch_sub(1);
  };
  // What each end waits for, from the buffers' state (level-triggered).
  auto rearm = [&](const Relay& relay) {
    std::uint32_t client = 0, backend = 0;
    if (relay.connecting) {
      backend = EPOLLOUT;
    } else {
      if (!relay.up.eof && !relay.up.full()) client |= EPOLLIN;
      if (!relay.down.empty()) client |= EPOLLOUT;
      if (!relay.down.eof && !relay.down.full()) backend |= EPOLLIN;
      if (!relay.up.empty()) backend |= EPOLLOUT;
    }
    watch(EPOLL_CTL_MOD, relay.client, 2 * relay.id, client);
    watch(EPOLL_CTL_MOD, relay.backend, 2 * relay.id + 1, backend);
  };

  std::chrono::steady_clock::time_point paused_until{}, logged_cap{}, logged_descriptors{}, logged_peer{};
  bool listening = true;
  auto accept_all = [&] {
    for (;;) {
      sockaddr_storage peer{};
      socklen_t size = sizeof peer;
      const int client = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&peer), &size, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (client < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (is_out_of_descriptors(errno)) {
          accept_failures_.fetch_add(1);
          log_now_and_then(logged_descriptors, std::string("TCP gate: cannot accept (") + std::strerror(errno) +
                                                   "): pausing 100 ms; the port accepts again once descriptors are free");
          paused_until = std::chrono::steady_clock::now() + kAcceptPause;
          watch(EPOLL_CTL_MOD, listen_fd_, kListenKey, 0);
          listening = false;
        }
        return;  // EAGAIN: all accepted
      }
      if (options_.loopback_peers_only && !is_loopback(peer)) {
        ::close(client);
        refused_not_loopback_.fetch_add(1);
        log_now_and_then(logged_peer, "TCP gate: refused a connection from a non-loopback peer (tcp_insecure accepts "
                                      "loopback peers only)");
        continue;
      }
      if (open_.load() >= options_.max_connections) {
        ::close(client);
        refused_over_cap_.fetch_add(1);
        log_now_and_then(logged_cap, "TCP gate: max_tcp_connections (" + std::to_string(options_.max_connections) +
                                         ") are open: closed a new connection at once");
        continue;
      }
      const int backend = connect_backend(backend_port_);
      if (backend < 0) {
        ::close(client);
        if (is_out_of_descriptors(errno)) accept_failures_.fetch_add(1);
        continue;
      }
      auto relay = std::make_shared<Relay>();
      relay->id = next_id++;
      relay->client = client;
      relay->backend = backend;
      relays[relay->id] = relay;
      watch(EPOLL_CTL_ADD, client, 2 * relay->id, 0);
      watch(EPOLL_CTL_ADD, backend, 2 * relay->id + 1, EPOLLOUT);
      open_.fetch_add(1);
      accepted_.fetch_add(1);
    }
  };

  std::array<epoll_event, 64> events;
  for (;;) {
    int timeout_ms = -1;
    if (!listening) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(paused_until - std::chrono::steady_clock::now());
      timeout_ms = static_cast<int>(std::max<long long>(0, left.count()));
    }
    const int count = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), timeout_ms);
    if (count < 0 && errno != EINTR) break;
    if (!listening && std::chrono::steady_clock::now() >= paused_until) {
      watch(EPOLL_CTL_MOD, listen_fd_, kListenKey, EPOLLIN);
      listening = true;
    }
    bool stopping = false;
    for (int i = 0; i < count; ++i) {
      const std::uint64_t key = events[i].data.u64;
      if (key == kWakeKey) {
        stopping = true;
        continue;
      }
      if (key == kListenKey) {
        accept_all();
        continue;
      }
      const auto found = relays.find(key / 2);
      if (found == relays.end()) continue;  // closed earlier in this batch
      const std::shared_ptr<Relay> relay = found->second;
      Step step = Step::kGoOn;
      if (relay->connecting && key % 2 == 1) {
        int error = 0;
        socklen_t size = sizeof error;
        ::getsockopt(relay->backend, SOL_SOCKET, SO_ERROR, &error, &size);
        if (error != 0) step = Step::kClose;
        relay->connecting = false;
      }
      // An error on either end ends the connection; after a hang-up what can
      // still be read and sent is, then it ends too. A plain FIN is read as
      // the end of its direction (pump).
      if (events[i].events & EPOLLERR) step = Step::kClose;
      if (step == Step::kGoOn) step = pump(*relay);
      if (events[i].events & EPOLLHUP) step = Step::kClose;
      if (step == Step::kClose)
        close_relay(relay);
      else
        rearm(*relay);
    }
    if (stopping) break;
  }
  // Every relayed connection closes with the gate.
  while (!relays.empty()) close_relay(std::shared_ptr<Relay>(relays.begin()->second));
  ::close(epoll_fd);
}

}  // namespace chromo::daemon
