#include "client/multi_waiter.hpp"

#include <fcntl.h>
#include <linux/futex.h>
#include <linux/time_types.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstddef>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "client/ports.hpp"
#include "transport/shm_segment.hpp"

#ifndef SYS_futex_waitv
#define SYS_futex_waitv 449
#endif

namespace ln::clientlib {
namespace {

using Clock = std::chrono::steady_clock;
// Polling (without futex_waitv) and ports that cannot be watched.
constexpr std::chrono::microseconds kSpin{50};
constexpr std::chrono::microseconds kFirstSleep{20};
constexpr std::chrono::microseconds kLongestSleep{1000};

std::atomic<bool> simulate_enosys{false};
std::atomic<bool> waitv_missing{false};

/// Sleeps until one of the words no longer holds its value (or is woken), a
/// signal comes or `until` passes. Returns 0 then, else the errno of
/// futex_waitv (ENOSYS where the kernel or seccomp lacks it).
int futex_waitv_until(struct futex_waitv* entries, std::size_t count, Clock::time_point until) noexcept {
  if (simulate_enosys.load(std::memory_order_relaxed)) return ENOSYS;
  __kernel_timespec at{};
  __kernel_timespec* timeout = nullptr;
  if (until != Clock::time_point::max()) {
    // steady_clock is CLOCK_MONOTONIC; futex_waitv takes an absolute time.
    const auto since_epoch = std::chrono::duration_cast<std::chrono::nanoseconds>(until.time_since_epoch()).count();
    at.tv_sec = since_epoch / 1000000000;
    at.tv_nsec = since_epoch % 1000000000;
    timeout = &at;
  }
  if (::syscall(SYS_futex_waitv, entries, static_cast<unsigned>(count), 0u, timeout, CLOCK_MONOTONIC) >= 0) return 0;
  const int error = errno;
  return error == EAGAIN || error == EINTR || error == ETIMEDOUT ? 0 : error;
}

Clock::time_point deadline_after(Clock::time_point start, double timeout) {
  if (timeout < 0 || std::isnan(timeout)) return Clock::time_point::max();
  return start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(timeout, 1e9)));
}

}  // namespace

/// One futex_waitv prepared on a waiter's words (see the header). Lives on
/// the stack: no allocation, so waiting never throws.
class MultiWaiter::Sleep {
 public:
  /// Checks the ports; the caller holds waiter.mutex_.
  explicit Sleep(MultiWaiter& waiter) noexcept {
    add(&waiter.wake_word_, waiter.wake_word_.load(std::memory_order_seq_cst));
    const std::atomic<std::uint32_t>* changes = InPort::segment_change_word();
    add(changes, changes->load(std::memory_order_seq_cst));
    if (waiter.stopping_.load(std::memory_order_seq_cst)) {
      stopped_ = true;
      return;
    }
    for (InPort* port : waiter.ports_) {
      transport::ShmWakeWatch& watch = watches_[count_];
      switch (port->check_before_sleep(watch)) {
        case InPort::WaitCheck::readable:
          ++readable_;
          break;
        case InPort::WaitCheck::busy:
          partial_ = true;
          break;
        case InPort::WaitCheck::not_readable:
          break;
      }
      if (!watch.active()) continue;
      if (count_ == kMaxEntries) {
        watch.withdraw();  // more segments than futex_waitv takes: poll the rest
        partial_ = true;
        continue;
      }
      add(watch.word(), watch.expected());
    }
  }

  int readable() const noexcept { return readable_; }
  bool stopped() const noexcept { return stopped_; }
  /// Some port is not watched: sleep only briefly.
  bool partial() const noexcept { return partial_; }
  /// See futex_waitv_until.
  int until(Clock::time_point until) noexcept { return futex_waitv_until(entries_.data(), count_, until); }

 private:
  static constexpr std::size_t kMaxEntries = FUTEX_WAITV_MAX;

  void add(const std::atomic<std::uint32_t>* word, std::uint32_t expected) noexcept {
    struct futex_waitv& entry = entries_[count_++];
    entry.val = expected;
    entry.uaddr = reinterpret_cast<std::uintptr_t>(word);
    entry.flags = FUTEX_32;  // not private: segment words are shared, and wakers use shared wakes
    entry.__reserved = 0;
  }

  std::array<struct futex_waitv, kMaxEntries> entries_{};
  // watches_[i] belongs to entries_[i] (the first two entries have none); the
  // last one may be an unused spare. Destroyed (withdrawn) after the sleep.
  std::array<transport::ShmWakeWatch, kMaxEntries + 1> watches_{};
  std::size_t count_ = 0;
  int readable_ = 0;
  bool partial_ = false;
  bool stopped_ = false;
};

MultiWaiter::~MultiWaiter() {
  {
    std::lock_guard<std::mutex> lock(ack_mutex_);  // so that the notifier cannot miss it
    stopping_.store(true, std::memory_order_seq_cst);
  }
  ack_cv_.notify_all();
  wake();
  if (notifier_.joinable()) notifier_.join();
}

void MultiWaiter::simulate_missing_futex_waitv(bool missing) noexcept {
  simulate_enosys.store(missing);
  if (!missing) waitv_missing.store(false);
}

bool MultiWaiter::event_driven() noexcept { return !waitv_missing.load(std::memory_order_relaxed); }

void MultiWaiter::wake() noexcept {
  wake_word_.fetch_add(1, std::memory_order_seq_cst);
  transport::futex_wake_all(&wake_word_);
}

void MultiWaiter::add_port(InPort* port) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::find(ports_.begin(), ports_.end(), port) != ports_.end()) return;
    ports_.push_back(port);
  }
  wake();  // it may be readable already
}

bool MultiWaiter::remove_port(InPort* port) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = std::find(ports_.begin(), ports_.end(), port);
    if (it == ports_.end()) return false;
    ports_.erase(it);
  }
  wake();  // a sleeping wait still watches its segment
  return true;
}

bool MultiWaiter::can_read(InPort* port) {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::find(ports_.begin(), ports_.end(), port) != ports_.end() && port->readable_now();
}

int MultiWaiter::count_readable() {
  std::lock_guard<std::mutex> lock(mutex_);
  int readable = 0;
  for (InPort* port : ports_) readable += port->readable_now() ? 1 : 0;
  return readable;
}

int MultiWaiter::wait(double timeout) {
  const Clock::time_point deadline = deadline_after(Clock::now(), timeout);
  if (const int readable = count_readable(); readable > 0 || timeout == 0) return readable;
  std::chrono::microseconds step = kFirstSleep;
  while (event_driven()) {
    std::unique_lock<std::mutex> lock(mutex_);
    Sleep sleep(*this);
    lock.unlock();
    if (sleep.readable() > 0 || sleep.stopped()) return sleep.readable();
    const Clock::time_point now = Clock::now();
    if (now >= deadline) return 0;
    Clock::time_point until = deadline;
    if (sleep.partial()) {
      until = now + std::min<Clock::duration>(step, deadline - now);
      step = std::min(step * 2, kLongestSleep);
    }
    const int error = sleep.until(until);
    if (error == ENOSYS || error == EPERM) {
      waitv_missing.store(true);
    } else if (error != 0) {
      return poll(deadline);  // unexpected (EFAULT, EINVAL, ENOMEM): poll this time
    }
  }
  return poll(deadline);
}

int MultiWaiter::poll(Clock::time_point deadline) {
  const Clock::time_point start = Clock::now();
  while (Clock::now() - start < kSpin && Clock::now() < deadline) {
    if (const int readable = count_readable(); readable > 0) return readable;
  }
  std::chrono::microseconds sleep = kFirstSleep;
  for (;;) {
    const Clock::time_point now = Clock::now();
    if (now >= deadline) return count_readable();
    std::this_thread::sleep_for(std::min<Clock::duration>(sleep, deadline - now));
    if (const int readable = count_readable(); readable > 0) return readable;
    sleep = std::min(sleep * 2, kLongestSleep);
    if (stopping_.load()) return 0;
  }
}

int MultiWaiter::start_pipe_notifier() {
  if (notifier_.joinable()) return pipe_read_.get();
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC | O_NONBLOCK) != 0) throw errno_failure(errno, "creating the multi-waiter's pipe");
  pipe_read_.reset(fds[0]);
  pipe_write_.reset(fds[1]);
  try {
    notifier_ = std::thread([this] { notifier_main(); });
  } catch (const std::system_error& error) {
    throw Failure(LNE_CHECK_ERRNO, std::string("starting the pipe notifier thread: ") + error.what());
  }
  return pipe_read_.get();
}

int MultiWaiter::acknowledge() {
  if (!notifier_.joinable()) return -LNE_INVALID_PARAMETER;
  char byte;
  while (::read(pipe_read_.get(), &byte, 1) == 1) {
  }
  std::lock_guard<std::mutex> lock(ack_mutex_);
  notified_ = false;
  ack_cv_.notify_all();
  return 0;
}

void MultiWaiter::notifier_main() {
  while (!stopping_.load()) {
    // Without a time limit: the destructor's wake() ends the wait.
    if (wait(-1) <= 0) continue;
    {
      std::lock_guard<std::mutex> lock(ack_mutex_);
      notified_ = true;
    }
    const char byte = 1;
    [[maybe_unused]] const ssize_t ignored = ::write(pipe_write_.get(), &byte, 1);
    // One notification at a time: wait until the program has handled it.
    std::unique_lock<std::mutex> lock(ack_mutex_);
    ack_cv_.wait(lock, [this] { return !notified_ || stopping_.load(); });
  }
}

}  // namespace ln::clientlib
