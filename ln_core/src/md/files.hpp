// File checks of the definition search path and the manager's configuration: std::filesystem's,
// without exceptions (a path that cannot be examined counts as not there).
#pragma once

#include <filesystem>
#include <string>
#include <system_error>

namespace ln::md::files {

inline bool is_directory(const std::string& path) {
  std::error_code error;
  return std::filesystem::is_directory(path, error);
}

inline bool is_regular_file(const std::string& path) {
  std::error_code error;
  return std::filesystem::is_regular_file(path, error);
}

inline bool exists(const std::string& path) {
  std::error_code error;
  return std::filesystem::exists(path, error);
}

}  // namespace ln::md::files
