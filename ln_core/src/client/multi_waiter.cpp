#include "client/multi_waiter.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "client/ports.hpp"

namespace ln::clientlib {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::chrono::microseconds kSpin{50};
constexpr std::chrono::microseconds kFirstSleep{20};
constexpr std::chrono::microseconds kLongestSleep{1000};
// The notifier re-checks for shutdown at least this often.
constexpr double kNotifierSlice = 0.1;

}  // namespace

MultiWaiter::~MultiWaiter() {
  if (notifier_.joinable()) {
    stopping_.store(true);
    ack_cv_.notify_all();
    notifier_.join();
  }
}

void MultiWaiter::add_port(InPort* port) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (std::find(ports_.begin(), ports_.end(), port) == ports_.end()) ports_.push_back(port);
}

bool MultiWaiter::remove_port(InPort* port) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = std::find(ports_.begin(), ports_.end(), port);
  if (it == ports_.end()) return false;
  ports_.erase(it);
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
  const Clock::time_point start = Clock::now();
  const bool forever = timeout < 0 || std::isnan(timeout);
  const Clock::time_point deadline =
      forever ? Clock::time_point::max()
              : start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(timeout, 1e9)));
  if (const int readable = count_readable(); readable > 0 || timeout == 0) return readable;
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
    if (wait(kNotifierSlice) <= 0) continue;
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
