// The web view's connections under chromod's limits (guarded_http.hpp).
#include "guarded_http.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <openssl/err.h>
#include <openssl/ssl.h>

#include <algorithm>
#include <climits>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

namespace chromo::daemon::web {

namespace {

using Clock = std::chrono::steady_clock;

thread_local bool t_close_after_response = false;

// Waits until `fd` is ready for `events` or `deadline` passes.
bool wait_for(int fd, short events, Clock::time_point deadline) {
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{fd, events, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, INT_MAX)));
    if (n > 0) return true;  // ready, or an error/hang-up the next call reports
    if (n < 0 && errno != EINTR) return false;
  }
}

void address_of(int fd, bool peer, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  const int got = peer ? ::getpeername(fd, reinterpret_cast<sockaddr*>(&address), &length)
                       : ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  if (got != 0) return;
  char host[NI_MAXHOST], service[NI_MAXSERV];
  if (::getnameinfo(reinterpret_cast<sockaddr*>(&address), length, host, sizeof host, service, sizeof service,
                    NI_NUMERICHOST | NI_NUMERICSERV) == 0) {
    ip = host;
    port = std::atoi(service);
  }
}

}  // namespace

void close_connection_after_response() { t_close_after_response = true; }

class ConnectionGuard {
 public:
  explicit ConnectionGuard(const ConnectionLimits& limits) : limits_(limits) {}
  const ConnectionLimits& limits() const { return limits_; }

  // A connection from its thread's start until just before its socket closes;
  // `waiting` while it waits for a request head (or the TLS handshake).
  std::uint64_t enter(int fd) {
    std::lock_guard lock(mutex_);
    const std::uint64_t id = next_++;
    entries_[id] = {fd, true, Clock::now()};
    return id;
  }
  void set_waiting(std::uint64_t id, bool waiting) {
    std::lock_guard lock(mutex_);
    auto found = entries_.find(id);
    if (found == entries_.end() || found->second.waiting == waiting) return;
    found->second.waiting = waiting;
    found->second.since = Clock::now();
  }
  void leave(std::uint64_t id) {
    std::lock_guard lock(mutex_);
    entries_.erase(id);
  }
  // Shuts down the connection that has waited longest for its request head,
  // if it has waited shed_after or more: its thread ends it. Under the lock,
  // so the socket cannot have been closed (and its number reused) meanwhile.
  bool shed_one() {
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    auto oldest = entries_.end();
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->second.waiting && now - it->second.since >= limits_.shed_after &&
          (oldest == entries_.end() || it->second.since < oldest->second.since))
        oldest = it;
    if (oldest == entries_.end()) return false;
    ::shutdown(oldest->second.fd, SHUT_RDWR);
    oldest->second.waiting = false;  // once
    ++counters_.shed;
    return true;
  }
  void count(std::size_t ConnectionCounters::*field) {
    std::lock_guard lock(mutex_);
    ++(counters_.*field);
  }
  ConnectionCounters counters() const {
    std::lock_guard lock(mutex_);
    return counters_;
  }

 private:
  struct Entry {
    int fd;
    bool waiting;
    Clock::time_point since;
  };
  ConnectionLimits limits_;
  mutable std::mutex mutex_;
  std::map<std::uint64_t, Entry> entries_;
  std::uint64_t next_ = 1;
  ConnectionCounters counters_;
};

ConnectionCounters counters_of(const ConnectionGuard& guard) { return guard.counters(); }

namespace {

// httplib's worker threads, shedding a waiting connection when a new one
// finds every thread busy (also every idle interval while one still waits).
class SheddingPool final : public httplib::TaskQueue {
 public:
  SheddingPool(std::size_t threads, std::shared_ptr<ConnectionGuard> guard) : guard_(std::move(guard)) {
    for (std::size_t i = 0; i < threads; ++i) threads_.emplace_back([this] { work(); });
  }
  void enqueue(std::function<void()> job) override {
    {
      std::lock_guard lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    ready_.notify_one();
    shed();
  }
  void on_idle() override { shed(); }
  void shutdown() override {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    ready_.notify_all();
    for (auto& thread : threads_) thread.join();
  }

 private:
  // One waiting connection shed per connection that finds no idle thread.
  void shed() {
    std::size_t waiting;
    {
      std::lock_guard lock(mutex_);
      waiting = jobs_.size() > idle_ ? jobs_.size() - idle_ : 0;
    }
    while (waiting-- > 0 && guard_->shed_one()) {
    }
  }
  void work() {
    while (true) {
      std::function<void()> job;
      {
        std::unique_lock lock(mutex_);
        ++idle_;
        ready_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
        --idle_;
        if (jobs_.empty()) return;  // stopping, nothing left
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      job();
    }
  }
  std::shared_ptr<ConnectionGuard> guard_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<std::function<void()>> jobs_;
  std::size_t idle_ = 0;
  bool stopping_ = false;
};

// One connection's bytes, plain or TLS, under the limits.
class GuardedStream final : public httplib::Stream {
 public:
  GuardedStream(int fd, SSL* ssl, ConnectionGuard& guard, std::uint64_t id)
      : fd_(fd), ssl_(ssl), guard_(guard), id_(id), limits_(guard.limits()) {}

  // Between requests: true when the next one has started to arrive within
  // keep_alive_timeout.
  bool wait_for_request() {
    guard_.set_waiting(id_, true);
    if (start_ < end_ || (ssl_ && SSL_pending(ssl_) > 0)) return true;
    return wait_for(fd_, POLLIN, Clock::now() + limits_.keep_alive_timeout);
  }
  void begin_request() {
    head_ = true;
    head_bytes_ = body_bytes_ = 0;
    line_ = lines_ = 0;
    previous_ = 0;
    head_deadline_ = Clock::now() + limits_.head_timeout;
  }
  bool failed() const { return failed_; }

  bool is_readable() const override {
    return start_ < end_ || (ssl_ && SSL_pending(ssl_) > 0) || wait_for(fd_, POLLIN, Clock::now() + limits_.io_timeout);
  }
  bool is_writable() const override {
    if (!wait_for(fd_, POLLOUT, Clock::now() + limits_.io_timeout)) return false;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) <= 0) return true;
    char byte;
    return ::recv(fd_, &byte, 1, MSG_PEEK) > 0;  // readable with nothing to read: the peer has gone
  }
  ssize_t read(char* out, size_t size) override {
    if (failed_) return -1;
    if (size == 0) return 0;
    if (start_ == end_) {
      const ssize_t got = fill();
      if (got < 0) failed_ = true;
      if (got <= 0) return got;
    }
    std::size_t n = std::min(size, end_ - start_);
    if (head_) {
      // Up to the head's end (its empty line) at most: what follows is body.
      std::size_t i = 0;
      while (i < n) {
        const char c = buffer_[start_ + i++];
        ++head_bytes_, ++line_;
        if (c == '\n') {
          if (lines_ > 0 && line_ == 2 && previous_ == '\r') {
            head_ = false;
            guard_.set_waiting(id_, false);
            break;
          }
          ++lines_, line_ = 0;
        }
        previous_ = c;
      }
      n = i;
      if (head_ && head_bytes_ > limits_.max_head_bytes) {
        guard_.count(&ConnectionCounters::heads_too_long);
        failed_ = true;
        return -1;
      }
    } else if ((body_bytes_ += n) > limits_.max_body_wire_bytes) {
      guard_.count(&ConnectionCounters::bodies_too_long);
      failed_ = true;
      return -1;
    }
    std::memcpy(out, buffer_ + start_, n);
    start_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* data, size_t size) override {
    if (size == 0) return 0;
    const auto deadline = Clock::now() + limits_.io_timeout;
    while (true) {
      if (ssl_) {
        ERR_clear_error();
        const int sent = SSL_write(ssl_, data, static_cast<int>(std::min<size_t>(size, INT_MAX)));
        if (sent > 0) return sent;
        const int error = SSL_get_error(ssl_, sent);
        const short events = error == SSL_ERROR_WANT_WRITE ? POLLOUT : error == SSL_ERROR_WANT_READ ? POLLIN : 0;
        if (!events || !wait_for(fd_, events, deadline)) return -1;
      } else {
        const ssize_t sent = ::send(fd_, data, size, MSG_NOSIGNAL);
        if (sent >= 0) return sent;
        if (errno == EINTR) continue;
        if ((errno != EAGAIN && errno != EWOULDBLOCK) || !wait_for(fd_, POLLOUT, deadline)) return -1;
      }
    }
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override { address_of(fd_, true, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address_of(fd_, false, ip, port); }
  socket_t socket() const override { return fd_; }

 private:
  // Refills the buffer: > 0 bytes read, 0 at the end, -1 on an error or when
  // the deadline passed (io_timeout; the head's deadline while it arrives).
  ssize_t fill() {
    start_ = end_ = 0;
    while (true) {
      auto deadline = Clock::now() + limits_.io_timeout;
      if (head_) {
        if (Clock::now() >= head_deadline_) {
          guard_.count(&ConnectionCounters::heads_too_slow);
          return -1;
        }
        deadline = std::min(deadline, head_deadline_);
      }
      short events = POLLIN;
      if (ssl_) {
        ERR_clear_error();
        const int got = SSL_read(ssl_, buffer_, sizeof buffer_);
        if (got > 0) return static_cast<ssize_t>(end_ = static_cast<std::size_t>(got));
        const int error = SSL_get_error(ssl_, got);
        if (error == SSL_ERROR_ZERO_RETURN) return 0;
        if (error == SSL_ERROR_WANT_WRITE) events = POLLOUT;
        else if (error != SSL_ERROR_WANT_READ) return -1;
      } else {
        const ssize_t got = ::recv(fd_, buffer_, sizeof buffer_, 0);
        if (got > 0) return static_cast<ssize_t>(end_ = static_cast<std::size_t>(got));
        if (got == 0) return 0;
        if (errno == EINTR) continue;
        if (errno != EAGAIN && errno != EWOULDBLOCK) return -1;
      }
      if (!wait_for(fd_, events, deadline)) {
        if (head_ && Clock::now() >= head_deadline_) guard_.count(&ConnectionCounters::heads_too_slow);
        return -1;
      }
    }
  }

  int fd_;
  SSL* ssl_;
  ConnectionGuard& guard_;
  std::uint64_t id_;
  const ConnectionLimits& limits_;
  char buffer_[16384];
  std::size_t start_ = 0, end_ = 0;
  bool failed_ = false;
  bool head_ = true;
  std::size_t head_bytes_ = 0, body_bytes_ = 0, line_ = 0, lines_ = 0;
  char previous_ = 0;
  Clock::time_point head_deadline_ = Clock::now();
};

bool tls_handshake(SSL* ssl, int fd, Clock::time_point deadline) {
  while (true) {
    ERR_clear_error();
    const int done = SSL_accept(ssl);
    if (done == 1) return true;
    const int error = SSL_get_error(ssl, done);
    const short events = error == SSL_ERROR_WANT_READ ? POLLIN : error == SSL_ERROR_WANT_WRITE ? POLLOUT : 0;
    if (!events || !wait_for(fd, events, deadline)) return false;
  }
}

// One connection: requests until it closes, fails, or has served its count;
// then a lingering close, so that a response refusing an unread body (413)
// reaches the client before the socket goes.
template <class Process>
void serve_connection(int fd, SSL_CTX* tls, ConnectionGuard& guard, const httplib::Server& server, Process process) {
  const std::uint64_t id = guard.enter(fd);
  const ConnectionLimits& limits = guard.limits();
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
  SSL* ssl = nullptr;
  bool ready = true;
  if (tls) {
    ssl = SSL_new(tls);
    ready = ssl && SSL_set_fd(ssl, fd) == 1 && tls_handshake(ssl, fd, Clock::now() + limits.head_timeout);
  }
  if (ready) {
    GuardedStream stream(fd, ssl, guard, id);
    for (std::size_t served = 0; served < limits.max_requests_per_connection && server.is_running(); ++served) {
      if (!stream.wait_for_request()) break;
      stream.begin_request();
      t_close_after_response = false;
      bool closed = false;
      const bool answered = process(stream, served + 1 == limits.max_requests_per_connection, closed);
      if (!answered || closed || t_close_after_response || stream.failed()) break;
    }
    if (ssl) {
      ERR_clear_error();
      SSL_shutdown(ssl);  // close_notify, not waiting for the client's
    }
  }
  if (ssl) SSL_free(ssl);
  guard.leave(id);
  ::shutdown(fd, SHUT_WR);
  char discard[4096];
  std::size_t drained = 0;
  const auto until = Clock::now() + std::chrono::seconds(1);
  while (drained < (256u << 10) && wait_for(fd, POLLIN, until)) {
    const ssize_t n = ::recv(fd, discard, sizeof discard, 0);
    if (n <= 0 && !(n < 0 && (errno == EINTR || errno == EAGAIN))) break;
    if (n > 0) drained += static_cast<std::size_t>(n);
  }
  ::close(fd);
}

class GuardedHttpServer final : public httplib::Server {
 public:
  explicit GuardedHttpServer(std::shared_ptr<ConnectionGuard> guard) : guard_(std::move(guard)) {}

 private:
  bool process_and_close_socket(socket_t sock) override {
    serve_connection(sock, nullptr, *guard_, *this, [this](httplib::Stream& stream, bool last, bool& closed) {
      return process_request(stream, last, closed, nullptr);
    });
    return true;
  }
  std::shared_ptr<ConnectionGuard> guard_;
};

class GuardedHttpsServer final : public httplib::SSLServer {
 public:
  GuardedHttpsServer(const char* certificate, const char* key, std::shared_ptr<ConnectionGuard> guard)
      : httplib::SSLServer(certificate, key), guard_(std::move(guard)) {}

 private:
  bool process_and_close_socket(socket_t sock) override {
    serve_connection(sock, ssl_context(), *guard_, *this, [this](httplib::Stream& stream, bool last, bool& closed) {
      return process_request(stream, last, closed, nullptr);
    });
    return true;
  }
  std::shared_ptr<ConnectionGuard> guard_;
};

}  // namespace

std::unique_ptr<httplib::Server> make_guarded_server(const ConnectionLimits& limits, const char* certificate_file,
                                                     const char* private_key_file,
                                                     std::shared_ptr<ConnectionGuard>* guard_out) {
  auto guard = std::make_shared<ConnectionGuard>(limits);
  std::unique_ptr<httplib::Server> server;
  if (certificate_file) server = std::make_unique<GuardedHttpsServer>(certificate_file, private_key_file, guard);
  else server = std::make_unique<GuardedHttpServer>(guard);
  server->new_task_queue = [guard, threads = limits.threads] { return new SheddingPool(threads, guard); };
  server->set_idle_interval(0, 200000);  // on_idle: shed while a connection waits and no new one comes
  if (guard_out) *guard_out = guard;
  return server;
}

}  // namespace chromo::daemon::web
