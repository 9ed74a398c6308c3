// The client's I/O thread: one poll() loop that serves the manager
// connection, the peer server and its connections, timers and tasks posted
// from other threads. Handlers run in the loop thread and must not block.
#pragma once

#include <poll.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "transport/shm_segment.hpp"

namespace ln::clientlib {

class EventLoop {
 public:
  using FdHandler = std::function<void(short revents)>;
  using Task = std::function<void()>;
  using Clock = std::chrono::steady_clock;
  using TimerId = std::uint64_t;

  /// Throws Failure when the wake-up descriptor cannot be created.
  EventLoop();
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  /// Starts the thread. Throws Failure.
  void start(const std::string& thread_name);
  /// Ends the thread and waits for it; tasks still queued are dropped.
  /// Must not be called from the loop thread.
  void stop();
  bool in_loop_thread() const { return std::this_thread::get_id() == thread_id_.load(); }

  // ---- loop thread only (or before start)
  /// Calls `handler` with the poll revents whenever `fd` is ready for
  /// `events`. Replaces an earlier watch of the same fd.
  void watch(int fd, short events, FdHandler handler);
  void set_events(int fd, short events);
  void unwatch(int fd);
  TimerId run_after(std::chrono::nanoseconds delay, Task task);
  void cancel(TimerId id);

  // ---- any thread
  /// Runs `task` in the loop thread soon. Never blocks.
  void post(Task task);

 private:
  struct Watch {
    short events;
    std::uint64_t serial;
    FdHandler handler;
  };

  void run();
  void run_due_timers();
  void run_posted_tasks();
  int poll_timeout_ms() const;
  void wake() noexcept;

  transport::UniqueFd wake_fd_;
  std::thread thread_;
  std::atomic<std::thread::id> thread_id_{};
  std::atomic<bool> stopping_{false};

  std::map<int, Watch> watches_;
  std::uint64_t next_serial_ = 1;
  std::multimap<Clock::time_point, std::pair<TimerId, Task>> timers_;
  TimerId next_timer_ = 1;

  std::mutex posted_mutex_;
  std::vector<Task> posted_;
};

}  // namespace ln::clientlib
