// Regular expressions of .lnc files (ready_regex, warning_regex): LN 2.9
// takes them as Python `re` patterns searched in a line of output. ln_core
// matches them with POSIX extended expressions (glibc's regex: no recursion,
// so no output line can exhaust the manager's stack), after translating
// what Python writes differently: \d \D, \t \n \r, (?:...), lazy
// quantifiers, escapes inside [...]. Patterns that need more of Python
// (look-arounds, inline flags, back-references) are refused with a reason.
#pragma once

#include <regex.h>

#include <memory>
#include <string>
#include <string_view>

namespace ln::manager {

class LineRegex {
 public:
  /// Compiles `pattern`. Throws std::invalid_argument with the reason.
  explicit LineRegex(const std::string& pattern);

  /// Whether the pattern occurs anywhere in `line`.
  bool search(std::string_view line) const;

  const std::string& pattern() const { return pattern_; }

  /// `pattern` in POSIX ERE syntax (exposed for tests). Throws
  /// std::invalid_argument for what has no translation.
  static std::string to_posix(const std::string& pattern);

 private:
  struct Compiled;
  std::string pattern_;
  std::shared_ptr<Compiled> compiled_;
};

}  // namespace ln::manager
