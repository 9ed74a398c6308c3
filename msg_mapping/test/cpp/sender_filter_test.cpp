// Loop prevention per ROS publisher (bridge/sender_filter): messages a bridge
// published are not bridged back to LN, while a real ROS publisher on the same
// topic is. Through the bridge: ln_ros2_bridge/test/test_auto.py and
// test_cyclone.py.
#include "bridge/sender_filter.hpp"

#include <gtest/gtest.h>

#include <map>

namespace msg_mapping::bridge {
namespace {

Gid gid(char c) {
  Gid g;
  g.fill(static_cast<std::uint8_t>(c));
  return g;
}

const Gid bridge = gid('B'), other = gid('O'), foreign = gid('F'), late = gid('L');

// The ROS graph as the filter sees it: gid -> node ("" = not known yet).
struct Graph {
  std::map<Gid, std::string> nodes;
  int lookups = 0;
  std::vector<Endpoint> operator()() {
    ++lookups;
    std::vector<Endpoint> out;
    for (const auto& [g, node] : nodes) out.push_back({g, node});
    return out;
  }
};

struct SenderFilterTest : ::testing::Test {
  Graph graph;
  double now = 100.0;
  SenderFilter filter{[this] { return graph(); },
                      [](const std::string& node) { return matches_any(node, {"ln_ros2_bridge*"}); }, 3};

  // The Python bridge's former admit(): what goes out now for a message `value` of `sender`.
  std::vector<int> admit(const Gid& sender, int value) {
    const auto decision = filter.decide(sender, now);
    if (decision == SenderFilter::Decision::Hold) filter.hold(sender, {{}, value}, now);
    std::vector<int> out = values(filter.release(now, false));
    if (decision == SenderFilter::Decision::Forward) out.push_back(value);
    return out;
  }
  static std::vector<int> values(const std::vector<HeldMessage>& messages) {
    std::vector<int> out;
    for (const auto& m : messages) out.push_back(static_cast<int>(m.source_timestamp));
    return out;
  }
};

using Values = std::vector<int>;

TEST_F(SenderFilterTest, BridgePublishersAreDroppedOthersForwarded) {
  graph.nodes = {{bridge, "/ln_ros2_bridge_a"}, {other, "/ns/talker"}};
  EXPECT_EQ(admit(bridge, 1), Values{});
  EXPECT_EQ(admit(other, 2), Values{2});
  EXPECT_EQ(admit(bridge, 3), Values{});
  EXPECT_EQ(admit(other, 4), Values{4});
  EXPECT_EQ(filter.dropped(), 2u);
  EXPECT_TRUE(filter.is_bridge(bridge));
  EXPECT_FALSE(filter.is_bridge(other));
  const int lookups = graph.lookups;
  admit(other, 5);
  EXPECT_EQ(graph.lookups, lookups) << "a known publisher needs no graph look-up";
}

TEST_F(SenderFilterTest, MessagesWaitForTheGraphToNameTheirPublisher) {
  graph.nodes = {{late, ""}};  // discovered, node not known yet
  EXPECT_EQ(admit(late, 1), Values{});
  now += 0.1;
  EXPECT_EQ(admit(late, 2), Values{});
  EXPECT_EQ(filter.held_count(), 2u);
  graph.nodes[late] = "/talker";
  now += 0.1;
  EXPECT_EQ(admit(late, 3), (Values{1, 2, 3})) << "held messages first, in order";

  graph.nodes[bridge] = "";  // a bridge's publisher, found out later
  EXPECT_EQ(admit(bridge, 4), Values{});
  graph.nodes[bridge] = "/ln_ros2_bridge_b";
  now += 0.1;
  EXPECT_EQ(values(filter.release(now, true)), Values{});
  EXPECT_EQ(filter.dropped(), 1u);
  EXPECT_FALSE(filter.has_held());
}

TEST_F(SenderFilterTest, APublisherWithoutANodeIsForwardedAfterThePendingTime) {
  graph.nodes = {{foreign, ""}};  // e.g. a plain DDS participant: never gets a node
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(admit(foreign, i), Values{});
    now += 0.1;
  }
  EXPECT_EQ(values(filter.release(now, true)), Values{});
  now += 2.0;
  EXPECT_EQ(values(filter.release(now, true)), (Values{2, 3, 4})) << "the newest `hold` messages, in order";
  EXPECT_EQ(filter.take_nodeless(), std::vector<Gid>{foreign});
  EXPECT_TRUE(filter.take_nodeless().empty());
  EXPECT_EQ(admit(foreign, 5), Values{5});
}

TEST_F(SenderFilterTest, PublishersThatLeftAreForgotten) {
  graph.nodes = {{bridge, "/ln_ros2_bridge"}, {other, "/talker"}};
  admit(bridge, 1);
  admit(other, 2);
  graph.nodes = {{other, "/talker"}};
  filter.release(now, true);
  EXPECT_FALSE(filter.is_bridge(bridge));
  EXPECT_EQ(admit(other, 3), Values{3});
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
