// Test support shared by the client's unit tests and its tests against a
// manager: bounded waiting for a condition (testing/wait.hpp), and what a
// waiting thread costs.
#pragma once

#include <sys/resource.h>
#include <time.h>

#include <chrono>
#include <functional>
#include <thread>

#include "testing/wait.hpp"

namespace ln::clienttest {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

using test::wait_until;

/// CPU time and voluntary context switches (wake-ups after sleeping) of the
/// calling thread; differences measure what a wait cost.
struct ThreadUsage {
  std::chrono::nanoseconds cpu{0};
  long wakeups = 0;

  static ThreadUsage now() {
    ThreadUsage usage;
    timespec cpu{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu);
    usage.cpu = std::chrono::seconds(cpu.tv_sec) + std::chrono::nanoseconds(cpu.tv_nsec);
    rusage counters{};
    ::getrusage(RUSAGE_THREAD, &counters);
    usage.wakeups = counters.ru_nvcsw;
    return usage;
  }
  ThreadUsage operator-(const ThreadUsage& before) const { return {cpu - before.cpu, wakeups - before.wakeups}; }
};

}  // namespace ln::clienttest
