// Waiting in tests: on a condition, bounded, never a fixed sleep.
#pragma once

#include <chrono>
#include <functional>
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

}  // namespace ln::test
