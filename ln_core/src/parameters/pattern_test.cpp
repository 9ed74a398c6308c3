#include "parameters/pattern.hpp"

#include <gtest/gtest.h>

namespace ln::paramcore {
namespace {

TEST(Pattern, GlobsAsLn29MatchesThem) {
  // Cases observed on LN 2.9 (parameter "ctrl.gain", "ctrl.sub.mat").
  EXPECT_TRUE(pattern_match("*", "ctrl.gain"));
  EXPECT_TRUE(pattern_match("ctrl*", "ctrl.sub.mat"));
  EXPECT_TRUE(pattern_match("ctrl.gain", "ctrl.gain"));
  EXPECT_TRUE(pattern_match("ctrl.?ain", "ctrl.gain"));
  EXPECT_TRUE(pattern_match("c*n", "ctrl.gain"));
  EXPECT_TRUE(pattern_match("*mat", "ctrl.sub.mat"));
  EXPECT_TRUE(pattern_match("ctrl.*.mat", "ctrl.sub.mat"));
  EXPECT_TRUE(pattern_match("ctrl.gain*", "ctrl.gain"));
  EXPECT_FALSE(pattern_match("ctrl.gai", "ctrl.gain"));
  EXPECT_FALSE(pattern_match("ctrl", "ctrl.gain"));
  EXPECT_FALSE(pattern_match("ctrl.", "ctrl.gain"));
  EXPECT_FALSE(pattern_match("ctrl.[gc]*", "ctrl.gain"));  // no character classes
  EXPECT_FALSE(pattern_match("", "ctrl.gain"));
}

TEST(Pattern, CommaSeparatedListsWithBlanksAsWritten) {
  EXPECT_TRUE(pattern_match("ctrl.gain,ctrl.u8", "ctrl.u8"));
  EXPECT_TRUE(pattern_match(",ctrl.gain", "ctrl.gain"));
  EXPECT_TRUE(pattern_match("ctrl.gain,", "ctrl.gain"));
  EXPECT_FALSE(pattern_match("ctrl.gain, ctrl.u8", "ctrl.u8"));  // " ctrl.u8" has a blank
  EXPECT_FALSE(pattern_match(",,", "x"));
}

TEST(Pattern, EveryNameTheGlobDescribes) {
  // LN 2.9 misses these (its '*' does not backtrack).
  EXPECT_TRUE(pattern_match("*.mat", "ctrl.sub.mat"));
  EXPECT_TRUE(pattern_match("**", "ctrl.gain"));
  EXPECT_TRUE(glob_match("a*b*c", "aXbYbZc"));
  EXPECT_FALSE(glob_match("a*b*c", "aXbYbZ"));
  EXPECT_TRUE(glob_match("*", ""));
  EXPECT_FALSE(glob_match("?", ""));
  EXPECT_TRUE(glob_match("a?c", "abc"));
  // Long names with many stars stay fast (no exponential backtracking).
  const std::string name(5000, 'a');
  EXPECT_FALSE(glob_match("*a*a*a*a*a*a*a*a*b", name));
}

}  // namespace
}  // namespace ln::paramcore
