#include "parameters/literal.hpp"

#include <cctype>
#include <cstdio>

namespace ln::paramcore {

const Literal* Literal::keyword(std::string_view name) const {
  for (const auto& [key, value] : keywords)
    if (key == name) return &value;
  return nullptr;
}

namespace {

// Deeper nesting than any parameter value needs; keeps hostile text from
// exhausting the stack.
constexpr int kMaxDepth = 32;

bool is_identifier_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
bool is_identifier_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

class Parser {
 public:
  explicit Parser(std::string_view text) : text_(text) {}

  bool parse(Literal& out, std::string& error) {
    if (!value(out, 0)) {
      error = error_;
      return false;
    }
    skip_blanks();
    if (pos_ != text_.size()) {
      error = "unexpected '" + std::string(1, text_[pos_]) + "' at offset " + std::to_string(pos_);
      return false;
    }
    return true;
  }

 private:
  bool fail(const std::string& what) {
    if (error_.empty()) error_ = what + " at offset " + std::to_string(pos_);
    return false;
  }
  void skip_blanks() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  bool at(char c) {
    skip_blanks();
    return pos_ < text_.size() && text_[pos_] == c;
  }
  bool take(char c) {
    if (!at(c)) return false;
    ++pos_;
    return true;
  }

  bool value(Literal& out, int depth) {
    if (depth > kMaxDepth) return fail("nesting too deep");
    skip_blanks();
    if (pos_ >= text_.size()) return fail("value expected");
    const char c = text_[pos_];
    if (c == '-' || c == '+') {
      ++pos_;
      if (!value(out, depth + 1)) return false;
      if (out.kind != Literal::Kind::Number && out.kind != Literal::Kind::Name) return fail("sign before a non-number");
      if (c == '-') out.text = (!out.text.empty() && out.text[0] == '-') ? out.text.substr(1) : "-" + out.text;
      return true;
    }
    if (c == '[') return sequence(out, Literal::Kind::List, ']', depth);
    if (c == '(') return sequence(out, Literal::Kind::Tuple, ')', depth);
    if (c == '{') return dict(out, depth);
    if (c == '\'' || c == '"') return string(out);
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') return number(out);
    if (is_identifier_start(c)) return name_or_call(out, depth);
    return fail("unexpected '" + std::string(1, c) + "'");
  }

  bool number(Literal& out) {
    const std::size_t start = pos_;
    while (pos_ < text_.size() &&
           (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '.' ||
            ((text_[pos_] == '-' || text_[pos_] == '+') && (text_[pos_ - 1] == 'e' || text_[pos_ - 1] == 'E'))))
      ++pos_;
    out = Literal{};
    out.kind = Literal::Kind::Number;
    out.text = std::string(text_.substr(start, pos_ - start));
    return true;  // whether it is a valid number is decided where it is used
  }

  bool name_or_call(Literal& out, int depth) {
    const std::size_t start = pos_;
    while (pos_ < text_.size() && (is_identifier_char(text_[pos_]) || (text_[pos_] == '.' && pos_ + 1 < text_.size() &&
                                                                       is_identifier_start(text_[pos_ + 1]))))
      ++pos_;
    std::string name(text_.substr(start, pos_ - start));
    if (!at('(')) {
      out = Literal{};
      out.kind = Literal::Kind::Name;
      out.text = std::move(name);
      return true;
    }
    ++pos_;
    Literal call;
    call.kind = Literal::Kind::Call;
    call.text = std::move(name);
    while (!take(')')) {
      if (!call.items.empty() || !call.keywords.empty()) {
        if (!take(',')) return fail("',' or ')' expected");
        if (take(')')) break;
      }
      skip_blanks();
      const std::size_t mark = pos_;
      if (pos_ < text_.size() && is_identifier_start(text_[pos_])) {
        while (pos_ < text_.size() && is_identifier_char(text_[pos_])) ++pos_;
        std::string key(text_.substr(mark, pos_ - mark));
        if (take('=')) {
          Literal argument;
          if (!value(argument, depth + 1)) return false;
          call.keywords.emplace_back(std::move(key), std::move(argument));
          continue;
        }
        pos_ = mark;
      }
      if (!call.keywords.empty()) return fail("positional argument after keyword argument");
      Literal argument;
      if (!value(argument, depth + 1)) return false;
      call.items.push_back(std::move(argument));
    }
    out = std::move(call);
    return true;
  }

  // [a, b] also accepts blanks as separators ("[1 2 3]", numpy's str());
  // (a, b) needs commas; (a) is just a.
  bool sequence(Literal& out, Literal::Kind kind, char close, int depth) {
    ++pos_;
    Literal seq;
    seq.kind = kind;
    bool trailing_comma = false;
    while (!take(close)) {
      if (pos_ >= text_.size()) return fail(std::string("missing '") + close + "'");
      if (!seq.items.empty() && !trailing_comma && kind == Literal::Kind::Tuple) return fail("',' expected");
      Literal item;
      if (!value(item, depth + 1)) return false;
      seq.items.push_back(std::move(item));
      trailing_comma = take(',');
      if (!trailing_comma && !at(close) && kind == Literal::Kind::Tuple) return fail("',' or ')' expected");
    }
    if (kind == Literal::Kind::Tuple && seq.items.size() == 1 && !trailing_comma) {
      out = std::move(seq.items.front());
      return true;
    }
    out = std::move(seq);
    return true;
  }

  bool dict(Literal& out, int depth) {
    ++pos_;
    Literal d;
    d.kind = Literal::Kind::Dict;
    while (!take('}')) {
      if (!d.items.empty() && !take(',')) return fail("',' or '}' expected");
      if (take('}')) break;
      Literal key, item;
      if (!value(key, depth + 1)) return false;
      if (!take(':')) return fail("':' expected");
      if (!value(item, depth + 1)) return false;
      d.items.push_back(std::move(key));
      d.items.push_back(std::move(item));
    }
    out = std::move(d);
    return true;
  }

  bool string(Literal& out) {
    const char quote = text_[pos_++];
    std::string decoded;
    while (true) {
      if (pos_ >= text_.size()) return fail("unterminated string");
      const char c = text_[pos_++];
      if (c == quote) break;
      if (c != '\\') {
        decoded.push_back(c);
        continue;
      }
      if (pos_ >= text_.size()) return fail("unterminated string");
      const char e = text_[pos_++];
      switch (e) {
        case 'n':
          decoded.push_back('\n');
          break;
        case 'r':
          decoded.push_back('\r');
          break;
        case 't':
          decoded.push_back('\t');
          break;
        case '0':
          decoded.push_back('\0');
          break;
        case '\\':
        case '\'':
        case '"':
          decoded.push_back(e);
          break;
        case 'x': {
          if (pos_ + 2 > text_.size() || !std::isxdigit(static_cast<unsigned char>(text_[pos_])) ||
              !std::isxdigit(static_cast<unsigned char>(text_[pos_ + 1])))
            return fail("invalid \\x escape");
          decoded.push_back(static_cast<char>(std::stoi(std::string(text_.substr(pos_, 2)), nullptr, 16)));
          pos_ += 2;
          break;
        }
        default:  // Python keeps unknown escapes as written
          decoded.push_back('\\');
          decoded.push_back(e);
      }
    }
    out = Literal{};
    out.kind = Literal::Kind::String;
    out.text = std::move(decoded);
    return true;
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  std::string error_;
};

}  // namespace

bool parse_literal(std::string_view text, Literal& out, std::string& error) {
  Parser parser(text);
  return parser.parse(out, error);
}

std::string python_string_literal(std::string_view text) {
  std::string out = "'";
  for (const char c : text) {
    switch (c) {
      case '\\':
        out += "\\\\";
        break;
      case '\'':
        out += "\\'";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
          char escaped[5];
          std::snprintf(escaped, sizeof escaped, "\\x%02x", static_cast<unsigned char>(c));
          out += escaped;
        } else {
          out.push_back(c);
        }
    }
  }
  out += "'";
  return out;
}

}  // namespace ln::paramcore
