#include "parameters/pattern.hpp"

#include <gtest/gtest.h>

#include <initializer_list>
#include <string_view>

namespace ln::paramcore {
namespace {

// {pattern, name, whether the pattern matches the name}
struct Case {
  const char* pattern;
  const char* name;
  bool matches;
};

// Each case through `match` (pattern_match or glob_match).
void expect_matches(bool (*match)(std::string_view, std::string_view), std::initializer_list<Case> cases) {
  for (const Case& c : cases)
    EXPECT_EQ(match(c.pattern, c.name), c.matches) << "pattern '" << c.pattern << "', name '" << c.name << "'";
}

TEST(Pattern, GlobsAsLn29MatchesThem) {
  // Cases observed on LN 2.9 (parameter "ctrl.gain", "ctrl.sub.mat").
  expect_matches(pattern_match, {
                                    {"*", "ctrl.gain", true},
                                    {"ctrl*", "ctrl.sub.mat", true},
                                    {"ctrl.gain", "ctrl.gain", true},
                                    {"ctrl.?ain", "ctrl.gain", true},
                                    {"c*n", "ctrl.gain", true},
                                    {"*mat", "ctrl.sub.mat", true},
                                    {"ctrl.*.mat", "ctrl.sub.mat", true},
                                    {"ctrl.gain*", "ctrl.gain", true},
                                    {"ctrl.gai", "ctrl.gain", false},
                                    {"ctrl", "ctrl.gain", false},
                                    {"ctrl.", "ctrl.gain", false},
                                    {"ctrl.[gc]*", "ctrl.gain", false},  // no character classes
                                    {"", "ctrl.gain", false},
                                });
}

TEST(Pattern, CommaSeparatedListsWithBlanksAsWritten) {
  expect_matches(pattern_match, {
                                    {"ctrl.gain,ctrl.u8", "ctrl.u8", true},
                                    {",ctrl.gain", "ctrl.gain", true},
                                    {"ctrl.gain,", "ctrl.gain", true},
                                    {"ctrl.gain, ctrl.u8", "ctrl.u8", false},  // " ctrl.u8" has a blank
                                    {",,", "x", false},
                                });
}

TEST(Pattern, EveryNameTheGlobDescribes) {
  // LN 2.9 misses these (its '*' does not backtrack).
  expect_matches(pattern_match, {
                                    {"*.mat", "ctrl.sub.mat", true},
                                    {"**", "ctrl.gain", true},
                                });
  expect_matches(glob_match, {
                                 {"a*b*c", "aXbYbZc", true},
                                 {"a*b*c", "aXbYbZ", false},
                                 {"*", "", true},
                                 {"?", "", false},
                                 {"a?c", "abc", true},
                             });
  // Long names with many stars stay fast (no exponential backtracking).
  const std::string name(5000, 'a');
  EXPECT_FALSE(glob_match("*a*a*a*a*a*a*a*a*b", name));
}

}  // namespace
}  // namespace ln::paramcore
