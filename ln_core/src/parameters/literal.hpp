// The small part of Python's literal syntax that LN's parameter services
// speak: query_dict answers are the text of a Python dict whose values are
// dict(...) calls holding numbers, booleans, strings and array(...) calls;
// override values are numbers, booleans or (nested) lists, possibly inside
// array(...). This parses that text into a tree, and writes Python string
// literals. It never evaluates anything.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ln::paramcore {

struct Literal {
  enum class Kind {
    Number,  // text: the literal as written, sign included ("-1.5e3", "0x10")
    Name,    // text: an identifier ("True", "nan", "inf"; "-inf" after a minus)
    String,  // text: the decoded contents
    List,    // items: [a, b] (elements may also be separated by blanks only)
    Tuple,   // items: (a, b) or (a,)
    Dict,    // items: key, value, key, value, ...
    Call,    // text: the callee ("array", "np.float64"); items: positional
             // arguments; keywords: name=value arguments
  };
  Kind kind = Kind::Number;
  std::string text;
  std::vector<Literal> items;
  std::vector<std::pair<std::string, Literal>> keywords;

  /// The keyword argument `name` of a Call, or nullptr.
  const Literal* keyword(std::string_view name) const;
};

/// Parses `text` (surrounding blanks allowed). On failure returns false and
/// sets `error` to what is wrong and where.
bool parse_literal(std::string_view text, Literal& out, std::string& error);

/// `text` as a Python string literal in single quotes, with \\, \', \n, \r,
/// \t and \xNN escapes (other bytes, UTF-8 included, as they are).
std::string python_string_literal(std::string_view text);

}  // namespace ln::paramcore
