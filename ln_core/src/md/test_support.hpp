// A throw-away directory tree of message-definition files for unit tests.
#pragma once

#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <stdexcept>
#include <string>

#include "ln/md/message_definition.hpp"

namespace ln::md::testing {

class DefinitionTree {
 public:
  DefinitionTree() {
    char pattern[] = "/tmp/ln_md_test_XXXXXX";
    if (!::mkdtemp(pattern)) throw std::runtime_error("mkdtemp failed");
    root_ = pattern;
  }
  ~DefinitionTree() {
    const std::string command = "rm -rf '" + root_ + "'";
    (void)!::system(command.c_str());
  }
  DefinitionTree(const DefinitionTree&) = delete;
  DefinitionTree& operator=(const DefinitionTree&) = delete;

  const std::string& root() const { return root_; }

  /// Writes `content` to `root/relative`, creating directories.
  std::string write(const std::string& relative, const std::string& content) const {
    const std::string path = root_ + "/" + relative;
    for (auto slash = path.find('/', root_.size() + 1); slash != std::string::npos;
         slash = path.find('/', slash + 1))
      ::mkdir(path.substr(0, slash).c_str(), 0700);
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }

 private:
  std::string root_;
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
