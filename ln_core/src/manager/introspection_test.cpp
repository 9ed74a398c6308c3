// The manager's introspection beyond the tables of manager_test.cpp: topic
// packet counts and rates (topic_stats), manager_status, and the
// topic_publisher_available/_gone notifications, through real TCP
// connections to an in-process manager.
#include <gtest/gtest.h>
#include <unistd.h>

#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

using protocol::StringList;

class IntrospectionTest : public ManagerWithClientsTest {
 protected:
  static std::int64_t publish(TestClient& c, const std::string& topic) {
    const Message r = c.call(
        "publish", [&](Message& m) { m.set("topic", topic).set("message_definition", "mt/point").set("buffers", 1); });
    EXPECT_FALSE(r.is_error()) << r.error_text();
    return r.is_error() ? -1 : r.get_int("topic_id");
  }

  static Message publisher_ready(TestClient& c, std::int64_t topic_id, std::int64_t generation,
                                 std::optional<std::int64_t> packets = std::nullopt) {
    return c.call("publisher_ready", [&](Message& m) {
      m.set("topic_id", topic_id).set("segment_generation", generation);
      if (packets) m.set("packets", *packets);
    });
  }

  /// Sends topic_stats and waits until the manager has handled it (it
  /// handles a connection's messages in order; the ping answer comes after).
  static void report(TestClient& c, std::int64_t topic_id, std::int64_t packets) {
    auto stats = Message::notification("topic_stats");
    stats.set("topic_id", topic_id).set("packets", packets);
    ASSERT_TRUE(c.send_raw(protocol::encode(stats)));
    ASSERT_FALSE(c.call("ping").is_error());
  }

  /// The packets and rate columns of list_topics for `topic`.
  static std::pair<std::string, double> counted(TestClient& c, const std::string& topic) {
    const Message topics = c.call("list_topics");
    const StringList& names = topics.get_list("names");
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == topic) return {topics.get_list("packets").at(i), std::stod(topics.get_list("rates").at(i))};
    ADD_FAILURE() << "topic '" << topic << "' is not listed";
    return {"", -1};
  }
};

double seconds_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

TEST_F(IntrospectionTest, RateIsTheCountOverTheReportIntervalAndDropsToZero) {
  auto pub = client("publisher");
  const std::int64_t topic = publish(*pub, "robot.point");
  EXPECT_EQ(counted(*pub, "robot.point"), std::make_pair(std::string("0"), 0.0));

  const auto ready_sent = Clock::now();
  ASSERT_FALSE(publisher_ready(*pub, topic, 1, 0).is_error());
  const auto ready_done = Clock::now();
  // The interval is what is measured: let some time pass.
  std::this_thread::sleep_for(200ms);
  const auto report_sent = Clock::now();
  report(*pub, topic, 40);
  const auto report_done = Clock::now();
  const auto [packets, rate] = counted(*pub, "robot.point");
  EXPECT_EQ(packets, "40");
  // The manager timed both messages somewhere within these windows.
  EXPECT_GE(rate, 40 / seconds_between(ready_sent, report_done) - 0.001);
  EXPECT_LE(rate, 40 / seconds_between(ready_done, report_sent) + 0.001);

  report(*pub, topic, 40);  // the final report of a publisher that stopped writing
  EXPECT_EQ(counted(*pub, "robot.point"), std::make_pair(std::string("40"), 0.0));
}

TEST_F(IntrospectionTest, OnlyThePublishersOwnCountsAreTaken) {
  auto pub = client("publisher");
  auto other = client("other");
  const std::int64_t topic = publish(*pub, "robot.point");
  ASSERT_FALSE(publisher_ready(*pub, topic, 1, 100).is_error());  // e.g. after a manager restart
  EXPECT_EQ(counted(*pub, "robot.point").first, "100");
  report(*other, topic, 5000);   // not its topic
  report(*other, 999999, 5000);  // no topic at all
  report(*pub, topic, 7);        // a count going back starts over
  EXPECT_EQ(counted(*pub, "robot.point"), std::make_pair(std::string("7"), 0.0));

  // Before hello a report is dropped too, and the connection stays usable.
  TestClient early(manager.port());
  auto stats = Message::notification("topic_stats");
  stats.set("topic_id", topic).set("packets", 1);
  ASSERT_TRUE(early.send_raw(protocol::encode(stats)));
  EXPECT_FALSE(early.hello("early").is_error());
  EXPECT_EQ(counted(early, "robot.point").first, "7");
}

TEST_F(IntrospectionTest, ANewPublisherStartsFromZero) {
  auto first = client("first");
  auto second = client("second");
  auto sub = client("subscriber");
  ASSERT_FALSE(sub->call("subscribe",
                         [](Message& m) {
                           m.set("topic", "robot.point").set("message_definition", "mt/point").set("buffers", 1);
                           m.set("rate", -1.0).set("reliable", false);
                         })
                   .is_error());
  const std::int64_t topic = publish(*first, "robot.point");
  ASSERT_FALSE(publisher_ready(*first, topic, 1, 0).is_error());
  report(*first, topic, 50);
  ASSERT_FALSE(first->call("unpublish", [&](Message& m) { m.set("topic_id", topic); }).is_error());
  EXPECT_EQ(counted(*sub, "robot.point"), std::make_pair(std::string("0"), 0.0)) << "no publisher, no count";
  EXPECT_EQ(publish(*second, "robot.point"), topic);
  EXPECT_EQ(counted(*sub, "robot.point"), std::make_pair(std::string("0"), 0.0));
}

TEST_F(IntrospectionTest, ManagerStatusDescribesTheManager) {
  auto a = client("alpha");
  auto b = client("beta");
  publish(*a, "a.topic");
  ASSERT_FALSE(b->call("register_service", [](Message& m) {
                  m.set("name", "b.service").set("interface", "mt/add").set("signature", "s");
                }).is_error());
  TestClient c(manager.port());
  const Message hello = c.hello("gamma");
  const Message status = c.call("manager_status");
  ASSERT_FALSE(status.is_error()) << status.error_text();
  EXPECT_NE(status.get_string("version").find("ln_core"), std::string::npos);
  EXPECT_EQ(status.get_string("version"), hello.get_string("manager_version"));
  EXPECT_EQ(status.get_int("pid"), ::getpid());  // the manager runs in this process
  EXPECT_EQ(status.get_string("address"), "127.0.0.1:" + std::to_string(manager.port()));
  EXPECT_GT(status.get_double("uptime"), 0.0);
  EXPECT_LT(status.get_double("uptime"), 120.0);
  EXPECT_EQ(status.get_int("clients"), 3);
  EXPECT_EQ(status.get_int("topics"), 1);
  EXPECT_EQ(status.get_int("services"), 1);
  const StringList& dirs = status.get_list("message_definition_dirs");
  ASSERT_GE(dirs.size(), 1u);
  EXPECT_EQ(dirs.front(), dir.path() + "/md") << "the configured directory is searched first";
}

TEST_F(IntrospectionTest, EveryClientHearsWhenATopicGainsOrLosesItsPublisher) {
  auto watcher = client("watcher");
  auto pub = client("publisher");
  const std::int64_t topic = publish(*pub, "robot.point");
  EXPECT_TRUE(watcher->no_notification_within(50ms)) << "not before the segment is ready";
  ASSERT_FALSE(publisher_ready(*pub, topic, 1).is_error());
  const Message available = watcher->wait_notification("topic_publisher_available");
  EXPECT_EQ(available.get_string("name"), "robot.point");
  EXPECT_EQ(available.get_string("publisher"), "publisher");
  EXPECT_EQ(pub->wait_notification("topic_publisher_available").get_string("name"), "robot.point");

  ASSERT_FALSE(publisher_ready(*pub, topic, 2).is_error());  // a new segment: still the same publisher
  ASSERT_FALSE(pub->call("unpublish", [&](Message& m) { m.set("topic_id", topic); }).is_error());
  const auto gone = watcher->next_notification();
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->method(), "topic_publisher_gone") << "nothing in between";
  EXPECT_EQ(gone->get_string("name"), "robot.point");

  // A publisher that never got ready was never announced, so nobody hears of it leaving.
  const std::int64_t again = publish(*pub, "robot.point");
  ASSERT_FALSE(pub->call("unpublish", [&](Message& m) { m.set("topic_id", again); }).is_error());
  EXPECT_TRUE(watcher->no_notification_within(50ms));

  // A publisher that crashes leaves like one that unpublishes.
  ASSERT_FALSE(publisher_ready(*pub, publish(*pub, "robot.point"), 3).is_error());
  EXPECT_EQ(watcher->wait_notification("topic_publisher_available").get_string("publisher"), "publisher");
  pub->close();
  EXPECT_EQ(watcher->wait_notification("topic_publisher_gone").get_string("name"), "robot.point");
}

}  // namespace
}  // namespace ln::manager::testing
