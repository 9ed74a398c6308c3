// Loop prevention per ROS publisher (bridge/sender_filter): messages a bridge
// published are not bridged back to LN, while a real ROS publisher on the same
// topic is. Through the bridge: ln_ros2_bridge/test/test_auto.py and
// test_cyclone.py.
#include "bridge/sender_filter.hpp"

#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

namespace msg_mapping::bridge {
namespace {

Gid gid(char c) {
  Gid g;
  g.fill(static_cast<std::uint8_t>(c));
  return g;
}

const Gid bridge = gid('B'), other = gid('O'), foreign = gid('F'), late = gid('L');

// The ROS graph: gid -> node ("" = not known yet).
using Graph = std::map<Gid, std::string>;

std::vector<Endpoint> snapshot(const Graph& graph) {
  std::vector<Endpoint> out;
  for (const auto& [g, node] : graph) out.push_back({g, node});
  return out;
}

using Values = std::vector<int>;

struct SenderFilterTest : ::testing::Test {
  Graph graph;
  double now = 100.0;
  SenderFilter filter{[](const std::string& node) { return matches_any(node, {"ln_ros2_bridge*"}); }, 3};

  // A message `value` of `sender` taken: what goes out at once (nothing when held or dropped).
  Values take(const Gid& sender, int value) {
    const auto decision = filter.decide(sender);
    if (decision == SenderFilter::Decision::Hold) filter.hold(sender, {{}, value}, now);
    return decision == SenderFilter::Decision::Forward ? Values{value} : Values{};
  }
  // The path's thread: a graph snapshot, then what the held messages release.
  Values look(bool forget_departed = false) {
    filter.learn(snapshot(graph), forget_departed);
    Values out;
    for (const auto& m : filter.release(now)) out.push_back(static_cast<int>(m.source_timestamp));
    return out;
  }
};

TEST_F(SenderFilterTest, BridgePublishersAreDroppedOthersForwarded) {
  graph = {{bridge, "/ln_ros2_bridge_a"}, {other, "/ns/talker"}};
  EXPECT_EQ(take(bridge, 1), Values{});
  EXPECT_EQ(take(other, 2), Values{});
  EXPECT_EQ(look(), Values{2}) << "held until the graph was asked; the bridge's dropped";
  EXPECT_EQ(take(bridge, 3), Values{});
  EXPECT_EQ(take(other, 4), Values{4});
  EXPECT_EQ(filter.dropped(), 2u);
  EXPECT_TRUE(filter.is_bridge(bridge));
  EXPECT_FALSE(filter.is_bridge(other));
  EXPECT_FALSE(filter.has_held());
}

TEST_F(SenderFilterTest, MessagesWaitForTheGraphToNameTheirPublisher) {
  graph = {{late, ""}};  // discovered, node not known yet
  EXPECT_EQ(take(late, 1), Values{});
  now += 0.1;
  EXPECT_EQ(look(), Values{});
  EXPECT_EQ(take(late, 2), Values{});
  EXPECT_EQ(filter.held_count(), 2u);
  graph[late] = "/talker";
  now += 0.1;
  EXPECT_EQ(take(late, 3), Values{}) << "still held: the callback does not ask the graph";
  EXPECT_EQ(look(), (Values{1, 2, 3})) << "held messages in order";
  EXPECT_EQ(take(late, 4), Values{4});

  graph[bridge] = "";  // a bridge's publisher, found out later
  EXPECT_EQ(take(bridge, 5), Values{});
  graph[bridge] = "/ln_ros2_bridge_b";
  now += 0.1;
  EXPECT_EQ(look(), Values{});
  EXPECT_EQ(filter.dropped(), 1u);
  EXPECT_FALSE(filter.has_held());
}

TEST_F(SenderFilterTest, APublisherWithoutANodeIsForwardedAfterThePendingTime) {
  graph = {{foreign, ""}};  // e.g. a plain DDS participant: never gets a node
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(take(foreign, i), Values{});
    now += 0.1;
  }
  EXPECT_EQ(look(true), Values{});
  now += 2.0;
  EXPECT_EQ(look(true), (Values{2, 3, 4})) << "the newest `hold` messages, in order";
  EXPECT_EQ(filter.take_nodeless(), std::vector<Gid>{foreign});
  EXPECT_TRUE(filter.take_nodeless().empty());
  EXPECT_EQ(take(foreign, 5), Values{5});
}

TEST_F(SenderFilterTest, PublishersThatLeftAreForgotten) {
  graph = {{bridge, "/ln_ros2_bridge"}, {other, "/talker"}};
  look();
  EXPECT_TRUE(filter.is_bridge(bridge));
  graph = {{other, "/talker"}};
  look(false);
  EXPECT_TRUE(filter.is_bridge(bridge)) << "only a refresh forgets";
  look(true);
  EXPECT_FALSE(filter.is_bridge(bridge));
  EXPECT_EQ(take(other, 3), Values{3});
  EXPECT_EQ(take(bridge, 4), Values{}) << "a gid that comes back is asked about again";
  EXPECT_TRUE(filter.has_held());
}

TEST(BridgeNames, MatchTheLastComponentOfTheNodeName) {
  const std::vector<std::string> patterns{"ln_ros2_bridge*", "robot_bridge"};
  EXPECT_TRUE(matches_any("/ln_ros2_bridge", patterns));
  EXPECT_TRUE(matches_any("/ns/deep/ln_ros2_bridge_2", patterns));
  EXPECT_TRUE(matches_any("/robot_bridge", patterns));
  EXPECT_FALSE(matches_any("/robot_bridge_2", patterns));
  EXPECT_FALSE(matches_any("/ln_ros2_bridge/talker", patterns));
  EXPECT_FALSE(matches_any("", patterns));
}

}  // namespace
}  // namespace msg_mapping::bridge
