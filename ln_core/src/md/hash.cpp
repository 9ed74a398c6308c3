#include "md/hash.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include "md/sha256.hpp"
#include "md/text.hpp"

namespace ln::md {
namespace {

// Python 3 repr() of a str. Field and type names are identifiers, so in
// practice only the quoting matters; escapes keep arbitrary input exact.
std::string python_repr(const std::string& s) {
  const bool has_single = s.find('\'') != std::string::npos;
  const bool has_double = s.find('"') != std::string::npos;
  const char quote = (has_single && !has_double) ? '"' : '\'';
  std::string out(1, quote);
  for (std::size_t i = 0; i < s.size();) {
    std::size_t length;
    const char32_t code = text::decode_utf8(s, i, length);
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (code >= 0x80) {
      // Python shows non-printable code points escaped; in names only
      // Unicode blanks (kept before '[') and C1 controls can occur.
      if (text::is_unicode_space(code) || code < 0xA0 || code == 0xAD) {
        char buffer[16];
        if (code < 0x100)
          std::snprintf(buffer, sizeof buffer, "\\x%02x", static_cast<unsigned>(code));
        else if (code < 0x10000)
          std::snprintf(buffer, sizeof buffer, "\\u%04x", static_cast<unsigned>(code));
        else
          std::snprintf(buffer, sizeof buffer, "\\U%08x", static_cast<unsigned>(code));
        out += buffer;
      } else {
        out.append(s, i, length);
      }
      i += length;
      continue;
    }
    ++i;
    if (c == '\\' || c == static_cast<unsigned char>(quote)) {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\x%02x", c);
      out += buffer;
    } else {
      out += static_cast<char>(c);
    }
  }
  out += quote;
  return out;
}

std::string fields_repr(const std::vector<Field>& fields) {
  std::string out = "[";
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const Field& f = fields[i];
    if (i) out += ", ";
    out += "[" + python_repr(f.type_spelling + (f.dynamic ? "*" : "")) + ", " + python_repr(f.hash_name) + ", " +
           std::to_string(f.count) + "]";
  }
  return out + "]";
}

// The field lists of the imported types by local define name, in the order
// LN 2.9 first meets them (its defines dict keeps that order).
class DefineFields {
 public:
  void set(const std::string& local_name, const std::vector<Field>* fields) {
    const auto [it, inserted] = index_.emplace(local_name, entries_.size());
    if (inserted)
      entries_.emplace_back(local_name, fields);
    else
      entries_[it->second].second = fields;
  }
  const std::vector<std::pair<std::string, const std::vector<Field>*>>& in_order() const { return entries_; }
  std::map<std::string, const std::vector<Field>*> sorted() const { return {entries_.begin(), entries_.end()}; }

 private:
  std::map<std::string, std::size_t> index_;
  std::vector<std::pair<std::string, const std::vector<Field>*>> entries_;
};

// LN collects the field lists of every imported type, keyed by the *local*
// define name, depth first, in the order the defines are written (repeats
// included); a later define of the same local name, nested or repeated,
// replaces an earlier one. Definitions already on the stack are not entered
// again (LN 2.9 handles only direct self-recursion; longer cycles are our
// own). Imports shared by several importers are entered once per path, as
// LN does: `budget` bounds that walk (a few small files that import each
// other twice per level would otherwise take forever).
constexpr std::size_t max_import_visits = 100'000;

void collect_defines(const Definition& definition, DefineFields& into, std::vector<const Definition*>& stack,
                     std::size_t& budget, const Definition& root) {
  for (const std::size_t index : definition.define_order) {
    const Define& define = definition.defines[index];
    const Definition* sub = define.definition;
    if (budget-- == 0)
      throw Error(root.path, 0,
                  "the definition imports more than " + std::to_string(max_import_visits) +
                      " types when its imports are followed (imports shared too often)");
    into.set(define.local_name, &sub->fields);
    if (std::find(stack.begin(), stack.end(), sub) != stack.end()) continue;
    stack.push_back(sub);
    collect_defines(*sub, into, stack, budget, root);
    stack.pop_back();
  }
}

DefineFields imported_fields(const Definition& definition) {
  DefineFields defines;
  std::vector<const Definition*> stack{&definition};
  std::size_t budget = max_import_visits;
  collect_defines(definition, defines, stack, budget, definition);
  return defines;
}

}  // namespace

std::string compute_definition_hash(const Definition& definition) {
  std::string sorted_defines = "[";
  bool first = true;
  for (const auto& [local_name, fields] : imported_fields(definition).sorted()) {
    if (!first) sorted_defines += ", ";
    first = false;
    sorted_defines += "(" + python_repr(local_name) + ", " + fields_repr(*fields) + ")";
  }
  sorted_defines += "]";

  const std::string text = "(" + fields_repr(definition.fields) + ", " + fields_repr(definition.response_fields) +
                           ", " + sorted_defines + ")";
  return sha256_hex(text);
}

std::string python_dict_text(const Definition& definition) {
  const DefineFields imported = imported_fields(definition);
  std::string defines = "{";
  for (const auto& [local_name, fields] : imported.in_order()) {
    if (defines.size() > 1) defines += ", ";
    defines += python_repr(local_name) + ": " + fields_repr(*fields);
  }
  defines += "}";
  return "{'fields': " + fields_repr(definition.fields) +
         ", 'resp_fields': " + fields_repr(definition.response_fields) + ", 'defines': " + defines + "}";
}

}  // namespace ln::md
