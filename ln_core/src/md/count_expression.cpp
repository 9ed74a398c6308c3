#include "md/count_expression.hpp"

#include <cctype>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ln::md {
namespace {

// Python distinguishes int and float results ("10/4" is 2.5, "10//4" is 2).
struct Number {
  bool is_float = false;
  std::int64_t integer = 0;
  double real = 0.0;

  double as_double() const { return is_float ? real : static_cast<double>(integer); }
  static Number of(std::int64_t v) { return Number{false, v, 0.0}; }
  static Number of(double v) { return Number{true, 0, v}; }
};

[[noreturn]] void fail(const std::string& why) { throw std::invalid_argument(why); }

Number floor_divide(const Number& a, const Number& b) {
  if (b.as_double() == 0.0) fail("division by zero");
  if (a.is_float || b.is_float) return Number::of(std::floor(a.as_double() / b.as_double()));
  if (a.integer == std::numeric_limits<std::int64_t>::min() && b.integer == -1) fail("the value is too large");
  std::int64_t q = a.integer / b.integer;
  if ((a.integer % b.integer != 0) && ((a.integer < 0) != (b.integer < 0))) --q;
  return Number::of(q);
}

Number modulo(const Number& a, const Number& b) {
  if (b.as_double() == 0.0) fail("modulo by zero");
  if (a.is_float || b.is_float) {
    double r = std::fmod(a.as_double(), b.as_double());
    if (r != 0.0 && ((r < 0) != (b.as_double() < 0))) r += b.as_double();
    return Number::of(r);
  }
  if (b.integer == -1) return Number::of(std::int64_t{0});
  std::int64_t r = a.integer % b.integer;
  if (r != 0 && ((r < 0) != (b.integer < 0))) r += b.integer;
  return Number::of(r);
}

Number power(const Number& base, const Number& exponent) {
  if (base.is_float || exponent.is_float || exponent.integer < 0) {
    const double r = std::pow(base.as_double(), exponent.as_double());
    if (!std::isfinite(r)) fail("the value is too large");
    return Number::of(r);
  }
  // 0, 1 and -1 never overflow; answering them directly bounds the loop
  // below to at most 63 multiplications.
  if (base.integer == 0) return Number::of(std::int64_t{exponent.integer == 0 ? 1 : 0});
  if (base.integer == 1) return Number::of(std::int64_t{1});
  if (base.integer == -1) return Number::of(std::int64_t{exponent.integer % 2 == 0 ? 1 : -1});
  std::int64_t result = 1;
  for (std::int64_t i = 0; i < exponent.integer; ++i)
    if (__builtin_mul_overflow(result, base.integer, &result)) fail("the value is too large");
  return Number::of(result);
}

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  Number parse() {
    Number value = bit_or();
    skip_blanks();
    if (pos_ != text_.size()) fail("unexpected '" + std::string(1, text_[pos_]) + "'");
    return value;
  }

 private:
  // Python's grammar and precedence, lowest first:
  //   bit_or := bit_xor ('|' bit_xor)*      bit_xor := bit_and ('^' bit_and)*
  //   bit_and := shift ('&' shift)*         shift := sum (('<<'|'>>') sum)*
  //   sum := term (('+'|'-') term)*         term := unary (('*'|'/'|'//'|'%') unary)*
  //   unary := ('-'|'+'|'~') unary | power  power := atom ['**' unary]
  //   atom := number | '(' bit_or ')'
  Number bit_or() {
    Number left = bit_xor();
    while (accept("|")) left = bitwise(left, bit_xor(), '|');
    return left;
  }

  Number bit_xor() {
    Number left = bit_and();
    while (accept("^")) left = bitwise(left, bit_and(), '^');
    return left;
  }

  Number bit_and() {
    Number left = shift();
    while (accept("&")) left = bitwise(left, shift(), '&');
    return left;
  }

  Number shift() {
    Number left = sum();
    for (;;) {
      if (accept("<<"))
        left = shift_left(left, sum());
      else if (accept(">>"))
        left = shift_right(left, sum());
      else
        return left;
    }
  }

  Number sum() {
    Number left = term();
    for (;;) {
      if (accept("+"))
        left = add(left, term(), +1);
      else if (accept("-"))
        left = add(left, term(), -1);
      else
        return left;
    }
  }

  Number term() {
    Number left = unary();
    for (;;) {
      if (accept("//"))
        left = floor_divide(left, unary());
      else if (accept("*"))
        left = multiply(left, unary());
      else if (accept("/"))
        left = divide(left, unary());
      else if (accept("%"))
        left = modulo(left, unary());
      else
        return left;
    }
  }

  Number unary() {
    if (accept("-")) {
      Number v = unary();
      if (v.is_float) return Number::of(-v.real);
      if (v.integer == std::numeric_limits<std::int64_t>::min()) fail("the value is too large");
      return Number::of(-v.integer);
    }
    if (accept("+")) return unary();
    if (accept("~")) {
      Number v = unary();
      if (v.is_float) fail("'~' needs an integer");
      return Number::of(~v.integer);  // Python: -x - 1
    }
    return power_expression();
  }

  Number power_expression() {
    Number base = atom();
    if (accept("**")) return power(base, unary());
    return base;
  }

  Number atom() {
    if (++depth_ > 100) fail("the expression is nested too deeply");
    Number value;
    if (accept("(")) {
      value = bit_or();
      if (!accept(")")) fail("missing ')'");
    } else {
      value = number();
    }
    --depth_;
    return value;
  }

  Number number() {
    skip_blanks();
    const std::size_t start = pos_;
    const std::string_view prefix = text_.substr(pos_, 2);
    if (prefix == "0x" || prefix == "0X") return based_integer(16);
    if (prefix == "0o" || prefix == "0O") return based_integer(8);
    if (prefix == "0b" || prefix == "0B") return based_integer(2);

    // A decimal integer or a Python float literal (3.0, .5, 1e3, 2.5E-1).
    std::string digits;
    bool is_float = false;
    auto take_digits = [&] {
      std::size_t n = 0;
      while (pos_ < text_.size() &&
             (std::isdigit(static_cast<unsigned char>(text_[pos_])) || (text_[pos_] == '_' && n > 0))) {
        if (text_[pos_] != '_') digits += text_[pos_], ++n;
        ++pos_;
      }
      return n;
    };
    std::size_t integer_digits = take_digits();
    if (pos_ < text_.size() && text_[pos_] == '.') {
      is_float = true;
      digits += text_[pos_++];
      if (take_digits() == 0 && integer_digits == 0)
        fail("expected a number at '" + std::string(text_.substr(start)) + "'");
    }
    if (integer_digits == 0 && !is_float) {
      if (start < text_.size()) fail("expected a number at '" + std::string(text_.substr(start)) + "'");
      fail("expected a number");
    }
    if (pos_ < text_.size() && (text_[pos_] == 'e' || text_[pos_] == 'E')) {
      is_float = true;
      digits += text_[pos_++];
      if (pos_ < text_.size() && (text_[pos_] == '+' || text_[pos_] == '-')) digits += text_[pos_++];
      if (take_digits() == 0) fail("incomplete exponent in '" + std::string(text_.substr(start, pos_ - start)) + "'");
    }
    if (pos_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '.'))
      fail("unexpected '" + std::string(1, text_[pos_]) + "' in a number");
    if (is_float) {
      const double value = std::strtod(digits.c_str(), nullptr);
      if (!std::isfinite(value)) fail("the value is too large");
      return Number::of(value);
    }
    if (digits.size() > 1 && digits.find_first_not_of('0') != std::string::npos && digits.front() == '0')
      fail("decimal numbers must not start with 0");
    std::int64_t value = 0;
    for (char c : digits)
      if (__builtin_mul_overflow(value, 10, &value) || __builtin_add_overflow(value, c - '0', &value))
        fail("the value is too large");
    return Number::of(value);
  }

  Number based_integer(int base) {
    pos_ += 2;
    std::int64_t value = 0;
    std::size_t digits = 0;
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      int digit;
      if (c == '_' && digits > 0) {
        ++pos_;
        continue;
      }
      if (c >= '0' && c <= '9')
        digit = c - '0';
      else if (c >= 'a' && c <= 'f')
        digit = c - 'a' + 10;
      else if (c >= 'A' && c <= 'F')
        digit = c - 'A' + 10;
      else
        break;
      if (digit >= base) fail("digit '" + std::string(1, c) + "' is invalid in base " + std::to_string(base));
      if (__builtin_mul_overflow(value, base, &value) || __builtin_add_overflow(value, digit, &value))
        fail("the value is too large");
      ++digits;
      ++pos_;
    }
    if (digits == 0) fail("expected digits after the base prefix");
    if (pos_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '.'))
      fail("unexpected '" + std::string(1, text_[pos_]) + "' in a number");
    return Number::of(value);
  }

  static Number bitwise(const Number& a, const Number& b, char op) {
    if (a.is_float || b.is_float) fail(std::string("'") + op + "' needs integers");
    switch (op) {
      case '|':
        return Number::of(a.integer | b.integer);
      case '^':
        return Number::of(a.integer ^ b.integer);
      default:
        return Number::of(a.integer & b.integer);
    }
  }

  static Number shift_left(const Number& a, const Number& b) {
    if (a.is_float || b.is_float) fail("'<<' needs integers");
    if (b.integer < 0) fail("negative shift count");
    if (a.integer == 0) return a;
    if (b.integer >= 63) fail("the value is too large");
    const std::int64_t shifted = static_cast<std::int64_t>(static_cast<std::uint64_t>(a.integer) << b.integer);
    if ((shifted >> b.integer) != a.integer) fail("the value is too large");
    return Number::of(shifted);
  }

  static Number shift_right(const Number& a, const Number& b) {
    if (a.is_float || b.is_float) fail("'>>' needs integers");
    if (b.integer < 0) fail("negative shift count");
    if (b.integer >= 63) return Number::of(std::int64_t{a.integer < 0 ? -1 : 0});
    return Number::of(a.integer >> b.integer);  // arithmetic: floors like Python
  }

  static Number add(const Number& a, const Number& b, int sign) {
    if (a.is_float || b.is_float) return Number::of(a.as_double() + sign * b.as_double());
    std::int64_t r = 0;
    const bool overflow =
        sign > 0 ? __builtin_add_overflow(a.integer, b.integer, &r) : __builtin_sub_overflow(a.integer, b.integer, &r);
    if (overflow) fail("the value is too large");
    return Number::of(r);
  }

  static Number multiply(const Number& a, const Number& b) {
    if (a.is_float || b.is_float) return Number::of(a.as_double() * b.as_double());
    std::int64_t r = 0;
    if (__builtin_mul_overflow(a.integer, b.integer, &r)) fail("the value is too large");
    return Number::of(r);
  }

  static Number divide(const Number& a, const Number& b) {
    if (b.as_double() == 0.0) fail("division by zero");
    return Number::of(a.as_double() / b.as_double());
  }

  bool accept(std::string_view token) {
    skip_blanks();
    if (text_.substr(pos_, token.size()) != token) return false;
    // "*" must not swallow the first half of "**", nor "/" of "//".
    if ((token == "*" || token == "/") && text_.substr(pos_ + 1, 1) == token) return false;
    pos_ += token.size();
    return true;
  }

  void skip_blanks() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t')) ++pos_;
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  int depth_ = 0;
};

}  // namespace

std::int64_t evaluate_count_expression(std::string_view expression) {
  const Number value = Parser(expression).parse();
  if (!value.is_float) return value.integer;
  if (!std::isfinite(value.real) || std::fabs(value.real) > 9.0e18) fail("the value is too large");
  return static_cast<std::int64_t>(value.real);  // int() truncates toward zero
}

}  // namespace ln::md
