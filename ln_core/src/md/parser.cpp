#include "md/parser.hpp"

#include <algorithm>
#include <list>
#include <map>
#include <stdexcept>
#include <unordered_map>

#include "md/count_expression.hpp"
#include "md/text.hpp"

namespace ln::md {
namespace {

constexpr std::int64_t max_array_count = 0x7fffffff;
// Types are looked up among the defines by a scan (a handful in practice);
// the bound keeps a definition from any client cheap to read.
constexpr std::size_t max_defines = 256;

enum class Section { First, Second };  // request/connect, response/call

class DefinitionParser {
 public:
  DefinitionParser(Definition& definition, DefineResolver& resolver) : def_(definition), resolver_(resolver) {}

  void parse(std::string_view text) {
    int line_number = 0;
    bool first_significant = true;
    while (!text.empty()) {
      const auto newline = std::min(text.find('\n'), text.size());
      std::string_view raw = text.substr(0, newline);
      text.remove_prefix(std::min(newline + 1, text.size()));
      ++line_number;
      line_ = line_number;
      if (!text::is_valid_utf8(raw)) fail("the line is not valid UTF-8");

      // LN strips with Python's str.strip(): Unicode blanks included.
      std::string_view line = text::strip_unicode(raw);
      if (line.empty() || line.front() == '#') continue;
      line = text::strip_unicode(line.substr(0, line.find('#')));

      if (first_significant) {
        first_significant = false;
        if (line == "service") {
          def_.kind = Kind::Service;
          continue;
        }
        if (line == "event") {
          def_.kind = Kind::Event;
          continue;
        }
      }
      if (section_marker(line)) continue;
      parse_declaration(line);
    }
    for (auto section : {Section::First, Section::Second}) place_length_fields(section);
  }

 private:
  [[noreturn]] void fail(const std::string& message) const { throw Error(def_.path, line_, message); }

  bool section_marker(std::string_view line) {
    const bool service = def_.kind == Kind::Service, event = def_.kind == Kind::Event;
    if ((service && line == "request") || (event && line == "connect"))
      section_ = Section::First;
    else if ((service && line == "response") || (event && line == "call"))
      section_ = Section::Second;
    else
      return false;
    return true;
  }

  std::vector<Field>& fields(Section s) { return s == Section::First ? def_.fields : def_.response_fields; }

  void parse_declaration(std::string_view line) {
    const auto blank = line.find_first_of(" \t");
    if (blank == std::string_view::npos)
      fail("expected 'TYPE NAME', 'TYPE NAME[COUNT]' or 'define NAME as \"md/name\"', got '" + std::string(line) + "'");
    const std::string_view first_word = line.substr(0, blank);
    const std::string_view rest = text::strip_unicode(line.substr(blank));
    if (first_word == "define")
      parse_define(rest);
    else
      parse_field(first_word, rest);
  }

  void parse_define(std::string_view rest) {
    const auto as = rest.find(" as ");
    if (as == std::string_view::npos) fail("expected 'define LOCAL_TYPE as \"md/name\"'");
    const std::string local(text::strip_unicode(rest.substr(0, as)));
    const std::string_view quoted = text::strip(rest.substr(as + 4));
    if (quoted.size() < 2 || quoted.front() != '"' || quoted.back() != '"')
      fail("the definition name in a define must be in double quotes: define " + local + " as \"md/name\"");
    const std::string target(quoted.substr(1, quoted.size() - 2));

    if (primitive_from_spelling(local)) fail("'" + local + "' is a built-in type and cannot be redefined");
    if (!text::is_identifier(local) || is_reserved_word(local))
      fail("'" + local + "' is not a usable type name (a C identifier that is not a keyword)");
    if (!is_valid_definition_name(target))
      fail("'" + target + "' is not a valid message-definition name (relative, '/'-separated, no '..')");

    if (def_.defines.size() >= max_defines)
      fail("more than " + std::to_string(max_defines) + " 'define's in one definition");
    Define define;
    define.local_name = local;
    define.line = line_;
    define.definition = &resolver_.resolve_define(def_, target, line_, define.absolute_name);
    if (define.definition->kind != Kind::Plain)
      fail("'" + target + "' is a service or event definition; only plain definitions can be used as types");
    // All sections share one set of local type names. Repeating a define
    // (a service often repeats it in its response section) changes nothing;
    // LN 2.9 would apply a *different* target to every field of that type,
    // also to those declared before, and mislabel the generated struct.
    if (const Define* earlier = def_.find_define(local)) {
      if (earlier->definition != define.definition)
        fail("type '" + local + "' is already defined in line " + std::to_string(earlier->line) + " as '" +
             earlier->absolute_name + "'; a second define must name the same definition");
      def_.define_order.push_back(static_cast<std::size_t>(earlier - def_.defines.data()));
      return;
    }
    def_.define_order.push_back(def_.defines.size());
    def_.defines.push_back(std::move(define));
  }

  void parse_field(std::string_view type_word, std::string_view rest) {
    Field field;
    field.line = line_;
    if (text::ends_with(type_word, "*")) {
      field.dynamic = true;
      type_word.remove_suffix(1);
    }
    field.type_spelling = std::string(type_word);
    field.primitive = primitive_from_spelling(type_word);
    if (!field.primitive) {
      const Define* define = def_.find_define(type_word);
      if (!define) fail("unknown type '" + std::string(type_word) + "'" + unknown_type_hint(type_word));
      field.sub = define->definition;
    }

    std::string_view name = rest;
    const auto bracket = rest.find('[');
    if (bracket != std::string_view::npos) {
      if (field.dynamic) fail("arrays of dynamic fields ('" + std::string(type_word) + "* name[N]') are not supported");
      name = rest.substr(0, bracket);
      field.count = array_count(rest.substr(bracket));
    }
    field.hash_name = std::string(name);  // LN hashes the name with blanks before '['
    field.name = std::string(text::strip_unicode(name));
    if (!text::is_identifier(field.name) || is_reserved_word(field.name))
      fail("'" + field.name + "' is not a valid field name (a C identifier that is not a keyword)");

    // One lookup per field: definitions can come from any client, and a
    // scan of the list per field made 100 000 fields take a minute.
    const auto [same, added] = field_lines_[static_cast<int>(section_)].emplace(field.name, line_);
    if (!added) fail("field '" + field.name + "' is already defined in line " + std::to_string(same->second));
    if (field.dynamic) dynamic_names_[static_cast<int>(section_)].push_back(field.name);
    fields(section_).push_back(std::move(field));
  }

  std::uint32_t array_count(std::string_view brackets) {
    if (brackets.back() != ']') fail("array count '" + std::string(brackets) + "' lacks its closing ']'");
    const std::string_view expression = text::strip(brackets.substr(1, brackets.size() - 2));
    if (expression.find("][") != std::string_view::npos)
      fail("multi-dimensional arrays are not supported; flatten them to one dimension (e.g. [3*4])");
    std::int64_t count;
    try {
      count = evaluate_count_expression(expression);
    } catch (const std::invalid_argument& e) {
      fail("invalid array count '" + std::string(expression) + "': " + e.what());
    }
    if (count < 1 || count > max_array_count)
      fail("array count '" + std::string(expression) + "' is " + std::to_string(count) + "; it must be between 1 and " +
           std::to_string(max_array_count));
    return static_cast<std::uint32_t>(count);
  }

  std::string unknown_type_hint(std::string_view type) const {
    if (text::ends_with(type, "*")) return " (only one '*' is allowed)";
    return "";
  }

  // Each dynamic field X carries its length in a field X_len placed right
  // before X: inserted when the author did not declare it, moved when it was
  // declared elsewhere. The move reproduces LN 2.9 exactly, including its
  // quirk: an X_len declared more than one field before X ends up right
  // *after* X (remove, then insert at X's old index). Done on a linked list
  // with the fields found by name, so it takes linear time. X and X_len are
  // never moved by the other fields' moves (X is dynamic, X_len must not be),
  // so their order in the list is still their declaration order.
  void place_length_fields(Section section) {
    const auto& dynamic_names = dynamic_names_[static_cast<int>(section)];
    if (dynamic_names.empty()) return;
    std::vector<Field>& declared_fields = fields(section);
    std::list<Field> list(std::make_move_iterator(declared_fields.begin()),
                          std::make_move_iterator(declared_fields.end()));
    std::unordered_map<std::string_view, std::list<Field>::iterator> by_name;
    std::unordered_map<std::string_view, std::size_t> declared_at;
    std::size_t index = 0;
    for (auto it = list.begin(); it != list.end(); ++it, ++index) {
      by_name.emplace(it->name, it);
      declared_at.emplace(it->name, index);
    }
    for (const auto& dynamic_name : dynamic_names) {
      const auto dynamic = by_name.at(dynamic_name);
      const std::string length_name = dynamic_name + "_len";
      const auto found = by_name.find(length_name);
      if (found == by_name.end()) {
        Field length;
        length.name = length.hash_name = length_name;
        length.type_spelling = "uint32_t";
        length.primitive = Primitive::UInt32;
        list.insert(dynamic, std::move(length));
        continue;
      }
      const auto declared = found->second;
      if (!declared->primitive || !is_integer(*declared->primitive) || declared->dynamic || declared->count != 1) {
        line_ = declared->line;
        fail("'" + length_name + "' holds the element count of dynamic field '" + dynamic_name +
             "' and must be an integer scalar such as uint32_t");
      }
      if (std::next(declared) == dynamic) continue;
      const bool declared_before = declared_at.at(length_name) < declared_at.at(dynamic_name);
      list.splice(declared_before ? std::next(dynamic) : dynamic, list, declared);
    }
    declared_fields.assign(std::make_move_iterator(list.begin()), std::make_move_iterator(list.end()));
  }

  Definition& def_;
  DefineResolver& resolver_;
  Section section_ = Section::First;
  int line_ = 0;
  std::vector<std::string> dynamic_names_[2];
  std::unordered_map<std::string, int> field_lines_[2];  // field name -> its line, per section
};

}  // namespace

void parse_definition(Definition& definition, std::string_view text, DefineResolver& resolver) {
  DefinitionParser(definition, resolver).parse(text);
}

}  // namespace ln::md
