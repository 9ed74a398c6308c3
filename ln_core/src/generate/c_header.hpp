// Emits the C/C++ header that ln_generate writes: for each definition its
// "<ID>_MD_NAME" (name|hash), packed structs usable from C and C++, and for
// services and events the signature constants and C++ base classes. The
// names and layouts are LN 2.9's, so programs written for LN 2.9 compile
// unchanged.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"

namespace ln::generate {

struct CHeaderOptions {
  /// Include-guard macro; LN derives it from the output file's name.
  std::string guard = "LN_MESSAGES_H";
  /// Text placed verbatim at the top (a comment saying how it was made).
  std::string preamble;
  /// --map-service-base: definition name -> base name of its C++ classes.
  std::map<std::string, std::string> service_base_names;
  /// --wrapping-ns: extra namespaces around the generated C++ classes.
  std::vector<std::string> wrapping_namespaces;
  /// --prefix-ns-define: when this macro is defined, its value names an
  /// outermost namespace.
  std::string prefix_namespace_define = "LN_MD_PREFIX_NS";
};

/// The complete header text for `definitions` (imports first, each type once).
std::string emit_c_header(const std::vector<const md::Definition*>& definitions, const CHeaderOptions& options);

/// LN's include guard for an output path: basename, upper case, '.' -> '_'.
std::string guard_for_output(const std::string& output_path);

}  // namespace ln::generate
