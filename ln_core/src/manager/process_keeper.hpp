// --keep-processes: processes outlive the manager, and the next manager of
// the instance adopts them. A small keeper process (ln_manager
// --process-keeper) holds a copy of every process's output descriptor and
// pidfd from the start, so that neither a manager that stops nor one that
// dies (SIGKILL, a crash) hangs up their terminals. Once the manager is gone
// the keeper reads their output into bounded buffers and waits, on an
// abstract Unix socket of the instance, for the next manager, which takes
// the descriptors, the last output lines and what it needs to know of each
// process, and becomes its supervisor. Only the same user may adopt.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace ln::manager {

/// What a manager hands to the keeper and the keeper to the next manager.
struct KeptProcess {
  std::string name;
  pid_t pid = 0;                  ///< also its process group
  std::uint64_t start_ticks = 0;  ///< /proc/PID/stat starttime: tells a reused pid apart
  bool ready = false;
  int output_fd = -1;  ///< -1 once the output ended
  int pidfd = -1;
  std::vector<std::string> output;  ///< lines printed while no manager read them
  bool ended = false;               ///< it ended while the keeper held it
};

/// The manager's end of its keeper. Does nothing without a keeper command.
class KeeperLink {
 public:
  KeeperLink() = default;
  ~KeeperLink();
  KeeperLink(const KeeperLink&) = delete;
  KeeperLink& operator=(const KeeperLink&) = delete;

  /// Starts `argv` (ln_manager --process-keeper INSTANCE) with the link as
  /// its descriptor 3, in a session of its own. Returns the reason it could
  /// not ("" on success).
  std::string start(const std::vector<std::string>& argv);
  bool running() const { return fd_ >= 0; }
  pid_t pid() const { return pid_; }
  /// The keeper keeps copies of these descriptors (the caller keeps its own).
  void add(const KeptProcess& process);
  void remove(const std::string& name);

 private:
  int fd_ = -1;
  pid_t pid_ = 0;
};

/// The abstract socket the keeper of `instance` waits on for this user.
std::string keeper_socket_name(const std::string& instance);

/// Takes over what a keeper of `instance` holds (empty if there is none):
/// the processes that still run, with their descriptors and recent output.
/// Throws std::runtime_error with the reason when a keeper is there but the
/// hand-over fails.
std::vector<KeptProcess> adopt_from_keeper(const std::string& instance, double timeout_seconds);

/// The keeper's main: serves `link_fd` until the manager is gone, then
/// holds the processes until the next manager of `instance` adopts them (or
/// all have ended). Returns the exit status.
int run_process_keeper(int link_fd, const std::string& instance);

/// /proc/PID/stat's starttime (0 if the process does not exist).
std::uint64_t process_start_ticks(pid_t pid);

}  // namespace ln::manager
