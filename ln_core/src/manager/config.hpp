// Reading LN's .lnc configuration files (ln_spec §6.3): the whole language
// (defines and %( ) evaluation with built-in and user functions, the global
// directives, ifdef/ifndef lines, list modifiers, templates) and the
// sections a single-host manager acts on: instance (with the manager's
// limits of limits.hpp), defines, process, state, group, node_map. What
// LN 2.9 knows but ln_core does not implement (hosts, networks, GUI
// plugins, X11 forwarding, ...) is reported once in the log and otherwise
// ignored; docs/lnc.md lists both.
//
// The result is a plain model (LncSettings): processes, states and groups
// with every value evaluated, checked and their references resolved, so
// that the process supervision (process_control.hpp) never sees text it
// has to interpret. A malformed config throws ConfigError naming the file,
// the line and the cause.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "manager/limits.hpp"
#include "manager/log.hpp"

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

/// Where something was written.
struct ConfigPlace {
  std::string file;
  int line = 0;
  std::string text() const { return file + ":" + std::to_string(line); }
};

/// One entry of depends_on (and the other dependency lists): satisfied by
/// any of `candidates` (several when the name is what processes `provide`;
/// highest priority first). `down`: a state that must be DOWN ("!name").
struct Dependency {
  std::vector<std::string> candidates;
  bool down = false;
};

/// One `set_resource_limits: NAME=VALUE` entry (setrlimit in the child).
struct ResourceLimit {
  int resource = 0;      ///< RLIMIT_*
  long long value = -1;  ///< -1: unlimited
};

struct ProcessConfig {
  std::string name;          ///< full name, with push_name_prefix prefixes
  std::string display_name;  ///< without them: LN_PROGRAM_NAME
  ConfigPlace place;
  std::string command;
  std::vector<std::pair<std::string, std::string>> alt_commands;  ///< name, command
  std::string node;                                               ///< as written ("" = this host)
  std::string remote_host;  ///< non-empty: the node is another host (not supported)
  std::vector<std::pair<std::string, std::string>> environment;  ///< KEY, VALUE; unique keys
  std::vector<std::string> pass_environment;                     ///< name patterns
  std::string change_directory;
  std::vector<std::string> flags;
  std::string ready_regex;
  std::optional<double> ready_time;
  std::vector<Dependency> depends_on, depends_on_restart;
  std::vector<std::string> start_before;  ///< processes
  std::vector<Dependency> start_on_ready, start_on_successful_stop;
  std::vector<std::pair<std::string, double>> provides;  ///< name, priority
  int term_signal = 15;
  double term_timeout = 2;
  std::optional<double> auto_restart_interval;
  int policy = -1;  ///< SCHED_* or -1: leave alone
  int priority = 0;
  std::vector<int> affinity;  ///< CPUs; empty = leave alone
  std::optional<int> nice;
  std::vector<ResourceLimit> resource_limits;
  std::vector<std::pair<std::string, std::string>> map_topics, map_services;  ///< from, to
  std::string output_logfile;
  std::uint64_t output_logfile_size_limit = 10u * 1024 * 1024;
  unsigned output_logfile_keep_count = 2;
  unsigned max_output_lines = 1000;
  std::string warning_regex, warning_msg;
  std::string description, documentation;

  bool has_flag(const std::string& flag) const;
  bool has_ready_condition() const { return !ready_regex.empty() || ready_time.has_value(); }
};

struct StateConfig {
  std::string name;
  ConfigPlace place;
  std::string check, up, down;  ///< shell command lines ("" = none)
  double min_check_interval = 30;
  std::optional<double> auto_check_interval;
  std::vector<Dependency> depends_on, depends_on_restart;
  std::vector<std::pair<std::string, double>> provides;
  std::vector<std::string> flags;
  std::string remote_host;  ///< non-empty: a node that is another host (not supported)
  std::string unsupported;  ///< non-empty: why this state cannot work here (tunnels)
  unsigned max_output_lines = 1000;

  bool has_flag(const std::string& flag) const;
};

struct GroupConfig {
  std::string name;
  ConfigPlace place;
  std::vector<std::string> members;  ///< processes and states, groups expanded
  std::vector<std::string> flags;
};

struct LncSettings {
  std::string instance_name;  ///< "" when the config names none
  /// From `manager: [HOST]:PORT`; the host is "" when not written.
  std::optional<std::string> manager_host;
  std::optional<std::uint16_t> manager_port;
  std::vector<std::string> message_definition_dirs;  ///< absolute, in config order
  std::string generated_definition_dir;              ///< "" = the default
  std::vector<ProcessConfig> processes;              ///< in config order
  std::vector<StateConfig> states;
  std::vector<GroupConfig> groups;
  std::vector<std::string> files;  ///< every file read, the config first
  /// The manager's limits (limits.hpp), defaults unless the instance section sets them.
  ManagerLimits limits;
};

/// What the reader may know beyond the config itself.
struct LncContext {
  /// Takes the place of the config's instance name (-i), also in %(instance_name).
  std::string instance_name;
  /// Defines every config sees (LN_PREFIX, LN_LD_LIBRARY_PATH, LN_PYTHON, ...).
  std::map<std::string, std::string> builtin_defines;
  /// Searched for `include FILE` when FILE is not beside the including file.
  std::vector<std::string> include_dirs;
};

/// Reads `path` and what it includes. Throws ConfigError.
LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const LncContext& context);
/// The same for text that claims to come from `path` (for tests).
LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const LncContext& context);

/// Shorthands with only an instance name override.
LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const std::string& instance_name = "");
LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const std::string& instance_name = "");

/// Splits "HOST:PORT" (HOST may be empty). Throws std::invalid_argument.
std::pair<std::string, std::uint16_t> split_host_port(const std::string& text);

/// Whether `node` names the manager's own host ("localhost", its name,
/// a loopback or local address, "" ...).
bool is_local_node(const std::string& node);

/// "SIGTERM", "TERM", "term" or "15" -> 15; nullopt if unknown.
std::optional<int> parse_signal(const std::string& text);
/// 15 -> "SIGTERM".
std::string signal_name(int signal);

/// "RTPRIO", "RLIMIT_RTPRIO", "real-time priority" (ulimit's words) ->
/// RLIMIT_RTPRIO; nullopt if unknown.
std::optional<int> parse_resource_limit(const std::string& name);

}  // namespace ln::manager
