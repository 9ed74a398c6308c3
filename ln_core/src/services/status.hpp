// Results and limits shared by the service data path.
#pragma once

#include <cstddef>
#include <string>
#include <utility>

namespace ln::services {

/// The outcome of an operation in the form the C API hands out: code() is 0
/// or a negative LNE_* value (what ln_service_* returns), detail() the text
/// for ln_get_error_message(), sys_errno() the errno behind a
/// -LNE_CHECK_ERRNO.
class Status {
 public:
  Status() = default;
  /// `lne_code` is a positive LNE_* value.
  static Status failure(int lne_code, std::string detail, int sys_errno = 0) {
    Status s;
    s.code_ = -lne_code;
    s.detail_ = std::move(detail);
    s.errno_ = sys_errno;
    return s;
  }
  bool ok() const { return code_ == 0; }
  int code() const { return code_; }
  const std::string& detail() const { return detail_; }
  int sys_errno() const { return errno_; }

 private:
  int code_ = 0;
  std::string detail_;
  int errno_ = 0;
};

/// Bounds on what one side sends and accepts. A peer that exceeds them gets
/// a clear error instead of making this process allocate without limit.
struct Limits {
  /// Largest flat request or response, in bytes (see marshal.hpp).
  std::size_t max_data_size = std::size_t{256} << 20;
  /// Deepest nesting of sub-type elements (fixed or dynamic, recursion
  /// included) a request or response may have; bounds the stack.
  unsigned max_nesting = 128;
  /// Provider side: responses a caller has not read yet that its
  /// connection may hold beyond what the kernel buffers (one response is
  /// always taken, whatever its size). More closes that caller's connection.
  std::size_t max_unread_responses = std::size_t{16} << 20;
  /// Provider side: a caller whose connection has taken no byte of its
  /// responses for this long loses the connection (it does not read).
  unsigned response_timeout_ms = 2000;
};

/// How a thread that waits for the other side waits: it first polls for up
/// to `spin_us` microseconds, yielding the CPU between polls (so a peer on
/// the same core runs at once), and only then sleeps in the kernel.
/// Waking a sleeping thread on another core costs a few µs on bare metal
/// and tens of µs on a VM, more than a whole call; a short spin saves it
/// whenever the answer (or the next request) comes quickly. At most
/// `spin_us` of CPU per wait is the price; 0 sleeps at once.
struct WaitPolicy {
  unsigned spin_us = 20;
};

}  // namespace ln::services
