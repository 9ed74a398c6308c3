// A throw-away directory tree of message-definition files for unit tests.
#pragma once

#include <initializer_list>
#include <string>
#include <utility>

#include "ln/md/message_definition.hpp"
#include "testing/temp_dir.hpp"

namespace ln::md::testing {

class DefinitionTree : public ln::test::TempDir {
 public:
  DefinitionTree() : TempDir("ln_md_test") {}
  const std::string& root() const { return path(); }
  /// Writes each {name, text}: the definition file `name` below root().
  void write_all(std::initializer_list<std::pair<std::string, std::string>> files) const {
    for (const auto& [name, text] : files) write(name, text);
  }
};

/// Loads `name` from `tree` and returns the Error it throws ("" if none).
inline std::string load_error(const DefinitionTree& tree, const std::string& name) {
  Library library(SearchPath::exactly({tree.root()}));
  try {
    library.load(name);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace ln::md::testing
