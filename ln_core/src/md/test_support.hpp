// A throw-away directory tree of message-definition files for unit tests.
#pragma once

#include <string>

#include "testing/temp_dir.hpp"

namespace ln::md::testing {

class DefinitionTree : public ln::test::TempDir {
 public:
  DefinitionTree() : TempDir("ln_md_test") {}
  const std::string& root() const { return path(); }
};

}  // namespace ln::md::testing
