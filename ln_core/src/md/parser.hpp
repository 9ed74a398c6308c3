// Reads the text of one message definition into a Definition. Imports
// (`define`) are resolved through a DefineResolver so that the parser knows
// nothing about files, caches or cycles.
#pragma once

#include <string>
#include <string_view>

#include "ln/md/message_definition.hpp"

namespace ln::md {

class DefineResolver {
 public:
  virtual ~DefineResolver() = default;
  /// The definition `quoted` imported by `importer` at `line`; sets
  /// `absolute_name` to the name generated code will use for it.
  virtual const Definition& resolve_define(const Definition& importer, const std::string& quoted, int line,
                                           std::string& absolute_name) = 0;
};

/// Parses `text` into `definition`, whose `name` and `path` are set.
/// Throws Error (with path and line) on the first problem. The hash is not
/// computed here: it needs every imported type complete.
void parse_definition(Definition& definition, std::string_view text, DefineResolver& resolver);

}  // namespace ln::md
