#include "parameters/literal.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ln::paramcore {
namespace {

Literal parse_ok(const std::string& text) {
  Literal literal;
  std::string error;
  EXPECT_TRUE(parse_literal(text, literal, error)) << text << ": " << error;
  return literal;
}

std::string parse_error(const std::string& text) {
  Literal literal;
  std::string error;
  EXPECT_FALSE(parse_literal(text, literal, error)) << text;
  return error;
}

TEST(Literal, NumbersKeepTheirTextAndSign) {
  EXPECT_EQ(parse_ok(" 2.5 ").text, "2.5");
  EXPECT_EQ(parse_ok("-1e-3").text, "-1e-3");
  EXPECT_EQ(parse_ok("- 7").text, "-7");
  EXPECT_EQ(parse_ok("--7").text, "7");
  EXPECT_EQ(parse_ok("+0x10").text, "0x10");
  const Literal minus_inf = parse_ok("-inf");
  EXPECT_EQ(minus_inf.kind, Literal::Kind::Name);
  EXPECT_EQ(minus_inf.text, "-inf");
}

TEST(Literal, ArraysListsAndCalls) {
  const Literal a = parse_ok("array([[1., 2.], [3., -4.]], dtype=double)");
  ASSERT_EQ(a.kind, Literal::Kind::Call);
  EXPECT_EQ(a.text, "array");
  ASSERT_EQ(a.items.size(), 1u);
  ASSERT_EQ(a.items[0].items.size(), 2u);
  EXPECT_EQ(a.items[0].items[1].items[1].text, "-4.");
  ASSERT_NE(a.keyword("dtype"), nullptr);
  EXPECT_EQ(a.keyword("dtype")->text, "double");
  EXPECT_EQ(parse_ok("np.float64(2.5)").text, "np.float64");
  // numpy's str() separates by blanks only.
  EXPECT_EQ(parse_ok("[1 -2  3]").items.size(), 3u);
  EXPECT_EQ(parse_ok("[1, 2,]").items.size(), 2u);
  EXPECT_EQ(parse_ok("(5)").kind, Literal::Kind::Number);
  EXPECT_EQ(parse_ok("(5,)").kind, Literal::Kind::Tuple);
  EXPECT_EQ(parse_ok("('a.b', 'gen/x')").items[1].text, "gen/x");
}

TEST(Literal, TheQueryDictAnswerOfAProvider) {
  const Literal d = parse_ok(
      "{\n  'c.gain': dict(input=1.5, output=2., override_enabled=True, description='it\\'s \"q\"\\\\\\n'),\n"
      "  'c.v': dict(input=array([1, 2], dtype=int8), output=array([1, 2], dtype=int8), override_enabled=False, "
      "description=''),\n}\n");
  ASSERT_EQ(d.kind, Literal::Kind::Dict);
  ASSERT_EQ(d.items.size(), 4u);
  EXPECT_EQ(d.items[0].text, "c.gain");
  EXPECT_EQ(d.items[1].keyword("override_enabled")->text, "True");
  EXPECT_EQ(d.items[1].keyword("description")->text, "it's \"q\"\\\n");
  EXPECT_EQ(d.items[3].keyword("input")->items[0].items.size(), 2u);
  EXPECT_EQ(parse_ok("{\n}\n").items.size(), 0u);
}

TEST(Literal, ReportsWhatIsWrong) {
  EXPECT_NE(parse_error("array([1, 2)").find("offset"), std::string::npos);
  parse_error("");
  parse_error("   ");
  parse_error("[1, 2");
  parse_error("'open");
  parse_error("5 6");
  parse_error("-[1]");
  parse_error("f(a=1, 2)");
  parse_error("{1: }");
  EXPECT_NE(parse_error(std::string(100, '[') + std::string(100, ']')).find("deep"), std::string::npos);
}

TEST(Literal, StringLiteralsRoundTrip) {
  for (const std::string& text : std::vector<std::string>{"", "plain", "it's", "back\\slash", "line\nnext\ttab\r",
                                                          std::string("\x01\x7f", 2), "quote \" double", "ünïcode"}) {
    const std::string quoted = python_string_literal(text);
    EXPECT_EQ(quoted.front(), '\'');
    Literal back = parse_ok(quoted);
    EXPECT_EQ(back.kind, Literal::Kind::String);
    EXPECT_EQ(back.text, text) << quoted;
  }
  EXPECT_EQ(python_string_literal("it's \"q\"\\"), "'it\\'s \"q\"\\\\'");
  EXPECT_EQ(python_string_literal("a\nb\tc"), "'a\\nb\\tc'");
}

}  // namespace
}  // namespace ln::paramcore
