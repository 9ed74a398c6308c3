// ln_manager: the headless LN manager daemon of ln_core. Serves the client
// protocol until SIGTERM or SIGINT; the logic lives in the ln_manager_core
// library (src/manager), this file only reads the command line.
#include <dirent.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "manager/config.hpp"
#include "manager/definitions.hpp"
#include "manager/limits.hpp"
#include "manager/manager.hpp"
#include "manager/process_keeper.hpp"
#include "manager/process_launch.hpp"

namespace {

using namespace ln::manager;

constexpr std::uint16_t default_port = 54414;  // the port of LN's quickstart examples

const char* const usage_text = R"(usage: ln_manager [-c FILE.lnc] [--listen HOST:PORT | -p PORT] [-i NAME]
                  [--start NAME]... [--isolated-test] [--keep-processes]
                  [--log-level debug|info|warning|error] [--without-gui] [--LIMIT VALUE ...] [-h]

The ln_core manager: the rendezvous of an LN instance, and the supervisor
of its processes. Clients find it through LN_MANAGER=HOST:PORT or
--ln-manager HOST:PORT.

  -c FILE.lnc         read the instance configuration: the instance section
                      (name, manager, gen_message_definition_path), defines,
                      the directives (include, push_name_prefix, ...),
                      templates, and the process, state and group sections it
                      supervises (docs/lnc.md). What ln_core does not
                      implement (hosts, networks, GUI plugins...) is reported
                      once and ignored; a malformed file is an error naming the
                      file, the line and the cause.
  --listen HOST:PORT  where to accept clients. The manager listens on
                      127.0.0.1 (this host only) unless told otherwise here or by
                      a host in the config's "manager: HOST:PORT" line; an empty
                      host (":PORT") also means 127.0.0.1. Use 0.0.0.0 or an
                      interface address to let other hosts in: there is no
                      authentication, so only do that on a trusted network.
                      PORT 0 picks a free port.
  -p PORT             the port only (overrides the config's port). Without
                      --listen, -p or a config: 127.0.0.1:54414.
  -i NAME             the instance name (overrides the config's name once the
                      config is read: %(instance_name) in it, and a port
                      derived from that, stay the config's, as in LN 2.9)
  --start NAME        start this process or group (or bring this state up)
                      once listening, with what it depends on; repeatable
  --isolated-test     a random instance name and a free port (PORT 0), for
                      tests that must not meet another manager
  --keep-processes    leave the processes running when the manager stops (or
                      dies); a manager started later with the same instance
                      name adopts them (docs/lnc.md)
  --check             read the config, print what each process would run (its
                      command line and environment), its dependencies, and the
                      states and groups, then exit: 0 if everything could start,
                      1 if something could not (the reason is printed), 2 for a
                      bad config
  --log-level LEVEL   what to log to stderr: debug, info (default), warning, error
  --without-gui       accepted for LN compatibility; there is no GUI
  -h, --help          this text

Limits (also keys of the config's instance section, e.g. "max_topic_shm: 64M";
an option overrides the config). BYTES take K, M or G (powers of 1024):
%LIMITS%

Message definitions are searched in the config's add_message_definition_dir
directories, then the built-in ones, ~/ln_message_definitions and
$LN_MESSAGE_DEFINITION_DIRS. On start-up the manager prints
"ln_manager: listening on HOST:PORT". SIGTERM, SIGINT or SIGHUP (its
terminal hung up) stop it: first its processes, dependents before what they
depend on (term_signal, SIGKILL after term_timeout); a second signal kills
them at once. Exit status: 0 after such a signal, 2 for a bad command line or
config, 1 when it cannot listen.
)";

[[noreturn]] void usage_error(const std::string& problem) {
  std::cerr << "ln_manager: " << problem << "\n(ln_manager -h shows the options)\n";
  std::exit(2);
}

std::string option_of(const std::string& key) {
  std::string option = "--" + key;
  for (char& c : option)
    if (c == '_') c = '-';
  return option;
}

std::string usage() {
  std::string limits;
  for (const LimitInfo& limit : limit_table()) {
    std::string head = "  " + option_of(limit.key) + " " + limit.value_text;
    head.resize(std::max<std::size_t>(head.size() + 1, 40), ' ');
    limits += head + limit.description + " (default " + limit.default_text + ")\n";
  }
  std::string text = usage_text;
  text.replace(text.find("%LIMITS%\n"), 9, limits);
  return text;
}

std::optional<LogLevel> parse_level(const std::string& text) {
  if (text == "debug") return LogLevel::Debug;
  if (text == "info") return LogLevel::Info;
  if (text == "warning") return LogLevel::Warning;
  if (text == "error") return LogLevel::Error;
  return std::nullopt;
}

std::uint16_t parse_port(const std::string& text) {
  try {
    return split_host_port(":" + text).second;
  } catch (const std::invalid_argument&) {
    usage_error("'" + text + "' is not a port number (0..65535)");
  }
}

// Many clients, each with a connection: use all the descriptors we may.
void raise_file_limit() {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur < limit.rlim_max) {
    limit.rlim_cur = limit.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &limit);
  }
}

// Where ln_core is installed (PREFIX/bin/ln_manager), for LN's built-in
// defines (LN_PREFIX, LN_LD_LIBRARY_PATH, ...) and the processes'
// LD_LIBRARY_PATH.
std::string install_prefix() {
  char exe[PATH_MAX] = "";
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) return "";
  std::string path(exe, static_cast<std::size_t>(n));
  for (int up = 0; up < 2; ++up) path = path.substr(0, std::max<std::size_t>(path.rfind('/'), 1));
  return path;
}

bool exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

std::string find_in_path(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  for (std::size_t start = 0; start <= dirs.size();) {
    const std::size_t colon = std::min(dirs.find(':', start), dirs.size());
    const std::string candidate = dirs.substr(start, colon - start) + "/" + program;
    start = colon + 1;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return program;
}

// The config is read with its own instance name, as LN 2.9 reads it: -i and
// --isolated-test rename the instance afterwards, so %(instance_name) and
// what derives from it (a port) stay as the config says.
LncContext config_context(const std::string& prefix) {
  LncContext context;
  auto& defines = context.builtin_defines;
  defines["LN_PREFIX"] = prefix;
  defines["LN_BASE_MANAGER"] = prefix;
  defines["LN_SHARE_DIR"] = prefix + "/share";
  defines["LN_LD_LIBRARY_PATH"] = prefix + "/lib";
  defines["LN_PYTHON"] = find_in_path("python3");
  std::string python_path;
  if (DIR* lib = ::opendir((prefix + "/lib").c_str())) {
    while (const dirent* entry = ::readdir(lib)) {
      const std::string site = prefix + "/lib/" + entry->d_name + "/site-packages";
      if (std::string(entry->d_name).rfind("python", 0) == 0 && exists(site + "/links_and_nodes"))
        python_path += (python_path.empty() ? "" : ":") + site;
    }
    ::closedir(lib);
  }
  defines["LN_PYTHONPATH"] = python_path;
  return context;
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

std::string joined(const std::vector<Dependency>& list) {
  std::string out;
  for (const auto& dependency : list) {
    std::string alternatives;
    for (const auto& candidate : dependency.candidates) alternatives += (alternatives.empty() ? "" : "|") + candidate;
    out += (out.empty() ? "" : ", ") + std::string(dependency.down ? "!" : "") + alternatives;
  }
  return out;
}

// --check: what the manager would run, without running anything.
int print_check(const ManagerOptions& options) {
  const LncSettings empty;
  const LncSettings& system = options.system ? *options.system : empty;
  const char* home = std::getenv("HOME");
  const DefinitionStore definitions(options.message_definition_dirs,
                                    !options.generated_definition_dir.empty()
                                        ? options.generated_definition_dir
                                        : std::string(home && *home ? home : "/tmp") + "/ln_message_definitions/gen",
                                    options.limits);
  const std::string host = options.listen_host == "0.0.0.0" ? "127.0.0.1" : options.listen_host;
  const LaunchContext context{host + ":" + std::to_string(options.port), definitions.search_dirs(),
                              options.process_options.library_dir};
  int status = 0;
  std::printf("instance %s, manager at %s\n", options.instance_name.c_str(), context.manager_address.c_str());
  for (const ProcessConfig& p : system.processes) {
    std::printf("\nprocess %s (%s)\n", p.name.c_str(), p.place.text().c_str());
    std::string problem;
    if (!p.remote_host.empty())
      problem = "runs on host '" + p.remote_host + "', not this one";
    else if (p.command.empty())
      problem = "has no command";
    else
      process_argv(p, p.command, problem);
    std::printf("  command: %s\n", p.command.empty() ? "(none)" : p.command.c_str());
    for (const auto& [name, command] : p.alt_commands)
      std::printf("  alt_command %s: %s\n", name.c_str(), command.c_str());
    for (const auto& entry : process_environment(p, context)) std::printf("  env %s\n", entry.c_str());
    std::printf("  directory: %s\n", process_directory(p).c_str());
    if (!p.depends_on.empty()) std::printf("  depends_on: %s\n", joined(p.depends_on).c_str());
    if (!p.depends_on_restart.empty()) std::printf("  depends_on_restart: %s\n", joined(p.depends_on_restart).c_str());
    if (!p.start_before.empty()) std::printf("  start_before: %s\n", joined(p.start_before).c_str());
    if (!p.start_on_ready.empty()) std::printf("  start_on_ready: %s\n", joined(p.start_on_ready).c_str());
    if (!p.start_on_successful_stop.empty())
      std::printf("  start_on_successful_stop: %s\n", joined(p.start_on_successful_stop).c_str());
    if (!p.provides.empty()) {
      std::string provides;
      for (const auto& [name, priority] : p.provides) {
        char priority_text[32];
        std::snprintf(priority_text, sizeof priority_text, ":%g", priority);
        provides += (provides.empty() ? "" : ", ") + name + (priority != 0 ? priority_text : "");
      }
      std::printf("  provides: %s\n", provides.c_str());
    }
    if (!p.flags.empty()) std::printf("  flags: %s\n", joined(p.flags).c_str());
    if (!problem.empty()) {
      std::printf("  cannot start: %s\n", problem.c_str());
      status = 1;
    }
  }
  for (const StateConfig& s : system.states)
    std::printf("\nstate %s (%s)\n  check: %s\n  up: %s\n  down: %s\n", s.name.c_str(), s.place.text().c_str(),
                s.check.c_str(), s.up.c_str(), s.down.c_str());
  for (const GroupConfig& g : system.groups) std::printf("\ngroup %s: %s\n", g.name.c_str(), joined(g.members).c_str());
  return status;
}

// Waits for SIGTERM/SIGINT/SIGHUP (blocked in every thread) and stops the
// manager; a second signal stops it again (which kills the processes).
struct SignalWaiter {
  const sigset_t* signals;
  Manager* manager;
  const LogFunction* log;
  std::atomic<bool> finished{false};
  std::atomic<int> received_count{0};

  static void* main(void* self_pointer) {
    auto& self = *static_cast<SignalWaiter*>(self_pointer);
    for (;;) {
      int received = 0;
      sigwait(self.signals, &received);
      if (self.finished.load()) return nullptr;
      const std::string name = received == SIGINT ? "SIGINT" : received == SIGHUP ? "SIGHUP" : "SIGTERM";
      if (self.received_count.fetch_add(1) == 0)
        (*self.log)(LogLevel::Info, "received " + name);
      else
        (*self.log)(LogLevel::Warning, "received " + name + " again");
      self.manager->stop();
    }
  }
};

}  // namespace

int main(int argc, char** argv) {
  // The keeper of --keep-processes (process_keeper.hpp), started by a
  // manager with its link as descriptor 3: not for people to run.
  if (argc == 3 && std::string(argv[1]) == "--process-keeper") {
    ::signal(SIGINT, SIG_IGN);  // a Ctrl-C in the terminal is for the manager
    ::signal(SIGPIPE, SIG_IGN);
    return run_process_keeper(3, argv[2]);
  }
  std::string config_file, instance_name, listen;
  std::optional<std::uint16_t> port_override;
  std::vector<std::string> start;
  bool isolated_test = false, keep_processes = false, check = false;
  std::vector<std::pair<std::string, std::string>> limit_options;  // applied over the config's
  LogLevel threshold = LogLevel::Info;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage_error(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "-h" || arg == "--help") {
      std::cout << usage();
      return 0;
    } else if (arg == "-c") {
      config_file = value();
    } else if (arg == "--listen") {
      listen = value();
    } else if (arg == "-p") {
      port_override = parse_port(value());
    } else if (arg == "-i") {
      instance_name = value();
    } else if (arg == "--start") {
      start.push_back(value());
    } else if (arg == "--isolated-test") {
      isolated_test = true;
    } else if (arg == "--keep-processes") {
      keep_processes = true;
    } else if (arg == "--check") {
      check = true;
    } else if (arg == "--log-level") {
      const std::string text = value();
      const auto level = parse_level(text);
      if (!level) usage_error("unknown log level '" + text + "'");
      threshold = *level;
    } else if (arg == "--without-gui") {
      // LN's manager needs it to run headless; this one always is.
    } else if (const auto limit = std::find_if(limit_table().begin(), limit_table().end(),
                                               [&](const LimitInfo& l) { return option_of(l.key) == arg; });
               limit != limit_table().end()) {
      limit_options.emplace_back(limit->key, value());
    } else {
      usage_error("unknown or unsupported option '" + arg + "'");
    }
  }
  if (!listen.empty() && port_override) usage_error("use either --listen HOST:PORT or -p PORT");
  if (isolated_test && (!listen.empty() || port_override))
    usage_error("--isolated-test picks a free port itself; leave out --listen and -p");
  if (isolated_test && instance_name.empty()) {
    std::random_device random;
    instance_name = "isolated_test_" + std::to_string(::getpid()) + "_" + std::to_string(random() % 100000);
  }

  const LogFunction log = [threshold](LogLevel level, const std::string& text) {
    if (level >= threshold) std::fprintf(stderr, "ln_manager: %s: %s\n", level_name(level), text.c_str());
  };

  const std::string prefix = install_prefix();
  ManagerOptions options;
  options.log = log;
  options.port = default_port;
  if (!config_file.empty()) {
    try {
      auto settings = std::make_shared<LncSettings>(read_lnc_file(config_file, log, config_context(prefix)));
      if (!settings->instance_name.empty()) options.instance_name = settings->instance_name;
      if (settings->manager_host && !settings->manager_host->empty()) options.listen_host = *settings->manager_host;
      if (settings->manager_port) options.port = *settings->manager_port;
      options.message_definition_dirs = settings->message_definition_dirs;
      options.generated_definition_dir = settings->generated_definition_dir;
      options.system = settings;
      options.limits = settings->limits;
    } catch (const ConfigError& e) {
      std::cerr << "ln_manager: " << e.what() << "\n";
      return 2;
    }
  }
  for (const auto& name : start) {
    const LncSettings* system = options.system.get();
    const auto named = [&](const auto& list) {
      return std::any_of(list.begin(), list.end(), [&](const auto& item) { return item.name == name; });
    };
    if (!system || !(named(system->processes) || named(system->states) || named(system->groups)))
      usage_error("--start " + name + ": the config has no process, state or group of that name");
  }
  options.start = start;
  for (const auto& [key, text] : limit_options) {
    try {
      set_limit(options.limits, key, text);
    } catch (const std::invalid_argument& e) {
      usage_error(e.what());
    }
  }
  if (!instance_name.empty()) options.instance_name = instance_name;
  if (port_override) options.port = *port_override;
  if (isolated_test) options.port = 0;
  if (!listen.empty()) {
    try {
      const auto [host, port] = split_host_port(listen);
      options.listen_host = host.empty() ? "127.0.0.1" : host;
      options.port = port;
    } catch (const std::invalid_argument& e) {
      usage_error(std::string("--listen: ") + e.what());
    }
  }
  if (exists(prefix + "/lib/libln.so")) options.process_options.library_dir = prefix + "/lib";
  if (check) return print_check(options);
  ProcessControlOptions& processes = options.process_options;
  processes.reap_orphans = true;  // this program runs nothing but the manager
  processes.stop_with_manager = !keep_processes;
  processes.keep_processes = keep_processes;
  char exe[PATH_MAX] = "";
  if (const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1); n > 0)
    processes.keeper_command = {std::string(exe, static_cast<std::size_t>(n)), "--process-keeper",
                                options.instance_name};

  // Signals are taken by sigwait() below, never by a handler that
  // interrupts the manager's thread.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGHUP);  // a terminal that hangs up stops it in order too
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  raise_file_limit();

  try {
    Manager manager(options);
    manager.start();
    std::printf("ln_manager: listening on %s:%u\n", options.listen_host.c_str(), static_cast<unsigned>(manager.port()));
    std::fflush(stdout);
    SignalWaiter waiter{&stop_signals, &manager, &log};
    // A plain POSIX thread: the sanitizer build's vptr check of a
    // std::thread's state, run while the thread ends, raced with the
    // manager's own shutdown and reported objects that were intact.
    pthread_t signal_thread;
    if (pthread_create(&signal_thread, nullptr, &SignalWaiter::main, &waiter) != 0)
      throw std::runtime_error("cannot start the signal-waiting thread");
    manager.run();
    // run() also ends on a fatal loop error: then wake the waiter ourselves.
    waiter.finished.store(true);
    pthread_kill(signal_thread, SIGTERM);
    pthread_join(signal_thread, nullptr);
    return waiter.received_count.load() > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "ln_manager: " << e.what() << "\n";
    return 1;
  }
}
