// Logging for the manager library: it never prints itself; whoever embeds it
// (ln_manager's main, a test) decides where the lines go.
#pragma once

#include <functional>
#include <string>

namespace ln::manager {

enum class LogLevel { Debug = 0, Info = 1, Warning = 2, Error = 3 };

using LogFunction = std::function<void(LogLevel, const std::string&)>;

inline const char* level_name(LogLevel level) {
  switch (level) {
    case LogLevel::Debug:
      return "debug";
    case LogLevel::Info:
      return "info";
    case LogLevel::Warning:
      return "warning";
    case LogLevel::Error:
      return "error";
  }
  return "?";
}

}  // namespace ln::manager
