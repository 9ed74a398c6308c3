// Starting one child process for the manager without blocking its loop for
// longer than fork+exec: its own session and process group (so that it and
// everything it starts can be signalled as one), output through a pty or a
// pipe, the scheduling and limits a .lnc asks for, and a pidfd that becomes
// readable when it ends. Failures before exec (command not found, no
// permission, no such directory) come back as SpawnError with the reason.
#pragma once

#include <sys/types.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "manager/config.hpp"

namespace ln::manager {

class SpawnError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SpawnRequest {
  std::vector<std::string> argv;         ///< argv[0]: the program (a path unless search_path)
  bool search_path = false;              ///< look argv[0] up in the child's PATH (execvpe)
  std::vector<std::string> environment;  ///< "NAME=VALUE", the whole environment
  std::string directory;                 ///< "" = the manager's
  bool pty = true;                       ///< else a pipe; stdin is /dev/null then
  int policy = -1;                       ///< SCHED_*; -1 = inherit
  int priority = 0;
  std::vector<int> affinity;
  std::optional<int> nice;
  std::vector<ResourceLimit> limits;
  /// Sent to the child when the manager dies (PR_SET_PDEATHSIG); 0 = none.
  int death_signal = 0;
  /// Becomes the child's descriptor 3 (-1: none).
  int extra_fd = -1;
  /// stdout and stderr go to /dev/null (no output descriptor).
  bool discard_output = false;
  /// A program the manager runs for itself (not one of its configuration's
  /// processes, e.g. manager_save's MCAP converter): is_helper_child() knows
  /// it from the moment it exists until forget_helper_child(), so that the
  /// orphan sweep leaves it alone.
  bool helper = false;
};

struct SpawnedChild {
  pid_t pid = -1;      ///< also its process group and session id
  int pidfd = -1;      ///< readable once it ended; the caller closes it
  int output_fd = -1;  ///< non-blocking; pty master or pipe; the caller closes it
  /// What could not be applied but did not stop the start (a real-time
  /// policy without the privilege, ...), one sentence each.
  std::vector<std::string> warnings;
};

/// Forks and executes. Throws SpawnError.
SpawnedChild spawn_child(const SpawnRequest& request);

/// How a child ended, in words: "exit status 3", "killed by SIGKILL",
/// "killed by SIGSEGV (core dumped)".
std::string describe_exit(int code, int status);

enum class Reaped {
  Running,
  Ended,   ///< code/status as in siginfo_t (CLD_EXITED: exit status, else the signal)
  Unknown  ///< it ended, but it is not our child (adopted): no status
};
/// waitid() for the child behind `pidfd` without blocking.
Reaped reap_child(int pidfd, pid_t pid, int& code, int& status);

/// Whether `pid` is a child spawned with SpawnRequest::helper and not forgotten yet.
bool is_helper_child(pid_t pid);
/// The helper child `pid` was reaped.
void forget_helper_child(pid_t pid);

/// Whether any process of process group `group` still runs (zombies do not
/// count).
bool process_group_alive(pid_t group);

/// PIDs of the calling process's children (all threads'), from /proc.
std::vector<pid_t> list_children();

}  // namespace ln::manager
