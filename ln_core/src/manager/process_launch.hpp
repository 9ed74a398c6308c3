// How a process of the config is started: its command line and the
// environment LN 2.9 gives it (the configured environment, pass_environment,
// LD_LIBRARY_PATH, LN_PROGRAM_NAME, LN_MESSAGE_DEFINITION_DIRS, LN_MAP_*,
// TERM, LN_MANAGER). Shared by the supervision (process_control.cpp) and
// `ln_manager --check`, which shows what would run.
#pragma once

#include <string>
#include <vector>

#include "manager/config.hpp"

namespace ln::manager {

/// What the environment of every process depends on.
struct LaunchContext {
  std::string manager_address;               ///< LN_MANAGER ("" = not set)
  std::vector<std::string> definition_dirs;  ///< LN_MESSAGE_DEFINITION_DIRS
  std::string library_dir;                   ///< added to LD_LIBRARY_PATH ("" = nothing)
};

/// The whole environment ("NAME=VALUE"), in LN 2.9's order.
std::vector<std::string> process_environment(const ProcessConfig& process, const LaunchContext& context);

/// The command line: the alt_command `alt` ("" = the command).
std::string process_command(const ProcessConfig& process, const std::string& alt);

/// The directory it starts in: change_directory, else /tmp, where LN 2.9's
/// daemon starts a process that names none.
std::string process_directory(const ProcessConfig& process);

/// The argv for `command`, or the reason it cannot run in `problem`
/// (command not found, not executable, no directory without a PATH search).
std::vector<std::string> process_argv(const ProcessConfig& process, const std::string& command, std::string& problem);

}  // namespace ln::manager
