// ln_md_info: prints what the model knows about message definitions as JSON
// (name, hash, signature, packet size, and the generated structs' layout).
// Used by the differential tests and handy for inspecting a definition.
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"

namespace {

using namespace ln::md;

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20) {
      char buffer[8];
      std::snprintf(buffer, sizeof buffer, "\\u%04x", c);
      out += buffer;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

const char* kind_name(Kind kind) {
  switch (kind) {
    case Kind::Plain:
      return "plain";
    case Kind::Service:
      return "service";
    case Kind::Event:
      return "event";
  }
  return "?";
}

// One generated struct: its C type, the member prefix inside it (services
// nest "req."/"resp."), and the fields with host offsets.
void print_section(std::ostream& out, const std::string& label, const std::string& c_type,
                   const std::string& member_prefix, const std::vector<Field>& fields) {
  const StructLayout layout = struct_layout(fields);
  out << "{\"section\": " << json_string(label) << ", \"c_type\": " << json_string(c_type)
      << ", \"member_prefix\": " << json_string(member_prefix) << ", \"size\": " << layout.size << ", \"fields\": [";
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const Field& f = fields[i];
    const std::size_t next = i + 1 < fields.size() ? layout.offsets[i + 1] : layout.size;
    out << (i ? ", " : "") << "{\"name\": " << json_string(f.name)
        << ", \"type\": " << json_string(f.primitive ? std::string(c_name(*f.primitive)) : f.sub->name)
        << ", \"dynamic\": " << (f.dynamic ? "true" : "false") << ", \"count\": " << f.count
        << ", \"offset\": " << layout.offsets[i] << ", \"size\": " << next - layout.offsets[i] << "}";
  }
  out << "]}";
}

void print_definition(std::ostream& out, const Definition& def) {
  const std::string id = identifier_from_name(def.name);
  out << "{\"name\": " << json_string(def.name) << ", \"path\": " << json_string(def.path) << ", \"kind\": \""
      << kind_name(def.kind) << "\", \"hash\": " << json_string(def.hash)
      << ", \"signature\": " << json_string(signature(def))
      << ", \"packet_size\": " << (def.kind == Kind::Plain ? std::to_string(packet_size(def)) : std::string("null"))
      << ", \"defines\": [";
  for (std::size_t i = 0; i < def.defines.size(); ++i)
    out << (i ? ", " : "") << "{\"local_name\": " << json_string(def.defines[i].local_name)
        << ", \"name\": " << json_string(def.defines[i].absolute_name) << "}";
  out << "], \"structs\": [";
  switch (def.kind) {
    case Kind::Plain:
      print_section(out, "fields", id + "_t", "", def.fields);
      break;
    case Kind::Service: {
      bool first = true;
      if (!def.fields.empty()) {
        print_section(out, "request", id + "_t", "req.", def.fields);
        first = false;
      }
      if (!def.response_fields.empty()) {
        if (!first) out << ", ";
        print_section(out, "response", id + "_t", "resp.", def.response_fields);
      }
      break;
    }
    case Kind::Event:
      print_section(out, "connect", id + "_connect_t", "", def.fields);
      out << ", ";
      print_section(out, "call", id + "_call_t", "", def.response_fields);
      break;
  }
  out << "]}";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> dirs, names;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::cout << "usage: ln_md_info [--md-dir DIR]... NAME...\n"
                   "Prints each message definition's name, hash, signature, packet size and\n"
                   "generated struct layout as one JSON object per line.\n";
      return 0;
    }
    if (arg == "--md-dir" || arg == "-md_dir") {
      if (++i >= argc) {
        std::cerr << "ln_md_info: error: --md-dir needs a directory\n";
        return 2;
      }
      dirs.push_back(argv[i]);
    } else {
      names.push_back(arg);
    }
  }
  if (names.empty()) {
    std::cerr << "ln_md_info: error: no message definition names given (see --help)\n";
    return 2;
  }
  try {
    Library library(SearchPath::standard(dirs));
    std::ostringstream out;
    for (const auto& name : names) {
      print_definition(out, library.load(name));
      out << "\n";
    }
    std::cout << out.str();
  } catch (const std::exception& e) {
    std::cerr << "ln_md_info: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
