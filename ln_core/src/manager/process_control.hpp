// The manager's process supervision: the processes, states and groups of
// the config (config.hpp), started in dependency order with readiness,
// stopped dependents first, restarted with back-off, their output kept in
// a bounded ring. Runs inside the manager's single-threaded loop: fd() is
// an epoll descriptor (children's exit pidfds, their output, one timer)
// that the loop watches; handle_events() does what became due and never
// blocks beyond a fork+exec.
//
// Lifecycle guarantees (docs/lnc.md has the whole story):
// * every process runs in its own session and process group; when it
//   ends, what is left of its group gets its term_signal and SIGKILL after
//   term_timeout;
// * with reap_orphans (the ln_manager daemon) the manager is a child
//   subreaper: descendants that left their group and lost their parent
//   become its children and are stopped the same way;
// * begin_shutdown() stops every process, dependents before what they
//   depend on; finished() tells when nothing runs any more;
// * if the manager dies without stopping them (SIGKILL), each process gets
//   its term_signal from the kernel (PR_SET_PDEATHSIG) unless
//   stop_with_manager is false;
// * with keep_processes, processes outlive the manager (stopped or dead)
//   and the next manager of the instance adopts them (process_keeper.hpp).
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "manager/config.hpp"
#include "manager/log.hpp"
#include "manager/process_output.hpp"

namespace ln::manager {

struct ProcessControlOptions {
  LogFunction log;
  /// LN_MANAGER for the processes ("IP:PORT").
  std::string manager_address;
  /// LN_MESSAGE_DEFINITION_DIRS for the processes: the manager's search path.
  std::vector<std::string> definition_dirs;
  /// Added to the processes' LD_LIBRARY_PATH (where libln.so is); "" = none.
  std::string library_dir;
  /// Processes get their term_signal when the manager dies (PDEATHSIG).
  bool stop_with_manager = true;
  /// Become a child subreaper and stop orphaned descendants. Only for a
  /// process that runs nothing but the manager: it reaps children it did
  /// not start.
  bool reap_orphans = false;
  /// Leave the processes running when the manager stops or dies, held by a
  /// keeper (process_keeper.hpp) started with `keeper_command`, for the next
  /// manager of `instance_name` to adopt.
  bool keep_processes = false;
  std::vector<std::string> keeper_command;
  /// Whose processes a keeper holds; a new ProcessControl adopts those of
  /// its instance that its config names.
  std::string instance_name;
};

/// One row of ProcessControl::status().
struct ObjectStatus {
  std::string name;
  std::string kind;       ///< "process", "state" or "group"
  std::string state;      ///< processes: stopped starting started ready stopping restarting failed;
                          ///< states: UP DOWN unknown checking "going up" "going down" error;
                          ///< groups: "N/M running"
  std::string requested;  ///< "start", "stop", "up", "down", "check" or ""
  std::int64_t pid = 0;   ///< 0 when not running
  double uptime = 0;      ///< seconds since it started (running processes)
  unsigned restarts = 0;  ///< automatic restarts so far
  bool ready = false;
  std::string last_exit;  ///< "exit status 3", "killed by SIGKILL", ""
  std::string error;      ///< why it failed or cannot start, ""
  std::string command;
  std::vector<std::string> depends_on;  ///< processes and states ("!" for DOWN)
  std::vector<std::string> members;     ///< groups
};

class ProcessControl {
 public:
  ProcessControl(const LncSettings& config, ProcessControlOptions options);
  /// Kills (SIGKILL) and reaps whatever still runs.
  ~ProcessControl();
  ProcessControl(const ProcessControl&) = delete;
  ProcessControl& operator=(const ProcessControl&) = delete;

  /// Readable when handle_events() has something to do.
  int fd() const;
  void handle_events();

  /// Whether a process, state or group has this name.
  bool knows(const std::string& name) const;
  /// What `ln process|state|group ACTION NAME` asks: start, stop, restart
  /// (processes and groups), up, down, check (states). `alt_command`
  /// selects a process's alt_command for this start ("" = its command).
  /// Throws RequestError (unknown name: LNE_INVALID_PARAMETER; refused:
  /// LNE_REQUEST_FAILED).
  void request(const std::string& name, const std::string& action, const std::string& alt_command = "");
  /// needs_provider: asks the highest-priority process or state that
  /// provides `what` to start (unless it runs); returns its name. Throws
  /// RequestError(LNE_NO_PROVIDER_FOUND) when none does.
  std::string start_provider(const std::string& what);
  /// The process or state `name`, when it failed, with why.
  std::string failure_of(const std::string& name) const;

  std::vector<ObjectStatus> status() const;
  /// Output lines of a process or state (see OutputRing::since).
  OutputRing::Slice output(const std::string& name, std::uint64_t after, std::size_t max) const;

  /// Stops everything: processes dependents first, state commands.
  void begin_shutdown();
  /// SIGKILL to everything that runs.
  void kill_all();
  /// After begin_shutdown(): nothing runs any more.
  bool finished() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ln::manager
