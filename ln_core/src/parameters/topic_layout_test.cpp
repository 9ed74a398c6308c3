#include "parameters/topic_layout.hpp"

#include <gtest/gtest.h>

namespace ln::paramcore {
namespace {

TEST(TopicLayout, NestsLikeTheNamesWithOneFieldDefinitionPerKind) {
  const TopicLayout layout = topic_layout({{"ctrl.gain", ElementType::Double, 1},
                                           {"ctrl.sub.mat", ElementType::Int16, 6},
                                           {"other.flag", ElementType::Boolean, 1},
                                           {"ctrl.speed", ElementType::Double, 1}});
  ASSERT_EQ(layout.error, "");
  // Packet order follows the tree: ctrl.{gain, sub.mat, speed}, then other.flag.
  EXPECT_EQ(layout.order, (std::vector<std::size_t>{0, 1, 3, 2}));
  EXPECT_EQ(layout.packet_size, (8 + 8 + 1) + (12 + 12 + 1) + (8 + 8 + 1) + (1 + 1 + 1));
  std::map<std::string, std::string> texts(layout.definitions.begin(), layout.definitions.end());
  EXPECT_EQ(texts.at("gen/ln/parameters/double_field"), "double input\ndouble output\nuint8_t override_enabled\n");
  EXPECT_EQ(texts.at("gen/ln/parameters/int16x6_field"),
            "int16_t input[6]\nint16_t output[6]\nuint8_t override_enabled\n");
  EXPECT_EQ(texts.at("gen/ln/parameters/bool_field"), "uint8_t input\nuint8_t output\nuint8_t override_enabled\n");
  EXPECT_EQ(layout.definitions.size(), 3u + 4u);  // three field kinds; root, ctrl, sub, other
  // Every definition comes after the ones it imports; the root is last.
  EXPECT_EQ(layout.definitions.back().first, layout.root);
  const std::string& root_text = layout.definitions.back().second;
  EXPECT_NE(root_text.find(" ctrl\n"), std::string::npos);
  EXPECT_NE(root_text.find(" other\n"), std::string::npos);
  for (std::size_t i = 0; i < layout.definitions.size(); ++i)
    for (std::size_t j = i + 1; j < layout.definitions.size(); ++j)
      EXPECT_EQ(layout.definitions[i].second.find("\"" + layout.definitions[j].first + "\""), std::string::npos);
  // Equal structures, equal names.
  EXPECT_EQ(topic_layout({{"ctrl.gain", ElementType::Double, 1}}).root,
            topic_layout({{"ctrl.gain", ElementType::Double, 1}}).root);
  EXPECT_NE(topic_layout({{"ctrl.gain", ElementType::Double, 1}}).root,
            topic_layout({{"ctrl.gain", ElementType::Single, 1}}).root);
}

TEST(TopicLayout, NamesThatAreNoTreeAreRefused) {
  EXPECT_NE(topic_layout({{"a", ElementType::Double, 1}, {"a.b", ElementType::Double, 1}}).error.find("also the name"),
            std::string::npos);
  EXPECT_NE(topic_layout({{"a..b", ElementType::Double, 1}}).error.find("empty name part"), std::string::npos);
}

TEST(TopicLayout, PacketsHoldInputOutputAndTheOverrideFlag) {
  std::vector<std::uint8_t> packet;
  append_to_packet(packet, {1, 2}, {3, 4}, true);
  append_to_packet(packet, {5}, {6}, false);
  EXPECT_EQ(packet, (std::vector<std::uint8_t>{1, 2, 3, 4, 1, 5, 6, 0}));
}

}  // namespace
}  // namespace ln::paramcore
