#include "services/socket_io.hpp"

#include <poll.h>
#include <sched.h>
#include <sys/socket.h>

#include <cerrno>
#include <climits>

namespace ln::services::io {
namespace {

// Waits until `fd` reports one of `events` or the deadline passes.
Result wait_for(int fd, short events, const Deadline& deadline) {
  for (;;) {
    pollfd p{fd, events, 0};
    timespec storage{};
    const int n = ppoll(&p, 1, deadline.remaining(storage), nullptr);
    if (n > 0) return {};
    if (n == 0) return {Outcome::Timeout, 0};
    if (errno != EINTR) return {Outcome::Failed, errno};
  }
}

}  // namespace

Deadline Deadline::after_seconds(double seconds) {
  if (!(seconds > 0)) return {};
  // Anything beyond a few centuries is "never" (and would overflow).
  if (seconds > 1e10) return {};
  return at(Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds)));
}

const timespec* Deadline::remaining(timespec& storage) const {
  if (!finite_) return nullptr;
  const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(when_ - Clock::now()).count();
  const long long ns = left > 0 ? left : 0;
  storage.tv_sec = static_cast<time_t>(ns / 1000000000);
  storage.tv_nsec = static_cast<long>(ns % 1000000000);
  return &storage;
}

int Deadline::remaining_ms() const {
  if (!finite_) return -1;
  const auto left = std::chrono::duration_cast<std::chrono::microseconds>(when_ - Clock::now()).count();
  if (left <= 0) return 0;
  const long long ms = (left + 999) / 1000;
  return ms > INT_MAX ? INT_MAX : static_cast<int>(ms);
}

Result send_some(int fd, const char* data, std::size_t size, std::size_t& sent) {
  while (sent < size) {
    const ssize_t n = ::send(fd, data + sent, size - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return {};
    if (n < 0 && (errno == EPIPE || errno == ECONNRESET)) return {Outcome::Closed, errno};
    return {Outcome::Failed, n < 0 ? errno : EIO};
  }
  return {};
}

Result send_all(int fd, const char* data, std::size_t size, const Deadline& deadline) {
  std::size_t sent = 0;
  return send_within(fd, data, size, deadline, sent);
}

Result send_within(int fd, const char* data, std::size_t size, const Deadline& deadline, std::size_t& sent) {
  sent = 0;
  for (;;) {
    Result r = send_some(fd, data, size, sent);
    if (r.outcome != Outcome::Done || sent == size) return r;
    r = wait_for(fd, POLLOUT, deadline);
    if (r.outcome != Outcome::Done) return r;
  }
}

Result receive_available(int fd, frames::FrameAssembler& assembler, Status& malformed) {
  // A read that fills the space offered suggests more is waiting (a large
  // frame arriving); keep reading a while instead of going back to epoll.
  constexpr int max_reads = 64;
  for (int reads = 0; reads < max_reads;) {
    std::size_t capacity = 0;
    char* space = assembler.space(capacity);
    const ssize_t n = ::recv(fd, space, capacity, MSG_DONTWAIT);
    if (n > 0) {
      malformed = assembler.commit(static_cast<std::size_t>(n));
      if (!malformed.ok()) return {Outcome::Malformed, 0};
      if (static_cast<std::size_t>(n) < capacity) return {};
      ++reads;
      continue;
    }
    if (n == 0) return {Outcome::Closed, 0};
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return {};
    if (errno == ECONNRESET) return {Outcome::Closed, errno};
    return {Outcome::Failed, errno};
  }
  return {};
}

Result receive_frame(int fd, frames::FrameAssembler& assembler, const Deadline& deadline, frames::Payload& out,
                     Status& malformed, unsigned spin_us) {
  const Clock::time_point spin_until = Clock::now() + std::chrono::microseconds(spin_us);
  bool spinning = spin_us > 0;
  // Called right after the request went out, when the answer cannot be
  // there yet: let the provider have the CPU first if it shares ours.
  if (spinning) ::sched_yield();
  while (!assembler.next(out)) {
    if (spinning && (Clock::now() >= spin_until || deadline.expired())) spinning = false;
    // Without a deadline a plain blocking read saves the ppoll() call.
    if (!spinning && deadline.finite()) {
      Result r = wait_for(fd, POLLIN, deadline);
      if (r.outcome != Outcome::Done) return r;
    }
    std::size_t capacity = 0;
    char* space = assembler.space(capacity);
    const ssize_t n = ::recv(fd, space, capacity, spinning || deadline.finite() ? MSG_DONTWAIT : 0);
    if (n > 0) {
      malformed = assembler.commit(static_cast<std::size_t>(n));
      if (!malformed.ok()) return {Outcome::Malformed, 0};
      continue;
    }
    if (n == 0) return {Outcome::Closed, 0};
    if (errno == EAGAIN || errno == EWOULDBLOCK) {
      if (spinning) ::sched_yield();
      continue;
    }
    if (errno == EINTR) continue;
    if (errno == ECONNRESET) return {Outcome::Closed, errno};
    return {Outcome::Failed, errno};
  }
  return {};
}

bool peer_closed(int fd) {
  pollfd p{fd, POLLRDHUP, 0};
  return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0;
}

bool idle_connection_spoiled(int fd) {
  pollfd p{fd, POLLIN | POLLRDHUP, 0};
  return ::poll(&p, 1, 0) != 0;
}

}  // namespace ln::services::io
