// Waiting in tests: on a condition, bounded, never a fixed sleep.
#pragma once

#include <sys/syscall.h>
#include <sys/types.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <thread>

namespace ln::test {

/// Checks `condition` every 2 ms until it holds (true) or `timeout` passes (false).
inline bool wait_until(const std::function<bool()>& condition,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!condition()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

/// The calling thread's kernel id (for thread_sleeps()).
inline pid_t current_thread_id() { return static_cast<pid_t>(::syscall(SYS_gettid)); }

/// Whether thread `tid` of this process sleeps in the kernel (state S in
/// /proc/self/task/TID/stat): a thread started to make a blocking call has
/// entered it. Linux only, like the library.
inline bool thread_sleeps(pid_t tid) {
  if (tid <= 0) return false;
  std::ifstream file("/proc/self/task/" + std::to_string(tid) + "/stat");
  const std::string stat((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const auto end_of_name = stat.rfind(')');  // the name, in parentheses, may hold anything
  return end_of_name != std::string::npos && end_of_name + 2 < stat.size() && stat[end_of_name + 2] == 'S';
}

}  // namespace ln::test
