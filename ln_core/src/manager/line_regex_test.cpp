#include "manager/line_regex.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace ln::manager {
namespace {

bool matches(const std::string& pattern, const std::string& line) { return LineRegex(pattern).search(line); }

TEST(LineRegex, PythonSpellingsThatPosixLacks) {
  EXPECT_TRUE(matches("ready", "the node is ready now"));
  EXPECT_TRUE(matches("^listening on port \\d+$", "listening on port 54414"));
  EXPECT_FALSE(matches("^listening on port \\d+$", "listening on port x"));
  EXPECT_TRUE(matches("a\\tb", "a\tb"));
  EXPECT_TRUE(matches("(?:ab)+c", "ababc"));
  EXPECT_TRUE(matches("start.*?end", "start middle end"));
  EXPECT_TRUE(matches("[\\d.]+ ms", "took 12.5 ms"));
  EXPECT_TRUE(matches("\\s+done", "all   done"));
  EXPECT_TRUE(matches("\\bword\\b", "a word here"));
  EXPECT_FALSE(matches("\\bword\\b", "swordfish"));
  EXPECT_TRUE(matches("[]x]", "]"));
  EXPECT_TRUE(matches("[[:digit:]]{3}", "abc123"));
  EXPECT_TRUE(matches("\\.", "a.b"));
  EXPECT_FALSE(matches("\\.", "ab"));
}

TEST(LineRegex, RefusesWhatItCannotMatch) {
  EXPECT_THROW(LineRegex("(?=look)ahead"), std::invalid_argument);
  EXPECT_THROW(LineRegex("(?i)case"), std::invalid_argument);
  EXPECT_THROW(LineRegex("(a)\\1"), std::invalid_argument);
  EXPECT_THROW(LineRegex("[unclosed"), std::invalid_argument);
  EXPECT_THROW(LineRegex("(unbalanced"), std::invalid_argument);
  EXPECT_THROW(LineRegex("trailing\\"), std::invalid_argument);
}

TEST(LineRegex, LongLinesDoNotExhaustTheStack) {
  const std::string line(1 << 20, 'a');
  EXPECT_TRUE(matches("(a|b)*$", line));
  EXPECT_FALSE(matches("^(a|b)*c", line));
}

}  // namespace
}  // namespace ln::manager
