#include <algorithm>
#include <array>

#include "ln/md/message_definition.hpp"
#include "md/text.hpp"

namespace ln::md {

namespace {
std::string located(const std::string& file, int line, const std::string& message) {
  if (file.empty()) return message;
  if (line <= 0) return file + ": " + message;
  return file + ":" + std::to_string(line) + ": " + message;
}
}  // namespace

Error::Error(std::string file, int line, const std::string& message)
    : std::runtime_error(located(file, line, message)), file_(std::move(file)), line_(line), message_(message) {}

bool Definition::is_dynamic() const {
  auto dynamic = [](const Field& f) { return f.dynamic; };
  return std::any_of(fields.begin(), fields.end(), dynamic) ||
         std::any_of(response_fields.begin(), response_fields.end(), dynamic);
}

const Define* Definition::find_define(std::string_view local_name) const {
  for (const auto& d : defines)
    if (d.local_name == local_name) return &d;
  return nullptr;
}

bool is_valid_definition_name(std::string_view name) {
  if (name.empty() || name.front() == '/' || name.back() == '/') return false;
  std::size_t start = 0;
  while (start <= name.size()) {
    const auto end = std::min(name.find('/', start), name.size());
    const auto component = name.substr(start, end - start);
    if (component.empty() || component == "." || component == "..") return false;
    if (component.find('\0') != std::string_view::npos) return false;
    start = end + 1;
  }
  return true;
}

std::string identifier_from_name(std::string_view name) {
  std::string id;
  bool in_separator_run = false;
  for (char c : name) {
    if (c == ' ' || c == '/' || c == '.') {
      if (!in_separator_run) id += '_';
      in_separator_run = true;
    } else {
      id += c;
      in_separator_run = false;
    }
  }
  return std::string(text::strip(id, "_"));
}

bool is_reserved_word(std::string_view name) {
  // clang-format off
  static constexpr std::array<std::string_view, 97> words{
      "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor",
      "bool", "break", "case", "catch", "char", "char8_t", "char16_t", "char32_t",
      "class", "compl", "concept", "const", "consteval", "constexpr", "constinit", "const_cast",
      "continue", "co_await", "co_return", "co_yield", "decltype", "default", "delete", "do",
      "double", "dynamic_cast", "else", "enum", "explicit", "export", "extern", "false",
      "float", "for", "friend", "goto", "if", "inline", "int", "long",
      "mutable", "namespace", "new", "noexcept", "not", "not_eq", "nullptr", "operator",
      "or", "or_eq", "private", "protected", "public", "register", "reinterpret_cast", "requires",
      "restrict", "return", "short", "signed", "sizeof", "static", "static_assert", "static_cast",
      "struct", "switch", "template", "this", "thread_local", "throw", "true", "try",
      "typedef", "typeid", "typename", "union", "unsigned", "using", "virtual", "void",
      "volatile", "wchar_t", "while", "xor", "xor_eq", "_Bool", "_Complex", "_Generic",
      "_Noreturn"};
  // clang-format on
  return std::find(words.begin(), words.end(), name) != words.end();
}

namespace text {

bool is_identifier(std::string_view s) {
  if (s.empty()) return false;
  auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
  auto digit = [](char c) { return c >= '0' && c <= '9'; };
  if (!alpha(s.front())) return false;
  return std::all_of(s.begin(), s.end(), [&](char c) { return alpha(c) || digit(c); });
}

char32_t decode_utf8(std::string_view s, std::size_t i, std::size_t& length) {
  const auto c = static_cast<unsigned char>(s[i]);
  std::size_t extra = c < 0x80 ? 0 : (c & 0xE0) == 0xC0 ? 1 : (c & 0xF0) == 0xE0 ? 2 : (c & 0xF8) == 0xF0 ? 3 : 0;
  if (c >= 0x80 && extra == 0) {
    length = 1;
    return c;
  }
  if (extra > 0 && i + extra >= s.size()) {
    length = 1;
    return c;
  }  // truncated
  char32_t code = extra == 0 ? c : extra == 1 ? (c & 0x1F) : extra == 2 ? (c & 0x0F) : (c & 0x07);
  for (std::size_t k = 1; k <= extra; ++k) {
    const auto cc = static_cast<unsigned char>(s[i + k]);
    if ((cc & 0xC0) != 0x80) {
      length = 1;
      return c;
    }
    code = (code << 6) | (cc & 0x3F);
  }
  length = extra + 1;
  return code;
}

bool is_unicode_space(char32_t c) {
  return (c >= 0x09 && c <= 0x0D) || (c >= 0x1C && c <= 0x20) || c == 0x85 || c == 0xA0 || c == 0x1680 ||
         (c >= 0x2000 && c <= 0x200A) || c == 0x2028 || c == 0x2029 || c == 0x202F || c == 0x205F || c == 0x3000;
}

std::string_view strip_unicode(std::string_view s) {
  // Leading: decode forwards.
  std::size_t begin = 0;
  while (begin < s.size()) {
    std::size_t length;
    if (!is_unicode_space(decode_utf8(s, begin, length))) break;
    begin += length;
  }
  // Trailing: find the start of the last code point, then test it.
  std::size_t end = s.size();
  while (end > begin) {
    std::size_t start = end - 1;
    while (start > begin && (static_cast<unsigned char>(s[start]) & 0xC0) == 0x80 && end - start < 4) --start;
    std::size_t length;
    const char32_t c = decode_utf8(s, start, length);
    if (start + length != end || !is_unicode_space(c)) break;
    end = start;
  }
  return s.substr(begin, end - begin);
}

bool is_valid_utf8(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size()) {
    const auto c = static_cast<unsigned char>(s[i]);
    std::size_t extra;
    std::uint32_t code;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xE0) == 0xC0) {
      extra = 1;
      code = c & 0x1F;
    } else if ((c & 0xF0) == 0xE0) {
      extra = 2;
      code = c & 0x0F;
    } else if ((c & 0xF8) == 0xF0) {
      extra = 3;
      code = c & 0x07;
    } else
      return false;
    if (i + extra >= s.size()) return false;  // truncated sequence
    for (std::size_t k = 1; k <= extra; ++k) {
      const auto cc = static_cast<unsigned char>(s[i + k]);
      if ((cc & 0xC0) != 0x80) return false;
      code = (code << 6) | (cc & 0x3F);
    }
    static constexpr std::uint32_t smallest[] = {0, 0x80, 0x800, 0x10000};
    if (code < smallest[extra] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return false;
    i += extra + 1;
  }
  return true;
}

std::string_view dirname(std::string_view path) {
  const auto slash = path.rfind('/');
  if (slash == std::string_view::npos) return {};
  if (slash == 0) return path.substr(0, 1);
  return path.substr(0, slash);
}

std::string join_path(std::string_view base, std::string_view tail) {
  if (base.empty() || (!tail.empty() && tail.front() == '/')) return std::string(tail);
  std::string joined(base);
  if (joined.back() != '/') joined += '/';
  joined += tail;
  return joined;
}

}  // namespace text
}  // namespace ln::md
