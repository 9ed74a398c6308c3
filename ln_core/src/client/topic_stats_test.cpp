// When publishers report their packet counts (topic_stats.hpp): the policy
// that keeps the manager's rates right with one message per second at most.
#include "client/topic_stats.hpp"

#include <gtest/gtest.h>

namespace ln::clientlib {
namespace {

using Clock = PacketCountReports::Clock;
constexpr auto period = PacketCountReports::kPeriod;

TEST(PacketCountReports, ReportsWhileCountingThenOnceMoreThenNothing) {
  PacketCountReports reports;
  Clock::time_point now{};
  reports.restart(0, now);
  now += period;
  EXPECT_TRUE(reports.due(100, now));
  now += period;
  EXPECT_TRUE(reports.due(200, now));
  now += period;
  EXPECT_TRUE(reports.due(200, now)) << "the final report lets the rate drop to 0";
  for (int i = 0; i < 3; ++i) {
    now += period;
    EXPECT_FALSE(reports.due(200, now)) << "idle: nothing to say";
  }
  now += period;
  EXPECT_TRUE(reports.due(201, now)) << "writing again";
}

TEST(PacketCountReports, NoShortIntervals) {
  PacketCountReports reports;
  Clock::time_point now{};
  reports.restart(10, now);
  EXPECT_FALSE(reports.due(20, now + period / 4)) << "too soon after the manager learned the count";
  EXPECT_TRUE(reports.due(30, now + period / 2));
  EXPECT_FALSE(reports.due(40, now + period / 2 + period / 4));
}

TEST(PacketCountReports, RestartForgetsABurst) {
  PacketCountReports reports;
  Clock::time_point now{};
  reports.restart(0, now);
  now += period;
  EXPECT_TRUE(reports.due(50, now));
  reports.restart(50, now);  // publisher_ready told the manager the count
  now += period;
  EXPECT_FALSE(reports.due(50, now)) << "the manager already knows 50 and has no rate to drop";
}

}  // namespace
}  // namespace ln::clientlib
