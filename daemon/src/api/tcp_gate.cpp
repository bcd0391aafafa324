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

#include <algorithm>
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

// The gate's thread: one epoll set over the listening socket, the stop
// event and both ends of every relayed connection, level-triggered.
class TcpGate::Loop {
 public:
  Loop(TcpGate& gate, int epoll_fd) : gate_(gate), epoll_fd_(epoll_fd) {
    watch(EPOLL_CTL_ADD, gate_.wake_fd_, kWakeKey, EPOLLIN);
    watch(EPOLL_CTL_ADD, gate_.listen_fd_, kListenKey, EPOLLIN);
  }
  ~Loop() {
    while (!relays_.empty()) close_relay(std::shared_ptr<Relay>(relays_.begin()->second));  // they close with the gate
  }

  // Until stop(): waits for events and serves them.
  void run() {
    std::array<epoll_event, 64> events;
    for (bool stopping = false; !stopping;) {
      const int count = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), wait_ms());
      if (count < 0 && errno != EINTR) return;
      resume_accepting_when_due();
      for (int i = 0; i < count; ++i) {
        const std::uint64_t key = events[i].data.u64;
        if (key == kWakeKey)
          stopping = true;
        else if (key == kListenKey)
          accept_all();
        else
          serve(key, events[i].events);
      }
    }
  }

 private:
  // Keys, not descriptors, name what an event is for: a descriptor closed and
  // reused within one batch of events is not taken for the new connection.
  // A relay's ends: 2·id (the client's) and 2·id + 1 (gRPC's).
  static constexpr std::uint64_t kWakeKey = 0, kListenKey = 1;

  void watch(int op, int fd, std::uint64_t key, std::uint32_t events) {
    epoll_event event{};
    event.events = events;
    event.data.u64 = key;
    ::epoll_ctl(epoll_fd_, op, fd, &event);
  }

  int wait_ms() const {
    if (listening_) return -1;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(paused_until_ - std::chrono::steady_clock::now());
    return static_cast<int>(std::max<long long>(0, left.count()));
  }

  void pause_accepting() {
    paused_until_ = std::chrono::steady_clock::now() + kAcceptPause;
    watch(EPOLL_CTL_MOD, gate_.listen_fd_, kListenKey, 0);
    listening_ = false;
  }

  void resume_accepting_when_due() {
    if (listening_ || std::chrono::steady_clock::now() < paused_until_) return;
    watch(EPOLL_CTL_MOD, gate_.listen_fd_, kListenKey, EPOLLIN);
    listening_ = true;
  }

  // Accepts until the backlog is empty: relays what the cap and the peer rule admit, closes the rest.
  void accept_all() {
    for (;;) {
      sockaddr_storage peer{};
      socklen_t size = sizeof peer;
      const int client =
          ::accept4(gate_.listen_fd_, reinterpret_cast<sockaddr*>(&peer), &size, SOCK_CLOEXEC | SOCK_NONBLOCK);
      if (client < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (is_out_of_descriptors(errno)) {
          gate_.accept_failures_.fetch_add(1);
          log_now_and_then(logged_descriptors_, std::string("TCP gate: cannot accept (") + std::strerror(errno) +
                                                    "): pausing 100 ms; the port accepts again once descriptors are free");
          pause_accepting();
        }
        return;  // EAGAIN: all accepted
      }
      if (gate_.options_.loopback_peers_only && !is_loopback(peer)) {
        gate_.refused_not_loopback_.fetch_add(1);  // counted before the peer can see the close
        ::close(client);
        log_now_and_then(logged_peer_, "TCP gate: refused a connection from a non-loopback peer (tcp_insecure accepts "
                                       "loopback peers only)");
        continue;
      }
      if (gate_.open_.load() >= gate_.options_.max_connections) {
        gate_.refused_over_cap_.fetch_add(1);  // counted before the peer can see the close
        ::close(client);
        log_now_and_then(logged_cap_, "TCP gate: max_tcp_connections (" + std::to_string(gate_.options_.max_connections) +
                                          ") are open: closed a new connection at once");
        continue;
      }
      relay(client);
    }
  }

  void relay(int client) {
    const int backend = connect_backend(gate_.backend_port_);
    if (backend < 0) {
      if (is_out_of_descriptors(errno)) gate_.accept_failures_.fetch_add(1);
      ::close(client);
      return;
    }
    auto relay = std::make_shared<Relay>();
    relay->id = next_id_++;
    relay->client = client;
    relay->backend = backend;
    relays_[relay->id] = relay;
    watch(EPOLL_CTL_ADD, client, 2 * relay->id, 0);
    watch(EPOLL_CTL_ADD, backend, 2 * relay->id + 1, EPOLLOUT);
    gate_.open_.fetch_add(1);
    gate_.accepted_.fetch_add(1);
  }

  // One end of a relay is ready (or failed): move what can move, then wait
  // for what its buffers need next, or close it.
  void serve(std::uint64_t key, std::uint32_t events) {
    const auto found = relays_.find(key / 2);
    if (found == relays_.end()) return;  // closed earlier in this batch
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
    if (events & EPOLLERR) step = Step::kClose;
    if (step == Step::kGoOn) step = pump(*relay);
    if (events & EPOLLHUP) step = Step::kClose;
    if (step == Step::kClose)
      close_relay(relay);
    else
      rearm(*relay);
  }

  // What each end waits for, from the buffers' state.
  void rearm(const Relay& relay) {
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
  }

  void close_relay(const std::shared_ptr<Relay>& relay) {
    for (int fd : {relay->client, relay->backend}) {
      ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
      ::close(fd);
    }
    relays_.erase(relay->id);
    gate_.open_.fetch_sub(1);
  }

  TcpGate& gate_;
  const int epoll_fd_;
  std::unordered_map<std::uint64_t, std::shared_ptr<Relay>> relays_;  // by id
  std::uint64_t next_id_ = 1;
  bool listening_ = true;
  std::chrono::steady_clock::time_point paused_until_{}, logged_cap_{}, logged_descriptors_{}, logged_peer_{};
};

void TcpGate::run() {
  const int epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd < 0) {
    log_line(LogLevel::kError, std::string("TCP gate: epoll_create1: ") + std::strerror(errno) + "; TCP not served");
    return;
  }
  {
    Loop loop(*this, epoll_fd);
    loop.run();
  }
  ::close(epoll_fd);
}

}  // namespace chromo::daemon
