#include "client/event_loop.hpp"

#include <pthread.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>

#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

// The library must never terminate its host program: a handler that throws
// (a bug, or bad_alloc) loses its event, not the process.
template <typename Callable, typename... Args>
void invoke_safely(Callable& callable, Args... args) noexcept {
  try {
    callable(args...);
  } catch (...) {
  }
}

}  // namespace

EventLoop::EventLoop() : wake_fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {
  if (!wake_fd_.valid()) throw errno_failure(errno, "creating the I/O thread's wake-up descriptor");
}

EventLoop::~EventLoop() { stop(); }

void EventLoop::start(const std::string& thread_name) {
  try {
    thread_ = std::thread([this, thread_name] {
      thread_id_.store(std::this_thread::get_id());
      ::pthread_setname_np(::pthread_self(), thread_name.substr(0, 15).c_str());
      run();
    });
  } catch (const std::system_error& error) {
    throw Failure(1, std::string("starting the I/O thread: ") + error.what());
  }
}

void EventLoop::stop() {
  if (!thread_.joinable()) return;
  stopping_.store(true);
  wake();
  thread_.join();
}

void EventLoop::watch(int fd, short events, FdHandler handler) {
  watches_[fd] = Watch{events, next_serial_++, std::move(handler)};
}

void EventLoop::set_events(int fd, short events) {
  if (auto it = watches_.find(fd); it != watches_.end()) it->second.events = events;
}

void EventLoop::unwatch(int fd) { watches_.erase(fd); }

EventLoop::TimerId EventLoop::run_after(std::chrono::nanoseconds delay, Task task) {
  const TimerId id = next_timer_++;
  timers_.emplace(Clock::now() + delay, std::make_pair(id, std::move(task)));
  return id;
}

void EventLoop::cancel(TimerId id) {
  for (auto it = timers_.begin(); it != timers_.end(); ++it) {
    if (it->second.first == id) {
      timers_.erase(it);
      return;
    }
  }
}

void EventLoop::post(Task task) {
  {
    std::lock_guard<std::mutex> lock(posted_mutex_);
    posted_.push_back(std::move(task));
  }
  wake();
}

void EventLoop::wake() noexcept {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t ignored = ::write(wake_fd_.get(), &one, sizeof one);
}

int EventLoop::poll_timeout_ms() const {
  if (timers_.empty()) return -1;
  const auto left = timers_.begin()->first - Clock::now();
  if (left <= Clock::duration::zero()) return 0;
  // Round up: waking a little late is better than spinning on a 0 timeout.
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(left).count() + 1;
  return static_cast<int>(std::min<long long>(ms, 60'000));
}

void EventLoop::run_due_timers() {
  const Clock::time_point now = Clock::now();
  while (!timers_.empty() && timers_.begin()->first <= now) {
    Task task = std::move(timers_.begin()->second.second);
    timers_.erase(timers_.begin());
    invoke_safely(task);
  }
}

void EventLoop::run_posted_tasks() {
  std::vector<Task> tasks;
  {
    std::lock_guard<std::mutex> lock(posted_mutex_);
    tasks.swap(posted_);
  }
  for (Task& task : tasks) invoke_safely(task);
}

void EventLoop::run() {
  std::vector<pollfd> fds;
  std::vector<std::uint64_t> serials;
  while (!stopping_.load()) {
    fds.clear();
    serials.clear();
    fds.push_back(pollfd{wake_fd_.get(), POLLIN, 0});
    serials.push_back(0);
    for (const auto& [fd, watch] : watches_) {
      fds.push_back(pollfd{fd, watch.events, 0});
      serials.push_back(watch.serial);
    }
    const int ready = ::poll(fds.data(), fds.size(), poll_timeout_ms());
    if (stopping_.load()) break;
    if (ready < 0 && errno != EINTR) continue;  // only EINTR/ENOMEM are possible; retry
    if (fds[0].revents != 0) {
      std::uint64_t count = 0;
      [[maybe_unused]] const ssize_t ignored = ::read(wake_fd_.get(), &count, sizeof count);
    }
    run_posted_tasks();
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      // A handler may have removed or replaced this watch meanwhile.
      auto it = watches_.find(fds[i].fd);
      if (it == watches_.end() || it->second.serial != serials[i]) continue;
      FdHandler handler = it->second.handler;  // a copy: the handler may unwatch itself
      invoke_safely(handler, fds[i].revents);
    }
    run_due_timers();
  }
  thread_id_.store(std::thread::id());
}

}  // namespace ln::clientlib
