// Small string helpers shared by the message-definition code.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace ln::md::text {

constexpr std::string_view whitespace = " \t\r\n\v\f";

inline std::string_view strip(std::string_view s, std::string_view chars = whitespace) {
  const auto first = s.find_first_not_of(chars);
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(chars);
  return s.substr(first, last - first + 1);
}

/// Strips what Python's str.strip() strips: every Unicode white-space
/// character (ASCII blanks, U+0085, U+00A0, U+2000..U+200A, U+3000, ...),
/// which LN 2.9 removes around lines, names and counts. `s` is UTF-8.
std::string_view strip_unicode(std::string_view s);

/// Decodes the UTF-8 code point at `s[i]`, setting `length` (1 for an
/// invalid byte, which is returned as is).
char32_t decode_utf8(std::string_view s, std::size_t i, std::size_t& length);
/// Python's str.isspace() for one code point.
bool is_unicode_space(char32_t c);

inline bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

inline bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// A C identifier: [A-Za-z_][A-Za-z0-9_]*.
bool is_identifier(std::string_view s);
/// Valid UTF-8 (no overlong forms, no surrogates).
bool is_valid_utf8(std::string_view s);

/// Directory part of a '/'-separated path, "" when there is none.
std::string_view dirname(std::string_view path);
/// Joins like Python's os.path.join for two relative-or-absolute parts.
std::string join_path(std::string_view base, std::string_view tail);

}  // namespace ln::md::text
