// What a client takes from its command line and environment before it
// connects (ln_spec §5): the manager address, the client name, topic and
// service name mappings, and the arguments it leaves to the program.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "client/name_mapping.hpp"

namespace ln::clientlib {

/// The LN options found in argv. Every other argument (argv[0] included)
/// stays in `remaining`, in order.
struct CommandLine {
  std::optional<std::string> manager_address;       ///< --ln-manager / -ln_manager
  std::optional<std::string> program_name;          ///< --ln-program-name / -ln_program_name
  std::vector<NameMapping::Rule> topic_mappings;    ///< --ln-map-topic SRC DST
  std::vector<NameMapping::Rule> service_mappings;  ///< --ln-map-service SRC DST
  std::vector<std::string> remaining;
};

/// Parses argv without modifying it. An option missing its value(s) at the
/// end of argv is left in `remaining`. A repeated address or name option:
/// the last one wins. With `exact_name` (the name in code starts with
/// "exact:") --ln-program-name is not an option and stays in `remaining`,
/// as in LN 2.9.
CommandLine parse_command_line(int argc, const char* const* argv, bool exact_name = false);

/// The manager address to use: the explicit one (argument or constructor)
/// wins, LN_MANAGER is the fallback; empty values count as absent.
std::optional<std::string> choose_manager_address(const std::optional<std::string>& explicit_address,
                                                  const char* ln_manager_env);

struct RequestedName {
  std::string name;
  bool exact = false;  ///< "exact:NAME": the manager must grant it unchanged
};

/// LN's name rules (§5.3): "exact:NAME" is taken verbatim and ignores the
/// overrides; otherwise LN_PROGRAM_NAME replaces the name from the code and
/// --ln-program-name replaces both. An empty result falls back to
/// `fallback` (the program's name).
RequestedName choose_client_name(const char* name_in_code, const char* program_name_env,
                                 const std::optional<std::string>& program_name_argument, const std::string& fallback);

}  // namespace ln::clientlib
