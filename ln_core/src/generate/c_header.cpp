#include "generate/c_header.hpp"

#include <algorithm>
#include <cctype>
#include <set>
#include <sstream>

namespace ln::generate {
namespace {

using md::Definition;
using md::Field;
using md::Kind;

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
  return s;
}

std::string struct_type_name(const Definition& def) { return md::identifier_from_name(def.name) + "_t"; }

std::string basename(const std::string& name) {
  const auto slash = name.rfind('/');
  return slash == std::string::npos ? name : name.substr(slash + 1);
}

class Emitter {
 public:
  explicit Emitter(const CHeaderOptions& options) : options_(options) {}

  void emit(const Definition& def) {
    if (emitted_.count(&def)) return;
    // Imports first. Only direct self-recursion exists (the model refuses
    // longer cycles), so this recursion ends.
    for (const auto& define : def.defines)
      if (define.definition != &def) emit(*define.definition);
    emitted_.insert(&def);
    // Each type is guarded by its MD_NAME macro, so a translation unit may
    // include several generated headers that share a type (LN 2.9's
    // headers then fail with redefinitions).
    const std::string guard = upper(md::identifier_from_name(def.name)) + "_MD_NAME";
    out_ << "\n#ifndef " << guard;
    switch (def.kind) {
      case Kind::Plain:
        emit_plain(def);
        break;
      case Kind::Service:
        emit_service(def);
        break;
      case Kind::Event:
        emit_event(def);
        break;
    }
    out_ << "#endif  /* " << guard << " */\n";
  }

  std::string text() const { return out_.str(); }

 private:
  void emit_fields(const std::vector<Field>& fields, const std::string& indent) {
    for (const Field& f : fields) {
      const std::string type = f.primitive ? std::string(md::c_name(*f.primitive)) : struct_type_name(*f.sub);
      out_ << indent << type << (f.dynamic ? "* " : " ") << f.name;
      if (f.count > 1) out_ << '[' << f.count << ']';
      out_ << ";\n";
    }
  }

  void emit_banner(const Definition& def, const std::string& id_upper) {
    out_ << "\n/* " << def.name << " */\n";
    out_ << "#define " << id_upper << "_MD_NAME \"" << def.name_with_hash() << "\"\n";
  }

  std::vector<std::string> cpp_namespaces(const Definition& def) const {
    std::vector<std::string> namespaces = options_.wrapping_namespaces;
    std::string_view name = def.name;
    for (auto slash = name.find('/'); slash != std::string_view::npos; slash = name.find('/')) {
      namespaces.emplace_back(name.substr(0, slash));
      name.remove_prefix(slash + 1);
    }
    return namespaces;
  }

  void open_cpp_scope(const Definition& def) {
    const auto& prefix = options_.prefix_namespace_define;
    out_ << "#ifdef __cplusplus\n#ifdef " << prefix << "\nnamespace " << prefix << " {\n#endif\n";
    for (const auto& ns : cpp_namespaces(def)) out_ << "namespace " << ns << " {\n";
  }

  void close_cpp_scope(const Definition& def) {
    auto namespaces = cpp_namespaces(def);
    for (auto it = namespaces.rbegin(); it != namespaces.rend(); ++it) out_ << "}  // namespace " << *it << "\n";
    out_ << "#ifdef " << options_.prefix_namespace_define << "\n}\n#endif\n#endif  // __cplusplus\n";
  }

  std::string base_name(const Definition& def) const {
    const auto mapped = options_.service_base_names.find(def.name);
    return mapped != options_.service_base_names.end() ? mapped->second : basename(def.name);
  }

  void emit_plain(const Definition& def) {
    const std::string id = md::identifier_from_name(def.name);
    emit_banner(def, upper(id));
    // The struct is declared before its body so that a recursive type can
    // point to itself.
    out_ << "#include \"ln/packed.h\"\n"
         << "struct LN_PACKED " << id << "_struct;\n"
         << "typedef struct " << id << "_struct " << id << "_t;\n"
         << "struct LN_PACKED " << id << "_struct {\n";
    emit_fields(def.fields, "\t");
    out_ << "};\n#include \"ln/endpacked.h\"\n";
    // The LN documentation names topic types NAMESPACE::NAME_t as well.
    if (!cpp_namespaces(def).empty()) {
      open_cpp_scope(def);
      out_ << "typedef ::" << id << "_t " << base_name(def) << "_t;\n";
      close_cpp_scope(def);
    }
  }

  void emit_service(const Definition& def) {
    const std::string id = md::identifier_from_name(def.name);
    const std::string base = base_name(def);
    emit_banner(def, upper(id));
    out_ << "#define " << upper(id) << "_SIGNATURE \"" << md::signature(def) << "\"\n"
         << "#define " << id << "_signature " << upper(id) << "_SIGNATURE\n";

    out_ << "#include \"ln/packed.h\"\ntypedef struct LN_PACKED {\n";
    std::vector<std::pair<std::string, std::string>> cpp_typedefs;
    if (!def.fields.empty()) {
      out_ << "\tstruct LN_PACKED " << id << "_request_t {\n";
      emit_fields(def.fields, "\t\t");
      out_ << "\t} req;\n";
      cpp_typedefs.emplace_back(id + "_request_t", "request_t");
    }
    if (!def.response_fields.empty()) {
      out_ << "\tstruct LN_PACKED " << id << "_response_t {\n";
      emit_fields(def.response_fields, "\t\t");
      out_ << "\t} resp;\n";
      cpp_typedefs.emplace_back(id + "_response_t", "response_t");
    }
    if (!cpp_typedefs.empty()) {
      out_ << "#ifdef __cplusplus\n";
      for (const auto& [type, alias] : cpp_typedefs) out_ << "\ttypedef " << type << ' ' << alias << ";\n";
      out_ << "#endif\n";
    }
    out_ << "} " << id << "_t;\n#include \"ln/endpacked.h\"\n";

    open_cpp_scope(def);
    const std::string cls = base + "_base";
    out_ << "typedef ::" << id << "_t " << base << "_t;\n\n"
         << "/* Derive a provider from this class: call register_" << base << "() and implement\n"
         << "   on_" << base << "(), which gets data.req filled and data.resp zeroed, must\n"
         << "   call req.respond() and return 0 (or an error code > 0). */\n"
         << "class " << cls << " {\n"
         << " public:\n"
         << "\tvirtual ~" << cls << "() { unregister_" << base << "(); }\n\n"
         << " protected:\n"
         << "\t::ln::service* svc;\n\n"
         << "\t" << cls << "() : svc(NULL) {}\n\n"
         << "\tvoid register_" << base << "(::ln::client* clnt, const std::string service_name,\n"
         << "\t\tconst char* group_name = NULL) {\n"
         << "\t\tsvc = clnt->get_service_provider(service_name, \"" << def.name << "\", " << id << "_signature);\n"
         << "\t\tsvc->set_handler(&handle_request, this);\n"
         << "\t\tsvc->do_register(group_name);\n"
         << "\t}\n\n"
         << "\tvoid unregister_" << base << "() {\n"
         << "\t\tif (svc) {\n"
         << "\t\t\tsvc->clnt->release_service(svc);\n"
         << "\t\t\tsvc = NULL;\n"
         << "\t\t}\n"
         << "\t}\n\n"
         << "\tvirtual int on_" << base << "(::ln::service_request& req, " << base << "_t& data) = 0;\n\n"
         << " private:\n"
         << "\tstatic int handle_request(::ln::client&, ::ln::service_request& req, void* self) {\n"
         << "\t\t" << base << "_t data;\n"
         << "\t\treq.set_data(&data, " << id << "_signature);\n";
    if (!def.response_fields.empty()) out_ << "\t\tmemset(&data.resp, 0, sizeof(data.resp));\n";
    out_ << "\t\treturn static_cast<" << cls << "*>(self)->on_" << base << "(req, data);\n"
         << "\t}\n"
         << "};\n";
    close_cpp_scope(def);
  }

  void emit_event(const Definition& def) {
    const std::string id = md::identifier_from_name(def.name);
    const std::string base = base_name(def);
    emit_banner(def, upper(id));
    out_ << "#define " << upper(id) << "_CONNECT_SIGNATURE \"" << def.name << ": "
         << md::fields_signature(def, def.fields) << "\"\n"
         << "#define " << upper(id) << "_CALL_SIGNATURE \"" << def.name << ": "
         << md::fields_signature(def, def.response_fields) << "\"\n"
         << "#define " << id << "_connect_signature " << upper(id) << "_CONNECT_SIGNATURE\n"
         << "#define " << id << "_call_signature " << upper(id) << "_CALL_SIGNATURE\n";
    out_ << "#include \"ln/packed.h\"\ntypedef struct LN_PACKED {\n";
    emit_fields(def.response_fields, "\t");
    out_ << "} " << id << "_call_t;\n#include \"ln/endpacked.h\"\n";
    out_ << "#include \"ln/packed.h\"\ntypedef struct LN_PACKED {\n";
    emit_fields(def.fields, "\t");
    out_ << "} " << id << "_connect_t;\n#include \"ln/endpacked.h\"\n";

    open_cpp_scope(def);
    const std::string cls = base + "_base";
    out_ << "typedef ::" << id << "_connect_t " << base << "_connect_t;\n"
         << "typedef ::" << id << "_call_t " << base << "_call_t;\n\n"
         << "class " << cls << " {\n"
         << " public:\n"
         << "\tvirtual ~" << cls << "() {}\n\n"
         << " protected:\n"
         << "\t::ln::event_connection* connection;\n\n"
         << "\tvoid connect_to_" << base << "(::ln::client* clnt, const std::string event_name, " << base
         << "_connect_t* connect_data) {\n"
         << "\t\tconnection = clnt->connect_to_event(event_name, " << id << "_connect_signature, connect_data,\n"
         << "\t\t\t&handle_event, this);\n"
         << "\t}\n\n"
         << "\t/* Called for each event; the default ignores it. */\n"
         << "\tvirtual void on_" << base << "(" << base << "_call_t& event) { (void)event; }\n\n"
         << " private:\n"
         << "\tstatic void handle_event(::ln::event_call& call, void* self) {\n"
         << "\t\t" << base << "_call_t event;\n"
         << "\t\tcall.set_data(&event, " << id << "_call_signature);\n"
         << "\t\tstatic_cast<" << cls << "*>(self)->on_" << base << "(event);\n"
         << "\t}\n"
         << "};\n";
    close_cpp_scope(def);
  }

  const CHeaderOptions& options_;
  std::set<const Definition*> emitted_;
  std::ostringstream out_;
};

}  // namespace

std::string emit_c_header(const std::vector<const md::Definition*>& definitions, const CHeaderOptions& options) {
  Emitter emitter(options);
  for (const auto* def : definitions) emitter.emit(*def);

  std::ostringstream out;
  out << options.preamble << "#ifndef " << options.guard << "\n#define " << options.guard << "\n\n"
      << "#include <stdint.h>\n#include <string.h>\n#include <ln/ln.h>\n\n"
      << "#ifndef HAVE_LN_MD_NAME\n#define HAVE_LN_MD_NAME 1\n#endif\n"
      << emitter.text() << "\n#endif  // " << options.guard << "\n";
  return out.str();
}

std::string guard_for_output(const std::string& output_path) {
  const auto slash = output_path.rfind('/');
  std::string guard = upper(slash == std::string::npos ? output_path : output_path.substr(slash + 1));
  // LN maps only '.'; anything else that cannot appear in a macro name
  // would break the header, so it becomes '_' as well.
  for (char& c : guard)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  if (!guard.empty() && std::isdigit(static_cast<unsigned char>(guard.front()))) guard.insert(0, "_");
  return guard;
}

}  // namespace ln::generate
