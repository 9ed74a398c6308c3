// Array counts in message definitions are integer expressions ("4*4",
// "(3+1)*2"). LN 2.9 hands them to Python's eval(); we evaluate the same
// arithmetic subset with Python's semantics, and nothing else.
#pragma once

#include <cstdint>
#include <string_view>

namespace ln::md {

/// Evaluates `expression` and truncates the result toward zero as Python's
/// int() does. Supports integer literals (decimal, 0x, 0o, 0b, '_'
/// separators) and float literals (3.0, .5, 1e3), + - * / // % ** << >>
/// & | ^, unary + - ~, and parentheses, with Python's precedence.
/// Throws std::invalid_argument with a readable reason.
std::int64_t evaluate_count_expression(std::string_view expression);

}  // namespace ln::md
