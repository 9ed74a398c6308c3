// A minimal JSON value for writing mapping files: objects keep their
// insertion order so the output is deterministic and readable.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace msg_mapping {

class Json {
 public:
  enum class Kind { Null, Bool, Number, String, Array, Object };

  Json() = default;
  Json(bool b) : kind_(Kind::Bool), text_(b ? "true" : "false") {}  // NOLINT: implicit by design
  Json(int v) : kind_(Kind::Number), text_(std::to_string(v)) {}
  Json(std::uint64_t v) : kind_(Kind::Number), text_(std::to_string(v)) {}
  Json(std::uint32_t v) : kind_(Kind::Number), text_(std::to_string(v)) {}
  Json(std::string s) : kind_(Kind::String), text_(std::move(s)) {}
  Json(const char* s) : kind_(Kind::String), text_(s) {}

  static Json array() { return Json(Kind::Array); }
  static Json object() { return Json(Kind::Object); }

  Json& set(std::string key, Json value) {
    members_.emplace_back(std::move(key), std::move(value));
    return *this;
  }
  Json& push(Json value) {
    members_.emplace_back(std::string(), std::move(value));
    return *this;
  }
  bool empty() const { return members_.empty(); }

  std::string dump(int indent = 2) const {
    std::string out;
    write(out, indent, 0);
    out += "\n";
    return out;
  }

 private:
  explicit Json(Kind kind) : kind_(kind) {}

  static void quote(std::string& out, const std::string& s) {
    static const char hex[] = "0123456789abcdef";
    out += '"';
    for (unsigned char c : s) {
      switch (c) {
        case '"':
          out += "\\\"";
          break;
        case '\\':
          out += "\\\\";
          break;
        case '\n':
          out += "\\n";
          break;
        case '\t':
          out += "\\t";
          break;
        case '\r':
          out += "\\r";
          break;
        default:
          if (c < 0x20) {
            out += "\\u00";
            out += hex[c >> 4];
            out += hex[c & 15];
          } else {
            out += static_cast<char>(c);
          }
      }
    }
    out += '"';
  }

  void write(std::string& out, int indent, int depth) const {
    switch (kind_) {
      case Kind::Null:
        out += "null";
        return;
      case Kind::Bool:
      case Kind::Number:
        out += text_;
        return;
      case Kind::String:
        quote(out, text_);
        return;
      case Kind::Array:
      case Kind::Object:
        break;
    }
    const bool object = kind_ == Kind::Object;
    if (members_.empty()) {
      out += object ? "{}" : "[]";
      return;
    }
    // Arrays of scalars stay on one line.
    bool flat = !object;
    for (const auto& m : members_)
      if (m.second.kind_ == Kind::Array || m.second.kind_ == Kind::Object) flat = false;
    out += object ? '{' : '[';
    const std::string pad(static_cast<std::size_t>(indent * (depth + 1)), ' ');
    for (std::size_t i = 0; i < members_.size(); ++i) {
      if (i) out += flat ? ", " : ",";
      if (!flat) out += "\n" + pad;
      if (object) {
        quote(out, members_[i].first);
        out += ": ";
      }
      members_[i].second.write(out, indent, depth + 1);
    }
    if (!flat) out += "\n" + std::string(static_cast<std::size_t>(indent * depth), ' ');
    out += object ? '}' : ']';
  }

  Kind kind_ = Kind::Null;
  std::string text_;
  std::vector<std::pair<std::string, Json>> members_;
};

}  // namespace msg_mapping
