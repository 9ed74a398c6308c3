// The ln_manager as a library: a single-threaded epoll loop that serves the
// client protocol (protocol/methods.hpp) on one TCP socket. Topic and
// service data never pass through it; it only brokers who talks to whom.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "manager/config.hpp"
#include "manager/limits.hpp"
#include "manager/log.hpp"
#include "manager/process_control.hpp"

namespace ln::manager {

struct ManagerOptions {
  /// Loopback unless asked otherwise: reaching the manager from other hosts
  /// is an explicit choice ("0.0.0.0" or an interface address).
  std::string listen_host = "127.0.0.1";
  std::uint16_t port = 0;  ///< 0: an ephemeral port (see Manager::port())
  std::string instance_name = "ln_core";
  /// Searched first, in this order (the config's add_message_definition_dir).
  std::vector<std::string> message_definition_dirs;
  /// Where put_message_definition stores; "" = ~/ln_message_definitions/gen.
  std::string generated_definition_dir;
  ManagerLimits limits;
  LogFunction log;
  /// The processes, states and groups to supervise (process_control.hpp);
  /// none by default.
  std::shared_ptr<const LncSettings> system;
  /// Started (processes, groups) or brought up (states) once listening.
  std::vector<std::string> start;
  /// How they are supervised (stop_with_manager, reap_orphans,
  /// keep_processes, keeper_command, library_dir); the manager fills in the
  /// log, its address, the definition search path and the instance name.
  ProcessControlOptions process_options;
};

class Manager {
 public:
  explicit Manager(ManagerOptions options);
  /// Stops the loop (and joins run_in_thread's thread).
  ~Manager();
  Manager(const Manager&) = delete;
  Manager& operator=(const Manager&) = delete;

  /// Binds and listens. Throws std::runtime_error with the reason.
  void start();
  /// The bound port (after start()).
  std::uint16_t port() const;
  /// Serves until stop(). Call after start().
  void run();
  /// run() in a new thread.
  void run_in_thread();
  /// Ends run() soon; from any thread (also a signal-handling one), any
  /// number of times. Joins the thread of run_in_thread() unless called
  /// from it. With processes, run() first stops them (dependents first,
  /// term_signal, SIGKILL after term_timeout) while it keeps serving
  /// clients; a second stop() kills them at once.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ln::manager
