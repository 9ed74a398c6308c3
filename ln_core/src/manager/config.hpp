// Reading LN's .lnc configuration files (ln_spec §6.3) as far as a manager
// without process control needs them: the `instance` section (name, manager,
// gen_message_definition_path, the manager's limits of limits.hpp),
// `defines`, and the directives `include`, `optional_include`,
// `add_message_definition_dir`, `undef`, `warning` and the `ifdef`/`ifndef`
// line prefixes. Values may use %(DEFINE), CURDIR,
// CURRENT, instance_name, hostname, manager and the functions env,
// get_port_from_string, dirname, basename, realpath and strip. Everything
// else (process, state, group, hosts ... sections, other instance keys and
// directives) is reported once in the log and otherwise ignored; nothing in
// a config is ever executed.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "manager/log.hpp"
#include "manager/manager.hpp"

namespace ln::manager {

/// A problem that makes a config unusable; what() is "FILE:LINE: reason".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& file, int line, const std::string& reason);
  const std::string& file() const { return file_; }
  int line() const { return line_; }

 private:
  std::string file_;
  int line_;
};

struct LncSettings {
  std::string instance_name;  ///< "" when the config names none
  /// From `manager: [HOST]:PORT`; the host is "" when not written.
  std::optional<std::string> manager_host;
  std::optional<std::uint16_t> manager_port;
  std::vector<std::string> message_definition_dirs;  ///< absolute, in config order
  std::string generated_definition_dir;             ///< "" = the default
  /// The manager's limits (limits.hpp), defaults unless the instance section sets them.
  ManagerLimits limits;
};

/// Reads `path` and what it includes. `instance_name` (from -i) takes the
/// place of the config's name, also in %(instance_name). Throws ConfigError.
LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const std::string& instance_name = "");
/// The same for text that claims to come from `path` (for tests).
LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const std::string& instance_name = "");

/// Splits "HOST:PORT" (HOST may be empty). Throws std::invalid_argument.
std::pair<std::string, std::uint16_t> split_host_port(const std::string& text);

}  // namespace ln::manager
