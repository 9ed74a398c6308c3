#include "manager/child_process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>

#ifndef CLOSE_RANGE_CLOEXEC
#define CLOSE_RANGE_CLOEXEC (1U << 2)
#endif

namespace ln::manager {
namespace {

// Helper children, held while forking one so that no one sees its PID before it is here.
std::mutex helpers_mutex;
std::set<pid_t> helpers;

// What the child reports through its status pipe before exec: which step
// went wrong and errno. Fatal ones end the child; the others are warnings.
enum Step : int { Session, Terminal, Directory, Limit, Nice, Scheduling, Affinity, Exec };
struct Report {
  char fatal;
  int step;
  int error;
};

std::string step_text(int step) {
  switch (step) {
    case Session:
      return "cannot create its session";
    case Terminal:
      return "cannot open its terminal";
    case Directory:
      return "cannot change to its directory";
    case Limit:
      return "cannot set a resource limit";
    case Nice:
      return "cannot set its nice value";
    case Scheduling:
      return "cannot set its scheduling policy/priority";
    case Affinity:
      return "cannot set its CPU affinity";
    default:
      return "cannot execute its command";
  }
}

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() { reset(); }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  int release() {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  void reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_ = -1;
};

// The child between fork and exec: async-signal-safe calls only.
[[noreturn]] void run_child(const SpawnRequest& request, char* const* argv, char* const* envp, const char* slave_name,
                            int null_fd, int output_write_fd, int status_fd, pid_t parent) {
  // status_fd may move (see extra_fd); report() uses its current value
  auto report = [&status_fd](bool fatal, int step) {
    const Report r{fatal ? 'E' : 'W', step, errno};
    (void)!::write(status_fd, &r, sizeof r);
    if (fatal) ::_exit(127);
  };
  // The manager blocks SIGTERM/SIGINT and ignores SIGPIPE; a child must not
  // inherit that.
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  for (int signal = 1; signal < NSIG; ++signal)
    if (signal != SIGKILL && signal != SIGSTOP) ::signal(signal, SIG_DFL);

  if (::setsid() < 0) report(true, Session);
  if (request.death_signal != 0) {
    ::prctl(PR_SET_PDEATHSIG, request.death_signal);
    if (::getppid() != parent) ::raise(request.death_signal);  // the manager died before prctl
  }
  if (slave_name != nullptr) {
    const int slave = ::open(slave_name, O_RDWR);  // the first terminal a session leader opens is its own
    if (slave < 0) report(true, Terminal);
    ::ioctl(slave, TIOCSCTTY, 0);
    ::dup2(slave, 0);
    ::dup2(slave, 1);
    ::dup2(slave, 2);
    if (slave > 2) ::close(slave);
  } else {
    ::dup2(null_fd, 0);
    ::dup2(request.discard_output ? null_fd : output_write_fd, 1);
    ::dup2(request.discard_output ? null_fd : output_write_fd, 2);
  }
  int first_closed = 3;
  if (request.extra_fd >= 0) {
    if (status_fd == 3) status_fd = ::fcntl(status_fd, F_DUPFD_CLOEXEC, 4);
    if (request.extra_fd == 3)
      ::fcntl(3, F_SETFD, 0);
    else
      ::dup2(request.extra_fd, 3);
    first_closed = 4;
  }
  if (!request.directory.empty() && ::chdir(request.directory.c_str()) != 0) report(true, Directory);
  for (const ResourceLimit& limit : request.limits) {
    rlimit value{};
    value.rlim_cur = value.rlim_max = limit.value < 0 ? RLIM_INFINITY : static_cast<rlim_t>(limit.value);
    if (::setrlimit(limit.resource, &value) != 0) {
      rlimit current{};  // without the privilege to raise the hard limit, at least the soft one
      if (::getrlimit(limit.resource, &current) == 0) {
        value.rlim_max = current.rlim_max;
        if (value.rlim_cur > current.rlim_max) value.rlim_cur = current.rlim_max;
      }
      if (::setrlimit(limit.resource, &value) != 0 || value.rlim_cur != value.rlim_max) report(false, Limit);
    }
  }
  if (request.nice && ::setpriority(PRIO_PROCESS, 0, *request.nice) != 0) report(false, Nice);
  if (request.policy >= 0) {
    sched_param param{};
    param.sched_priority = request.priority;
    if (::sched_setscheduler(0, request.policy, &param) != 0) report(false, Scheduling);
  }
  if (!request.affinity.empty()) {
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int cpu : request.affinity)
      if (cpu >= 0 && cpu < CPU_SETSIZE) CPU_SET(cpu, &set);
    if (::sched_setaffinity(0, sizeof set, &set) != 0) report(false, Affinity);
  }
  // Nothing of the manager's leaks into the program (the status pipe closes
  // at exec, which tells the manager that exec worked).
  if (::syscall(SYS_close_range, static_cast<unsigned>(first_closed), ~0u, CLOSE_RANGE_CLOEXEC) != 0)
    for (int fd = first_closed; fd < 65536; ++fd) ::fcntl(fd, F_SETFD, FD_CLOEXEC);
  ::execve(argv[0], argv, envp);
  report(true, Exec);
  ::_exit(127);
}

}  // namespace

// argv[0] found in the PATH of `environment` (as a shell would), or "".
std::string search_path(const std::string& program, const std::vector<std::string>& environment) {
  std::string path = "/usr/local/bin:/usr/bin:/bin";
  for (const auto& entry : environment)
    if (entry.rfind("PATH=", 0) == 0) path = entry.substr(5);
  for (std::size_t start = 0; start <= path.size();) {
    const std::size_t colon = std::min(path.find(':', start), path.size());
    std::string dir = path.substr(start, colon - start);
    start = colon + 1;
    const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/" + program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

SpawnedChild spawn_child(const SpawnRequest& request) {
  if (request.argv.empty() || request.argv.front().empty()) throw SpawnError("the command is empty");
  // Everything the child uses is prepared before fork.
  std::vector<std::string> argv_storage = request.argv;
  if (request.search_path && argv_storage[0].find('/') == std::string::npos) {
    const std::string found = search_path(argv_storage[0], request.environment);
    if (found.empty())
      throw SpawnError("'" + argv_storage[0] + "' is not found in the process's PATH (command not found)");
    argv_storage[0] = found;
  }
  std::vector<char*> argv;
  for (auto& arg : argv_storage) argv.push_back(arg.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_storage = request.environment;
  std::vector<char*> envp;
  for (auto& entry : env_storage) envp.push_back(entry.data());
  envp.push_back(nullptr);

  Fd master, output_read, output_write, null_fd;
  char slave_name[128] = "";
  if (request.pty) {
    master.reset(::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC));
    if (master.get() < 0 || ::grantpt(master.get()) != 0 || ::unlockpt(master.get()) != 0 ||
        ::ptsname_r(master.get(), slave_name, sizeof slave_name) != 0)
      throw SpawnError(errno_text("cannot create a pseudo-terminal"));
    winsize size{};
    size.ws_row = 24;
    size.ws_col = 160;
    ::ioctl(master.get(), TIOCSWINSZ, &size);
  } else if (request.discard_output) {
    null_fd.reset(::open("/dev/null", O_RDWR | O_CLOEXEC));
  } else {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw SpawnError(errno_text("cannot create the output pipe"));
    output_read.reset(fds[0]);
    output_write.reset(fds[1]);
    null_fd.reset(::open("/dev/null", O_RDONLY | O_CLOEXEC));
  }
  int status_fds[2];
  if (::pipe2(status_fds, O_CLOEXEC) != 0) throw SpawnError(errno_text("cannot create the status pipe"));
  Fd status_read(status_fds[0]), status_write(status_fds[1]);

  const pid_t parent = ::getpid();
  std::unique_lock<std::mutex> helpers_lock(helpers_mutex, std::defer_lock);
  if (request.helper) helpers_lock.lock();
  const pid_t pid = ::fork();
  if (pid < 0) throw SpawnError(errno_text("fork failed"));
  if (pid == 0)
    run_child(request, argv.data(), envp.data(), request.pty ? slave_name : nullptr, null_fd.get(), output_write.get(),
              status_write.get(), parent);
  if (request.helper) {
    helpers.insert(pid);
    helpers_lock.unlock();
  }
  status_write.reset();
  output_write.reset();

  // The child writes reports and closes the pipe at exec (or exits): read
  // until then. It only makes a few system calls first, so this is short.
  SpawnedChild child;
  child.pid = pid;
  std::string fatal;
  for (;;) {
    Report report{};
    const ssize_t n = ::read(status_read.get(), &report, sizeof report);
    if (n < 0 && errno == EINTR) continue;
    if (n != static_cast<ssize_t>(sizeof report)) break;
    const std::string text = step_text(report.step) + ": " + std::strerror(report.error);
    if (report.fatal == 'E')
      fatal = text;
    else
      child.warnings.push_back(text);
  }
  if (!fatal.empty()) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    forget_helper_child(pid);
    throw SpawnError(fatal);
  }
  child.pidfd = static_cast<int>(::syscall(SYS_pidfd_open, pid, 0));
  if (child.pidfd < 0) {
    const std::string reason = errno_text("pidfd_open failed");
    ::kill(-pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    forget_helper_child(pid);
    throw SpawnError(reason);
  }
  ::fcntl(child.pidfd, F_SETFD, FD_CLOEXEC);
  const int output = request.pty ? master.release() : output_read.release();
  if (output >= 0) ::fcntl(output, F_SETFL, ::fcntl(output, F_GETFL) | O_NONBLOCK);
  child.output_fd = output;
  return child;
}

Reaped reap_child(int pidfd, pid_t pid, int& code, int& status) {
  siginfo_t info{};
  int result = ::waitid(P_PIDFD, static_cast<id_t>(pidfd), &info, WEXITED | WNOHANG);
  if (result != 0 && errno == EINVAL) result = ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG);
  if (result != 0) {
    if (errno != ECHILD) return Reaped::Running;
    // Not our child: it is gone once its pidfd is readable.
    pollfd p{pidfd, POLLIN, 0};
    return ::poll(&p, 1, 0) == 1 ? Reaped::Unknown : Reaped::Running;
  }
  if (info.si_pid == 0) return Reaped::Running;
  code = info.si_code;
  status = info.si_status;
  return Reaped::Ended;
}

std::string describe_exit(int code, int status) {
  if (code == CLD_EXITED) return "exit status " + std::to_string(status);
  return "killed by " + signal_name(status) + (code == CLD_DUMPED ? " (core dumped)" : "");
}

bool is_helper_child(pid_t pid) {
  std::lock_guard<std::mutex> lock(helpers_mutex);
  return helpers.count(pid) != 0;
}

void forget_helper_child(pid_t pid) {
  std::lock_guard<std::mutex> lock(helpers_mutex);
  helpers.erase(pid);
}

bool process_group_alive(pid_t group) {
  if (group <= 0 || (::kill(-group, 0) != 0 && errno != EPERM)) return false;
  // Zombies count for kill(): look for a member that still runs (an init
  // that does not reap would otherwise keep a dead group "alive").
  DIR* proc = ::opendir("/proc");
  if (proc == nullptr) return true;
  bool running = false;
  while (const dirent* entry = ::readdir(proc)) {
    if (entry->d_name[0] < '0' || entry->d_name[0] > '9') continue;
    std::ifstream in(std::string("/proc/") + entry->d_name + "/stat");
    std::string stat;
    std::getline(in, stat);
    const auto close = stat.rfind(')');  // the command may contain spaces and parentheses
    if (close == std::string::npos) continue;
    std::istringstream fields(stat.substr(close + 1));
    char state = 0;
    long parent = 0, process_group = 0;
    if (fields >> state >> parent >> process_group && process_group == group && state != 'Z' && state != 'X') {
      running = true;
      break;
    }
  }
  ::closedir(proc);
  return running;
}

std::vector<pid_t> list_children() {
  std::vector<pid_t> children;
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return children;
  while (const dirent* task = ::readdir(tasks)) {
    if (task->d_name[0] == '.') continue;
    std::ifstream in(std::string("/proc/self/task/") + task->d_name + "/children");
    pid_t pid = 0;
    while (in >> pid) children.push_back(pid);
  }
  ::closedir(tasks);
  return children;
}

}  // namespace ln::manager
