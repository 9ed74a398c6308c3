#include "md/count_expression.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace ln::md {

TEST(CountExpression, EvaluatesIntegersAndArithmeticLikePython) {
  EXPECT_EQ(evaluate_count_expression("16"), 16);
  EXPECT_EQ(evaluate_count_expression(" 4*4 "), 16);
  EXPECT_EQ(evaluate_count_expression("(2+1)*3"), 9);
  EXPECT_EQ(evaluate_count_expression("2**3"), 8);
  EXPECT_EQ(evaluate_count_expression("2**3**2"), 512);  // right associative
  EXPECT_EQ(evaluate_count_expression("-2**2"), -4);     // ** binds tighter than unary -
  EXPECT_EQ(evaluate_count_expression("10//3"), 3);
  EXPECT_EQ(evaluate_count_expression("-7//2"), -4);  // floor division
  EXPECT_EQ(evaluate_count_expression("7/2"), 3);     // true division, then int() truncates
  EXPECT_EQ(evaluate_count_expression("-7/2"), -3);
  EXPECT_EQ(evaluate_count_expression("-7%3"), 2);  // sign follows the divisor
  EXPECT_EQ(evaluate_count_expression("0x10 + 0o10 + 0b10"), 26);
  EXPECT_EQ(evaluate_count_expression("1_000"), 1000);
  EXPECT_EQ(evaluate_count_expression("(-1)**3"), -1);
  EXPECT_EQ(evaluate_count_expression("6*6-1"), 35);
  // Float literals, as Python's int(eval(...)) sees them.
  EXPECT_EQ(evaluate_count_expression("3.0"), 3);
  EXPECT_EQ(evaluate_count_expression("1e1"), 10);
  EXPECT_EQ(evaluate_count_expression("2.5*2"), 5);
  EXPECT_EQ(evaluate_count_expression("9//2.5"), 3);
  EXPECT_EQ(evaluate_count_expression(".5+1.5"), 2);
  EXPECT_EQ(evaluate_count_expression("08.5"), 8);
  // Bitwise operators with Python precedence.
  EXPECT_EQ(evaluate_count_expression("1<<3"), 8);
  EXPECT_EQ(evaluate_count_expression("~-4"), 3);
  EXPECT_EQ(evaluate_count_expression("1 | 2 ^ 3 & 6"), 1 | (2 ^ (3 & 6)));
  EXPECT_EQ(evaluate_count_expression("1 + 2 << 1"), 6);
  EXPECT_EQ(evaluate_count_expression("-9 >> 1"), -5);
}

TEST(CountExpression, RejectsEverythingThatIsNotArithmetic) {
  for (const char* bad :
       {"",        "abc",   "3]",   "2][3", "__import__('os')",      "(1",    "1)",  "08",       "1e",
        ".",       "1/0",   "5//0", "5%0",  "9223372036854775807+1", "2**64", "3 4", "1.5 << 2", "1 << -1",
        "1 << 70", "2 < 3", "0x",   "0b2"}) {
    EXPECT_THROW(evaluate_count_expression(bad), std::invalid_argument) << "expression: " << bad;
  }
}

TEST(CountExpression, BoundsNestingDepth) {
  std::string deep(500, '(');
  deep += "1" + std::string(500, ')');
  EXPECT_THROW(evaluate_count_expression(deep), std::invalid_argument);
}

}  // namespace ln::md
