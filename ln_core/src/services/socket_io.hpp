// Blocking socket I/O with deadlines, as the service data path needs it.
// Sockets stay in blocking mode; MSG_DONTWAIT makes single calls
// non-blocking where a deadline or an event loop requires it. Sends never
// raise SIGPIPE.
#pragma once

#include <chrono>
#include <cstddef>
#include <ctime>

#include "services/call_frames.hpp"

namespace ln::services::io {

using Clock = std::chrono::steady_clock;

/// When to give up; the default never does.
class Deadline {
 public:
  Deadline() = default;
  /// `seconds` <= 0 means never (LN's "timeout 0 = wait forever" for calls).
  static Deadline after_seconds(double seconds);
  static Deadline at(Clock::time_point when) {
    Deadline d;
    d.finite_ = true;
    d.when_ = when;
    return d;
  }
  bool finite() const { return finite_; }
  Clock::time_point when() const { return when_; }
  /// What is left in whole milliseconds, rounded up, for epoll_wait(); -1 = no limit.
  int remaining_ms() const;
  bool expired() const { return finite_ && Clock::now() >= when_; }
  /// What is left, for ppoll(); nullptr = no limit.
  const timespec* remaining(timespec& storage) const;

 private:
  bool finite_ = false;
  Clock::time_point when_{};
};

enum class Outcome {
  Done,
  Timeout,
  Closed,     ///< the peer closed the connection (or it was shut down here)
  Failed,     ///< a system error; see sys_errno
  Malformed,  ///< the peer sent bytes that are no valid frame stream
};

struct Result {
  Outcome outcome = Outcome::Done;
  int sys_errno = 0;
};

/// Sends all `size` bytes before `deadline`.
Result send_all(int fd, const char* data, std::size_t size, const Deadline& deadline);

/// send_all() that tells how many bytes went out (`sent`, also on Timeout).
Result send_within(int fd, const char* data, std::size_t size, const Deadline& deadline, std::size_t& sent);

/// Sends what the socket takes now; `sent` grows by that.
Result send_some(int fd, const char* data, std::size_t size, std::size_t& sent);

/// Waits (until `deadline`) for a complete frame and takes it; polls
/// (yielding) for up to `spin_us` before it sleeps (see WaitPolicy). For a
/// response right after its request: when spinning it yields before the
/// first look, so that a provider on the same CPU can answer first.
Result receive_frame(int fd, frames::FrameAssembler& assembler, const Deadline& deadline, frames::Payload& out,
                     Status& malformed, unsigned spin_us = 0);

/// Reads what the socket has now into `assembler` without blocking. Done
/// also when nothing was there.
Result receive_available(int fd, frames::FrameAssembler& assembler, Status& malformed);

/// True if the peer has closed its end (checked without blocking).
bool peer_closed(int fd);

/// True if an idle connection is no longer fit for a new request: the peer
/// closed it or sent something unasked (checked without blocking).
bool idle_connection_spoiled(int fd);

}  // namespace ln::services::io
