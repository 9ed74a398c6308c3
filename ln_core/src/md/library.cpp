#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "ln/md/message_definition.hpp"
#include "md/hash.hpp"
#include "md/parser.hpp"
#include "md/text.hpp"

namespace ln::md {
namespace {

bool is_regular_file(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, 0, std::string("cannot read the file: ") + std::strerror(errno));
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) throw Error(path, 0, std::string("cannot read the file: ") + std::strerror(errno));
  return content.str();
}

// One line, so that every error is one line.
std::string list_dirs(const SearchPath& path) {
  std::string out;
  for (const auto& d : path.dirs()) out += (out.empty() ? " " : ", ") + d;
  return out.empty() ? " (no existing directories)" : out;
}

// Sizes above 4 GiB cannot be described by LN's 32-bit message sizes, and
// checking here keeps every later size computation free of overflow.
constexpr std::size_t max_definition_size = std::numeric_limits<std::uint32_t>::max();
// Signatures, the hash and layouts write sub-types out in full: a few
// small files that import each other twice per level would otherwise
// describe billions of fields.
constexpr std::size_t max_expanded_fields = 1'000'000;

}  // namespace

struct Library::Loader final : DefineResolver {
  explicit Loader(Library& library) : lib(library) {}

  // Loads the definition `name` stored in `path`, or returns the one already
  // known (possibly still being parsed: that is how recursion resolves).
  const Definition& load_file(const std::string& name, const std::string& path) {
    if (auto it = lib.loaded_.find(name); it != lib.loaded_.end()) return *it->second;
    return parse_new(name, path, read_file(path));
  }

  const Definition& parse_new(const std::string& name, const std::string& path, const std::string& text) {
    auto owned = std::make_unique<Definition>();
    Definition& def = *owned;
    def.name = name;
    def.path = path;
    lib.loaded_.emplace(name, std::move(owned));
    created.push_back(&def);
    parse_definition(def, text, *this);
    return def;
  }

  const Definition& resolve_define(const Definition& importer, const std::string& quoted, int line,
                                   std::string& absolute_name) override {
    // In-memory sources come first, with the same "next to the importer
    // first" rule as files.
    for (const std::string& candidate : {text::join_path(text::dirname(importer.name), quoted), quoted}) {
      if (auto source = lib.sources_.find(candidate); source != lib.sources_.end()) {
        absolute_name = candidate;
        if (auto it = lib.loaded_.find(candidate); it != lib.loaded_.end()) return *it->second;
        return parse_new(candidate, "<" + candidate + ">", source->second);
      }
    }
    // First next to the importing file (so "value" inside ln/parameters/query
    // means ln/parameters/value), then on the search path.
    if (is_regular_file(importer.path)) {
      const std::string sibling = text::join_path(text::dirname(importer.path), quoted);
      if (is_regular_file(sibling)) {
        absolute_name = text::join_path(text::dirname(importer.name), quoted);
        return load_file(absolute_name, sibling);
      }
    }
    auto found = lib.search_path_.find(quoted);
    if (!found) {
      lib.search_path_.rescan();
      found = lib.search_path_.find(quoted);
    }
    if (!found)
      throw Error(importer.path, line,
                  "define refers to '" + quoted +
                      "', which is neither next to this file nor in:" + list_dirs(lib.search_path_));
    absolute_name = quoted;
    return load_file(absolute_name, *found);
  }

  // Runs once the outermost load has parsed everything it imports. Every
  // walk here visits each definition once (definitions may come from any
  // client of a manager: imports that share sub-types must not cost
  // exponential time).
  void finish() {
    std::map<const Definition*, Visit> by_value, all;
    for (Definition* def : created) check_no_cycle(*def, by_value, true);
    for (Definition* def : created) check_no_cycle(*def, all, false);
    // Imports are created after their importers: check them first, so that
    // sizes of already-checked sub-types never overflow.
    for (auto it = created.rbegin(); it != created.rend(); ++it) check_sizes(**it);
    for (Definition* def : created) def->hash = compute_definition_hash(*def);
  }

  void forget_created() {
    for (Definition* def : created) lib.loaded_.erase(def->name);
    created.clear();
  }

  enum class Visit { in_progress, done };

  // Depth first from `current`; a sub-type met again while it is still in
  // progress closes a cycle. By value (`by_value`): a type may contain
  // itself only through a pointer, else it would be infinitely large. All
  // fields: recursion must be direct (a type pointing to itself), because
  // signatures write a recursive reference as "[]", meaning the innermost
  // enclosing type, so a longer cycle (A holds B*, B holds A*) has no
  // unambiguous signature. LN 2.9 cannot load such definitions either.
  void check_no_cycle(const Definition& current, std::map<const Definition*, Visit>& visits, bool by_value) {
    if (!visits.emplace(&current, Visit::in_progress).second) return;
    for (const auto* list : {&current.fields, &current.response_fields}) {
      if (by_value && list == &current.response_fields) break;
      for (const Field& f : *list) {
        if (!f.sub || (by_value ? f.dynamic : f.sub == &current)) continue;
        const auto seen = visits.find(f.sub);
        if (seen == visits.end()) {
          check_no_cycle(*f.sub, visits, by_value);
        } else if (seen->second == Visit::in_progress) {
          if (by_value)
            throw Error(current.path, f.line,
                        "field '" + f.name + "' makes '" + f.sub->name +
                            "' contain itself; recursive types "
                            "must use a pointer ('" +
                            f.type_spelling + "* " + f.name + "')");
          throw Error(current.path, f.line,
                      "field '" + f.name + "' closes a cycle of types through '" + f.sub->name +
                          "'; only a type pointing to itself may be recursive");
        }
      }
    }
    visits[&current] = Visit::done;
  }

  // Sizes of the host struct (pointers for dynamic fields) and the number
  // of fields once sub-types are written out, as signatures and the hash
  // do; checked for every section. Sub-types (also those of earlier loads)
  // are measured once and remembered.
  struct Sizes {
    std::size_t host_size = 0;
    std::size_t expanded_fields = 0;
  };

  const Sizes& check_sizes(const Definition& def) {
    if (auto known = sizes.find(&def); known != sizes.end()) return known->second;
    Sizes plain;
    for (const auto* list : {&def.fields, &def.response_fields}) {
      std::size_t total = 0;
      std::size_t expanded = 0;
      for (const Field& f : *list) {
        // By-value cycles and cycles longer than one type are refused
        // before this runs: only a dynamic field can name `def` itself.
        const Sizes* sub = f.sub && f.sub != &def ? &check_sizes(*f.sub) : nullptr;
        const std::size_t element = f.dynamic ? sizeof(void*) : f.primitive ? size_of(*f.primitive) : sub->host_size;
        std::size_t bytes;
        if (__builtin_mul_overflow(element, std::size_t{f.count}, &bytes) ||
            __builtin_add_overflow(total, bytes, &total) || total > max_definition_size)
          throw Error(def.path, f.line, "the definition grows beyond 4 GiB at field '" + f.name + "'");
        expanded += 1 + (sub ? sub->expanded_fields : 0);
        if (expanded > max_expanded_fields)
          throw Error(def.path, f.line,
                      "the definition has more than " + std::to_string(max_expanded_fields) +
                          " fields with its sub-types written out, at field '" + f.name + "'");
      }
      if (list == &def.fields) plain = {total, expanded};
    }
    return sizes.emplace(&def, plain).first->second;
  }

  std::map<const Definition*, Sizes> sizes;

  Library& lib;
  std::vector<Definition*> created;
};

Library::Library(SearchPath search_path) : search_path_(std::move(search_path)) {}
Library::~Library() = default;

const Definition& Library::load(std::string_view name) {
  if (auto it = loaded_.find(name); it != loaded_.end()) return *it->second;
  const std::string wanted(name);
  Loader loader(*this);
  try {
    const Definition* result = nullptr;
    if (auto source = sources_.find(wanted); source != sources_.end())
      result = &loader.parse_new(wanted, "<" + wanted + ">", source->second);
    if (!result && is_valid_definition_name(wanted)) {
      auto found = search_path_.find(wanted);
      if (!found) {
        search_path_.rescan();
        found = search_path_.find(wanted);
      }
      if (found) result = &loader.load_file(wanted, *found);
    }
    // LN also accepts a path to a definition file; the path as given is
    // then its name (and the base of the names of what it imports).
    if (!result && is_regular_file(wanted)) {
      char resolved[PATH_MAX];
      const std::string real = ::realpath(wanted.c_str(), resolved) ? resolved : wanted;
      result = &loader.load_file(wanted, real);
    }
    if (!result) {
      if (!is_valid_definition_name(wanted))
        throw Error("", 0,
                    "'" + wanted + "' is not a valid message-definition name (relative, '/'-separated, no '..')");
      throw Error("", 0,
                  "message definition '" + wanted + "' not found in these directories:" + list_dirs(search_path_));
    }
    loader.finish();
    return *result;
  } catch (...) {
    loader.forget_created();  // nothing half-loaded stays behind
    throw;
  }
}

void Library::add_source(std::string_view name, std::string_view text) {
  const std::string key(name);
  if (!is_valid_definition_name(key))
    throw Error("", 0, "'" + key + "' is not a valid message-definition name (relative, '/'-separated, no '..')");
  if (auto it = loaded_.find(key); it != loaded_.end() && sources_[key] != text)
    throw Error("", 0, "message definition '" + key + "' is already loaded with a different text");
  sources_[key] = std::string(text);
}

const Definition& Library::load_text(std::string_view name, std::string_view text) {
  const std::string wanted(name);
  if (!is_valid_definition_name(wanted))
    throw Error("", 0, "'" + wanted + "' is not a valid message-definition name (relative, '/'-separated, no '..')");
  if (auto it = loaded_.find(wanted); it != loaded_.end())
    throw Error("", 0, "message definition '" + wanted + "' is already loaded");
  Loader loader(*this);
  try {
    const Definition& def = loader.parse_new(wanted, "<" + wanted + ">", std::string(text));
    loader.finish();
    return def;
  } catch (...) {
    loader.forget_created();
    throw;
  }
}

}  // namespace ln::md
