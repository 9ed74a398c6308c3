#include "manager/process_launch.hpp"

#include <fnmatch.h>
#include <pwd.h>
#include <unistd.h>

#include <cstdlib>

#include <algorithm>
#include <vector>

#include "manager/lnc_eval.hpp"

namespace ln::manager {

std::vector<std::string> process_environment(const ProcessConfig& process, const LaunchContext& context) {
  std::vector<std::pair<std::string, std::string>> env = process.environment;
  auto has = [&](const std::string& name) {
    return std::any_of(env.begin(), env.end(), [&](const auto& e) { return e.first == name; });
  };
  auto value = [&](const std::string& name) -> std::string& {
    for (auto& e : env)
      if (e.first == name) return e.second;
    env.emplace_back(name, "");
    return env.back().second;
  };
  for (const auto& pattern : process.pass_environment)
    for (char** entry = environ; *entry != nullptr; ++entry) {
      const std::string text = *entry;
      const auto equals = text.find('=');
      if (equals == std::string::npos) continue;
      const std::string name = text.substr(0, equals);
      if (::fnmatch(pattern.c_str(), name.c_str(), 0) == 0 && !has(name))
        env.emplace_back(name, text.substr(equals + 1));
    }
  if (!context.library_dir.empty() && !process.has_flag("no_ln_ld_library_path")) {
    std::string& path = value("LD_LIBRARY_PATH");
    if (("::" + path + ":").find(":" + context.library_dir + ":") == std::string::npos)
      path = path.empty() ? context.library_dir : path + ":" + context.library_dir;
  }
  if (!has("LN_PROGRAM_NAME")) env.emplace_back("LN_PROGRAM_NAME", process.display_name);
  std::string dirs;
  for (const auto& dir : context.definition_dirs) dirs += (dirs.empty() ? "" : ":") + dir;
  if (!dirs.empty()) {
    std::string& configured = value("LN_MESSAGE_DEFINITION_DIRS");
    configured = configured.empty() ? dirs : configured + ":" + dirs;
  }
  for (const auto& [name, list] :
       {std::pair{"LN_MAP_TOPICS", &process.map_topics}, std::pair{"LN_MAP_SERVICES", &process.map_services}}) {
    if (list->empty() || has(name)) continue;
    std::string joined;
    for (const auto& [from, to] : *list) joined += (joined.empty() ? "" : "|") + from + "|" + to;
    env.emplace_back(name, joined);
  }
  if (process.has_flag("set_user_and_home")) {
    // the manager's user, as LN 2.9's daemon sets them: its account, else its environment
    passwd entry{};
    passwd* account = nullptr;
    std::vector<char> buffer(16384);  // (getpwuid_r: the manager's threads may look up accounts too)
    ::getpwuid_r(::geteuid(), &entry, buffer.data(), buffer.size(), &account);
    const char* user = account != nullptr ? account->pw_name : std::getenv("USER");
    const char* home = account != nullptr ? account->pw_dir : std::getenv("HOME");
    if (user != nullptr && !has("USER")) env.emplace_back("USER", user);
    if (home != nullptr && !has("HOME")) env.emplace_back("HOME", home);
  }
  if (!process.has_flag("no_pty") && !has("TERM")) env.emplace_back("TERM", "xterm");
  if (!has("LN_MANAGER") && !context.manager_address.empty()) env.emplace_back("LN_MANAGER", context.manager_address);
  std::vector<std::string> out;
  for (const auto& [name, text] : env) out.push_back(name + "=" + text);
  return out;
}

std::string process_command(const ProcessConfig& process, const std::string& alt) {
  if (!alt.empty())
    for (const auto& [name, command] : process.alt_commands)
      if (name == alt) return command;
  return process.command;
}

std::string process_directory(const ProcessConfig& process) {
  return process.change_directory.empty() ? std::string("/tmp") : process.change_directory;
}

std::vector<std::string> process_argv(const ProcessConfig& process, const std::string& command, std::string& problem) {
  if (process.has_flag("start_in_shell")) return {"/bin/sh", "-c", command};
  std::vector<std::string> argv;
  try {
    argv = split_words(command);
  } catch (const EvaluationError& e) {
    problem = "its command cannot be split into words: " + std::string(e.what());
    return {};
  }
  if (argv.empty()) {
    problem = "its command is empty";
    return {};
  }
  const std::string& program = argv.front();
  if (program.find('/') == std::string::npos) {
    if (!process.has_flag("use_execvpe"))
      problem = "command not found: '" + program +
                "' has no directory, and processes start without a PATH search (as in LN 2.9): give its path "
                "(for instance /usr/bin/" +
                program + "), or add the flag use_execvpe or start_in_shell";
    return argv;
  }
  const std::string path = program.front() == '/' ? program : process_directory(process) + "/" + program;
  if (::access(path.c_str(), F_OK) != 0)
    problem = "command not found: '" + program + "' does not exist";
  else if (::access(path.c_str(), X_OK) != 0)
    problem = "permission denied: '" + program + "' is not executable";
  return argv;
}

}  // namespace ln::manager
