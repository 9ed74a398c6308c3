// When publishers report their packet counts (topic_stats.hpp): the policy
// that keeps the manager's rates right with one message per second at most.
#include "client/topic_stats.hpp"

#include <gtest/gtest.h>

namespace ln::clientlib {
namespace {

using Clock = PacketCountReports::Clock;
constexpr auto period = PacketCountReports::kPeriod;

/// Reports on a clock that the test moves on.
struct Reports {
  PacketCountReports reports;
  Clock::time_point now{};
  explicit Reports(std::uint64_t count) { reports.restart(count, now); }
  /// Whether a report of `count` is due one period later.
  bool due_a_period_later(std::uint64_t count) {
    now += period;
    return reports.due(count, now);
  }
};

TEST(PacketCountReports, ReportsWhileCountingThenOnceMoreThenNothing) {
  Reports r(0);
  EXPECT_TRUE(r.due_a_period_later(100));
  EXPECT_TRUE(r.due_a_period_later(200));
  EXPECT_TRUE(r.due_a_period_later(200)) << "the final report lets the rate drop to 0";
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(r.due_a_period_later(200)) << "idle: nothing to say";
  EXPECT_TRUE(r.due_a_period_later(201)) << "writing again";
}

TEST(PacketCountReports, NoShortIntervals) {
  Reports r(10);
  EXPECT_FALSE(r.reports.due(20, r.now + period / 4)) << "too soon after the manager learned the count";
  EXPECT_TRUE(r.reports.due(30, r.now + period / 2));
  EXPECT_FALSE(r.reports.due(40, r.now + period / 2 + period / 4));
}

TEST(PacketCountReports, RestartForgetsABurst) {
  Reports r(0);
  EXPECT_TRUE(r.due_a_period_later(50));
  r.reports.restart(50, r.now);  // publisher_ready told the manager the count
  EXPECT_FALSE(r.due_a_period_later(50)) << "the manager already knows 50 and has no rate to drop";
}

}  // namespace
}  // namespace ln::clientlib
