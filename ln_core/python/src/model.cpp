// The message-definition model for Python: the one md parser of ln_core
// (ln/md/message_definition.hpp) turned into plain Python data that
// links_and_nodes/_packets.py compiles into packet classes.
//
// A definition becomes a dict
//   {"name", "hash", "kind" ("plain" | "service" | "event"), "size",
//    "signature", "fields": [field...], "response_fields": [field...],
//    "defs": {name: definition dict of every imported sub-type}}
// and a field a tuple
//   (name, type_spelling, primitive ("" for a sub-type), sub ("" or the
//    sub-type's definition name), dynamic, count, element_size)
// where element_size is the primitive's size or the sub-type's packet size.
#include "model.hpp"

#include <map>
#include <set>

#include <nanobind/stl/string.h>

#include "md/parser.hpp"

namespace nb = nanobind;
using namespace ln::md;

namespace lnpy {
namespace {

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::Service:
      return "service";
    case Kind::Event:
      return "event";
    default:
      return "plain";
  }
}

nb::list fields_to_python(const std::vector<Field>& fields, std::vector<const Definition*>& subs) {
  nb::list out;
  for (const Field& f : fields) {
    std::size_t element = 0;
    std::string primitive, sub;
    if (f.primitive) {
      primitive = std::string(c_name(*f.primitive));
      element = size_of(*f.primitive);
    } else {
      sub = f.sub->name;
      element = packet_size(*f.sub);
      subs.push_back(f.sub);
    }
    out.append(nb::make_tuple(f.name, f.type_spelling, primitive, sub, f.dynamic, f.count, element));
  }
  return out;
}

nb::dict one_to_python(const Definition& d, std::vector<const Definition*>& subs) {
  nb::dict out;
  out["name"] = d.name;
  out["hash"] = d.hash;
  out["kind"] = kind_name(d.kind);
  out["size"] = d.kind == Kind::Plain ? packet_size(d) : 0;
  out["signature"] = signature(d);
  out["fields"] = fields_to_python(d.fields, subs);
  out["response_fields"] = fields_to_python(d.response_fields, subs);
  return out;
}

// Records the names a definition imports instead of resolving them. Every
// import resolves to the same placeholder, so a define repeated under
// another spelling passes here; the real parse checks what it names.
struct ImportRecorder final : DefineResolver {
  std::vector<std::string> quoted;
  Definition placeholder;
  const Definition& resolve_define(const Definition&, const std::string& name, int, std::string& absolute) override {
    quoted.push_back(name);
    absolute = name;
    return placeholder;
  }
};

std::string dirname_of(const std::string& name) {
  const auto slash = name.rfind('/');
  return slash == std::string::npos ? std::string() : name.substr(0, slash);
}

}  // namespace

nb::dict definition_to_python(const Definition& definition) {
  std::vector<const Definition*> pending;
  nb::dict top = one_to_python(definition, pending);
  nb::dict defs;
  std::set<std::string> done{definition.name};
  while (!pending.empty()) {
    const Definition* d = pending.back();
    pending.pop_back();
    if (!done.insert(d->name).second) continue;
    defs[d->name.c_str()] = one_to_python(*d, pending);
  }
  top["defs"] = defs;
  return top;
}

nb::dict build_model(const std::string& name, const std::optional<std::string>& root_text, const Fetch& fetch) {
  std::map<std::string, std::string> sources;
  if (root_text) {
    sources[name] = *root_text;
  } else {
    auto text = fetch(name);
    if (!text) throw Error("", 0, "message definition '" + name + "' not found");
    sources[name] = *text;
  }
  // Breadth-first over the imports: each text is parsed once to learn what
  // it imports, the imported texts are fetched the way the parser will look
  // them up (next to the importer first, then as written).
  std::vector<std::string> queue{name};
  while (!queue.empty()) {
    const std::string current = queue.back();
    queue.pop_back();
    ImportRecorder recorder;
    Definition scratch;
    scratch.name = current;
    scratch.path = "<" + current + ">";
    parse_definition(scratch, sources[current], recorder);
    for (const std::string& quoted : recorder.quoted) {
      const std::string dir = dirname_of(current);
      std::vector<std::string> candidates;
      if (!dir.empty()) candidates.push_back(dir + "/" + quoted);
      candidates.push_back(quoted);
      bool found = false;
      for (const std::string& candidate : candidates) {
        if (sources.count(candidate)) {
          found = true;
          break;
        }
        if (!is_valid_definition_name(candidate)) continue;
        if (auto text = fetch(candidate)) {
          sources[candidate] = *text;
          queue.push_back(candidate);
          found = true;
          break;
        }
      }
      if (!found) throw Error(scratch.path, 0, "define refers to '" + quoted + "', which the manager does not know");
    }
  }
  Library library(SearchPath::exactly({}));
  for (const auto& [source_name, text] : sources) library.add_source(source_name, text);
  return definition_to_python(library.load(name));
}

}  // namespace lnpy
