#include "manager/mcap_converter.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "manager/child_process.hpp"
#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

using Clock = std::chrono::steady_clock;

/// What of the converter's output goes into an error message, at most.
constexpr std::size_t kMessageTail = 2000;
constexpr std::size_t kOutputKept = 16384;

[[noreturn]] void fail(const McapConversion& conversion, const std::string& why) {
  throw RequestError(LNE_REQUEST_FAILED, "cannot write '" + conversion.target + "' as MCAP: " + why);
}

bool is_script(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  char head[2] = {};
  const ssize_t n = ::read(fd, head, sizeof head);
  ::close(fd);
  return n == 2 && head[0] == '#' && head[1] == '!';
}

/// Reads what is there (non-blocking descriptor); false at the end of the output.
bool read_available(int fd, std::string& output) {
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n > 0) {
      output.append(buffer, static_cast<std::size_t>(n));
      if (output.size() > kOutputKept) output.erase(0, output.size() - kOutputKept);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);
  }
}

/// The converter's output as one trimmed text, its end where it is long.
std::string message_of(std::string output) {
  const auto first = output.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "(it printed nothing)";
  output = output.substr(first, output.find_last_not_of(" \t\r\n") - first + 1);
  if (output.size() > kMessageTail) output = "..." + output.substr(output.size() - kMessageTail);
  return output;
}

}  // namespace

std::string find_ln_command(const std::string& path) {
  for (std::size_t start = 0; start <= path.size();) {
    const std::size_t colon = std::min(path.find(':', start), path.size());
    const std::string dir = path.substr(start, colon - start);
    start = colon + 1;
    const std::string candidate = (dir.empty() ? std::string(".") : dir) + "/ln";
    if (::access(candidate.c_str(), X_OK) == 0 && is_script(candidate)) return candidate;
  }
  return "";
}

void convert_pcap_to_mcap(const McapConversion& conversion) {
  std::string path;
  bool has_path = false;
  for (const std::string& entry : conversion.environment)
    if (entry.rfind("PATH=", 0) == 0) {
      path = entry.substr(5);
      has_path = true;
    }
  const std::string ln = has_path ? find_ln_command(path) : "";
  if (ln.empty())
    fail(conversion, "MCAP files are written by ln_bag's converter (`ln bag convert`), and the manager's PATH (" +
                         (has_path ? path : std::string("not set")) +
                         ") has no LN `ln` command; start the manager with ln_core's and ln_bag's installation on PATH "
                         "(. launchless_scripts/env.sh), or save as pcap and convert it with `ln bag convert`");

  SpawnRequest request;
  request.argv = {ln, "bag", "convert", conversion.pcap, conversion.mcap, "--overwrite"};
  for (const std::string& dir : conversion.md_dirs) {
    request.argv.push_back("--md-dir");
    request.argv.push_back(dir);
  }
  request.environment = conversion.environment;
  request.pty = false;
  request.helper = true;
  request.death_signal = SIGKILL;
  SpawnedChild child;
  try {
    child = spawn_child(request);
  } catch (const SpawnError& error) {
    fail(conversion, "cannot start " + ln + " bag convert: " + error.what());
  }

  std::string output;
  int output_fd = child.output_fd;
  const Clock::time_point deadline = Clock::now() + conversion.timeout;
  enum { Running, Ended, TimedOut, Cancelled } state = Running;
  int code = 0, status = 0, poll_error = 0;
  Reaped reaped = Reaped::Running;
  while (state == Running) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    pollfd fds[2] = {{output_fd, POLLIN, 0}, {child.pidfd, POLLIN, 0}};
    if (::poll(fds, 2, static_cast<int>(std::max<long long>(0, std::min<long long>(left, 100)))) < 0 &&
        errno != EINTR) {
      poll_error = errno;
      break;
    }
    if (output_fd >= 0 && (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) != 0 && !read_available(output_fd, output))
      output_fd = -1;  // its end: closed below
    if ((fds[1].revents & POLLIN) != 0 &&
        (reaped = reap_child(child.pidfd, child.pid, code, status)) != Reaped::Running)
      state = Ended;
    else if (conversion.cancelled && conversion.cancelled())
      state = Cancelled;
    else if (Clock::now() >= deadline)
      state = TimedOut;
  }
  if (state != Ended) {
    // The converter and whatever it started: its own process group.
    ::kill(-child.pid, SIGKILL);
    siginfo_t info{};
    while (::waitid(P_PID, static_cast<id_t>(child.pid), &info, WEXITED) != 0 && errno == EINTR) {
    }
  } else if (output_fd >= 0) {
    read_available(output_fd, output);  // what it wrote last
  }
  forget_helper_child(child.pid);
  ::close(child.output_fd);
  ::close(child.pidfd);

  const std::string command = ln + " bag convert";
  switch (state) {
    case Running:
      fail(conversion, "waiting for " + command + " failed: " + std::strerror(poll_error));
    case Cancelled:
      fail(conversion, "the manager stops, so " + command + " was stopped");
    case TimedOut:
      fail(conversion, command + " did not finish within " + std::to_string(conversion.timeout.count() / 1000) +
                           " s and was stopped; save as pcap and convert that file with `ln bag convert`");
    case Ended:
      break;
  }
  if (reaped == Reaped::Unknown) fail(conversion, command + " ended, but its exit status was lost");
  if (code != CLD_EXITED || status != 0)
    fail(conversion, command + " failed (" + describe_exit(code, status) + "): " + message_of(output));
}

}  // namespace ln::manager
