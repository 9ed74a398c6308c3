#include "manager/line_regex.hpp"

#include <stdexcept>

namespace ln::manager {

struct LineRegex::Compiled {
  regex_t regex{};
  bool valid = false;
  ~Compiled() {
    if (valid) ::regfree(&regex);
  }
};

namespace {

// The character an escape means inside [...] in Python, as POSIX bracket
// content (where a backslash is an ordinary character).
std::string bracket_escape(char c) {
  switch (c) {
    case 'd':
      return "0-9";
    case 'w':
      return "A-Za-z0-9_";
    case 's':
      return " \t\r\n\f\v";
    case 't':
      return "\t";
    case 'n':
      return "\n";
    case 'r':
      return "\r";
    case 'f':
      return "\f";
    case 'v':
      return "\v";
    case '\\':
      return "\\";
    case ']':
      throw std::invalid_argument("\\] inside [...] has no POSIX form; put ] first in the set instead");
    case 'D':
    case 'W':
    case 'S':
      throw std::invalid_argument(std::string("\\") + c + " inside [...] is not supported");
    default:
      return std::string(1, c);
  }
}

}  // namespace

std::string LineRegex::to_posix(const std::string& pattern) {
  std::string out;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    const char c = pattern[i];
    if (c == '\\') {
      if (++i >= pattern.size()) throw std::invalid_argument("the pattern ends with a lone backslash");
      const char e = pattern[i];
      if (e == 'd')
        out += "[0-9]";
      else if (e == 'D')
        out += "[^0-9]";
      else if (e == 't')
        out += '\t';
      else if (e == 'n')
        out += '\n';
      else if (e == 'r')
        out += '\r';
      else if (e == 'A')
        out += '^';
      else if (e == 'Z' || e == 'z')
        out += '$';
      else if (e >= '1' && e <= '9')
        throw std::invalid_argument("back-references (\\1 ...) are not supported");
      else
        out += std::string("\\") + e;  // \w \W \s \S \b \B \. \( ... as in Python
    } else if (c == '[') {
      // a bracket expression: copy up to its closing ']' (which may come first)
      out += '[';
      std::size_t j = i + 1;
      if (j < pattern.size() && pattern[j] == '^') out += pattern[j++];
      if (j < pattern.size() && pattern[j] == ']') out += pattern[j++];
      for (; j < pattern.size() && pattern[j] != ']'; ++j) {
        if (pattern[j] == '\\' && j + 1 < pattern.size())
          out += bracket_escape(pattern[++j]);
        else if (pattern[j] == '[' && j + 1 < pattern.size() && pattern[j + 1] == ':') {
          const auto end = pattern.find(":]", j + 2);  // a POSIX class like [:digit:]
          if (end == std::string::npos) throw std::invalid_argument("'[:' without ':]'");
          out += pattern.substr(j, end + 2 - j);
          j = end + 1;
        } else {
          out += pattern[j];
        }
      }
      if (j >= pattern.size()) throw std::invalid_argument("'[' without its closing ']'");
      out += ']';
      i = j;
    } else if (c == '(' && i + 1 < pattern.size() && pattern[i + 1] == '?') {
      if (i + 2 < pattern.size() && pattern[i + 2] == ':') {
        out += '(';  // a non-capturing group: grouping is all a search needs
        i += 2;
      } else {
        throw std::invalid_argument("'(?" + pattern.substr(i + 2, 1) +
                                    "' (look-arounds, inline flags, named groups) is not supported");
      }
    } else if (c == '?' && i > 0 && !out.empty() &&
               (pattern[i - 1] == '*' || pattern[i - 1] == '+' || pattern[i - 1] == '?' || pattern[i - 1] == '}') &&
               (i < 2 || pattern[i - 2] != '\\')) {
      // a lazy quantifier: whether a line matches does not depend on laziness
    } else {
      out += c;
    }
  }
  return out;
}

LineRegex::LineRegex(const std::string& pattern) : pattern_(pattern), compiled_(std::make_shared<Compiled>()) {
  const std::string posix = to_posix(pattern);
  const int error = ::regcomp(&compiled_->regex, posix.c_str(), REG_EXTENDED | REG_NOSUB);
  if (error != 0) {
    char text[256] = "";
    ::regerror(error, &compiled_->regex, text, sizeof text);
    throw std::invalid_argument(text);
  }
  compiled_->valid = true;
}

bool LineRegex::search(std::string_view line) const {
  // regexec wants a NUL-terminated string; REG_STARTEND avoids the copy.
  regmatch_t range{0, static_cast<regoff_t>(line.size())};
  return ::regexec(&compiled_->regex, line.data(), 1, &range, REG_STARTEND) == 0;
}

}  // namespace ln::manager
