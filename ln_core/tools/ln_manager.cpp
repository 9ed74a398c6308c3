// ln_manager: the headless LN manager daemon of ln_core. Serves the client
// protocol until SIGTERM or SIGINT; the logic lives in the ln_manager_core
// library (src/manager), this file only reads the command line.
#include <pthread.h>
#include <signal.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "manager/config.hpp"
#include "manager/limits.hpp"
#include "manager/manager.hpp"

namespace {

using namespace ln::manager;

constexpr std::uint16_t default_port = 54414;  // the port of LN's quickstart examples

const char* const usage_text = R"(usage: ln_manager [-c FILE.lnc] [--listen HOST:PORT | -p PORT] [-i NAME]
                  [--log-level debug|info|warning|error] [--without-gui] [--LIMIT VALUE ...] [-h]

The ln_core manager: the rendezvous of an LN instance. Clients find it
through LN_MANAGER=HOST:PORT or --ln-manager HOST:PORT.

  -c FILE.lnc         read the instance configuration. Used from it: the
                      instance section (name, manager, gen_message_definition_path),
                      defines, include, add_message_definition_dir; everything
                      else (processes, states, groups, hosts...) is reported once
                      and ignored.
  --listen HOST:PORT  where to accept clients. The manager listens on
                      127.0.0.1 (this host only) unless told otherwise here or by
                      a host in the config's "manager: HOST:PORT" line; an empty
                      host (":PORT") also means 127.0.0.1. Use 0.0.0.0 or an
                      interface address to let other hosts in: there is no
                      authentication, so only do that on a trusted network.
                      PORT 0 picks a free port.
  -p PORT             the port only (overrides the config's port). Without
                      --listen, -p or a config: 127.0.0.1:54414.
  -i NAME             the instance name (overrides the config's name)
  --log-level LEVEL   what to log to stderr: debug, info (default), warning, error
  --without-gui       accepted for LN compatibility; there is no GUI
  -h, --help          this text

Limits (also keys of the config's instance section, e.g. "max_topic_shm: 64M";
an option overrides the config). BYTES take K, M or G (powers of 1024):
%LIMITS%

Message definitions are searched in the config's add_message_definition_dir
directories, then the built-in ones, ~/ln_message_definitions and
$LN_MESSAGE_DEFINITION_DIRS. On start-up the manager prints
"ln_manager: listening on HOST:PORT". Exit status: 0 after SIGTERM/SIGINT,
2 for a bad command line or config, 1 when it cannot listen.
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

// Waits for SIGTERM/SIGINT (blocked in every thread) and stops the manager.
struct SignalWaiter {
  const sigset_t* signals;
  Manager* manager;
  const LogFunction* log;
  std::atomic<bool> stopped_by_signal{false};

  static void* main(void* self_pointer) {
    auto& self = *static_cast<SignalWaiter*>(self_pointer);
    int received = 0;
    sigwait(self.signals, &received);
    if (!self.stopped_by_signal.exchange(true) && received != 0)
      (*self.log)(LogLevel::Info, std::string("received ") + (received == SIGINT ? "SIGINT" : "SIGTERM"));
    self.manager->stop();
    return nullptr;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string config_file, instance_name, listen;
  std::optional<std::uint16_t> port_override;
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

  const LogFunction log = [threshold](LogLevel level, const std::string& text) {
    if (level >= threshold) std::fprintf(stderr, "ln_manager: %s: %s\n", level_name(level), text.c_str());
  };

  ManagerOptions options;
  options.log = log;
  options.port = default_port;
  if (!config_file.empty()) {
    try {
      const LncSettings settings = read_lnc_file(config_file, log, instance_name);
      if (!settings.instance_name.empty()) options.instance_name = settings.instance_name;
      if (settings.manager_host && !settings.manager_host->empty()) options.listen_host = *settings.manager_host;
      if (settings.manager_port) options.port = *settings.manager_port;
      options.message_definition_dirs = settings.message_definition_dirs;
      options.generated_definition_dir = settings.generated_definition_dir;
      options.limits = settings.limits;
    } catch (const ConfigError& e) {
      std::cerr << "ln_manager: " << e.what() << "\n";
      return 2;
    }
  }
  for (const auto& [key, text] : limit_options) {
    try {
      set_limit(options.limits, key, text);
    } catch (const std::invalid_argument& e) {
      usage_error(e.what());
    }
  }
  if (!instance_name.empty()) options.instance_name = instance_name;
  if (port_override) options.port = *port_override;
  if (!listen.empty()) {
    try {
      const auto [host, port] = split_host_port(listen);
      options.listen_host = host.empty() ? "127.0.0.1" : host;
      options.port = port;
    } catch (const std::invalid_argument& e) {
      usage_error(std::string("--listen: ") + e.what());
    }
  }

  // Signals are taken by sigwait() below, never by a handler that
  // interrupts the manager's thread.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
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
    const bool clean = waiter.stopped_by_signal.exchange(true);
    pthread_kill(signal_thread, SIGTERM);
    pthread_join(signal_thread, nullptr);
    return clean ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "ln_manager: " << e.what() << "\n";
    return 1;
  }
}
