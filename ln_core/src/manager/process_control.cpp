#include "manager/process_control.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/epoll.h>
#include <sys/prctl.h>
#include <sys/timerfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <set>

#include "manager/child_process.hpp"
#include "manager/line_regex.hpp"
#include "manager/lnc_eval.hpp"
#include "manager/process_keeper.hpp"
#include "manager/process_launch.hpp"
#include "manager/request_error.hpp"

extern char** environ;

namespace ln::manager {
namespace {

using Clock = std::chrono::steady_clock;
using Seconds = std::chrono::duration<double>;

// A restart that follows a run shorter than this counts as a quick failure:
// the next delay doubles.
constexpr double stable_run_seconds = 30;
constexpr double longest_restart_delay = 60;
// Leftovers of a state command or an orphan get this long after SIGTERM.
constexpr double orphan_term_timeout = 2;
constexpr double orphan_sweep_interval = 1;
constexpr std::size_t max_output_slice = 10000;

Clock::time_point after(double seconds) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(Seconds(seconds));
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", std::round(seconds * 1000) / 1000);
  return text;
}

enum class Goal { None, Up, Down };

// A child the control waits for: a process, a state's command.
struct Child {
  pid_t pid = 0;
  int pidfd = -1;
  int output_fd = -1;
  bool running() const { return pid > 0; }
};

struct Leftover {
  pid_t group;
  std::string owner;
  Clock::time_point kill_at;
  bool killed = false;
};

struct Foreign {
  Clock::time_point kill_at;
  bool killed = false;
};

}  // namespace

struct ProcessControl::Impl {
  struct Process {
    ProcessConfig config;
    std::optional<LineRegex> ready_regex, warning_regex;
    OutputRing output;
    std::unique_ptr<OutputLog> log;
    std::string log_problem;
    Child child;
    enum class Phase { Stopped, Running, Stopping } phase = Phase::Stopped;
    Goal goal = Goal::None;
    bool ready = false;
    bool stop_expected = false;
    bool restart_after_stop = false;  // a Down goal that becomes Up once stopped
    bool failed = false;
    std::string error;
    std::string last_exit;
    bool last_stop_successful = true;
    std::string alt_command;  // for the next start
    Clock::time_point requested_at{}, started_at{}, stopped_at{}, failed_at{};
    std::optional<Clock::time_point> ready_at, kill_at, restart_at;
    unsigned restarts = 0, quick_failures = 0;
    bool restarting = false;                      // the pending start is an automatic restart
    bool passive = false;                         // waits for its dependencies to come back, starts none
    bool adopted = false;                         // started by an earlier manager: no exit status
    std::uint64_t start_request = 0;              // when its start was asked for, in order of asking
    std::vector<std::string> dependents;          // depends_on or depends_on_restart this
    std::vector<std::string> restart_dependents;  // depends_on_restart this

    explicit Process(const ProcessConfig& c) : config(c), output(c.max_output_lines) {}
  };

  struct State {
    StateConfig config;
    OutputRing output;
    Child child;
    std::string command_kind;  // "check", "up", "down" while one runs
    std::optional<Clock::time_point> kill_at;
    enum class Value { Unknown, Up, Down } value = Value::Unknown;
    std::optional<Clock::time_point> checked_at, next_auto_check;
    Goal goal = Goal::None;
    bool check_requested = false;
    bool checked_for_goal = false, commanded_for_goal = false;
    bool failed = false;
    std::string error;
    Clock::time_point requested_at{}, failed_at{};

    explicit State(const StateConfig& c) : config(c), output(c.max_output_lines) {}
  };

  Impl(const LncSettings& config, ProcessControlOptions o)
      : options(std::move(o)), launch{options.manager_address, options.definition_dirs, options.library_dir} {
    epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
    timer_fd = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (epoll_fd < 0 || timer_fd < 0)
      throw std::runtime_error("cannot create the process control's descriptors: " + std::string(std::strerror(errno)));
    watch(timer_fd);
    for (const auto& p : config.processes) {
      auto process = std::make_unique<Process>(p);
      if (!p.ready_regex.empty()) process->ready_regex.emplace(p.ready_regex);
      if (!p.warning_regex.empty()) process->warning_regex.emplace(p.warning_regex);
      if (!p.output_logfile.empty())
        process->log =
            std::make_unique<OutputLog>(p.output_logfile, p.output_logfile_size_limit, p.output_logfile_keep_count);
      processes[p.name] = std::move(process);
      process_order.push_back(p.name);
    }
    for (const auto& s : config.states) {
      auto state = std::make_unique<State>(s);
      if (s.auto_check_interval) state->next_auto_check = Clock::now();
      states[s.name] = std::move(state);
      state_order.push_back(s.name);
    }
    groups = config.groups;
    // once each, also when a process names its dependency in both lists
    auto add = [](std::vector<std::string>& list, const std::string& name) {
      if (std::find(list.begin(), list.end(), name) == list.end()) list.push_back(name);
    };
    for (auto& [name, process] : processes) {
      for (const auto& dependency : process->config.depends_on)
        for (const auto& candidate : dependency.candidates)
          if (auto* target = find_process(candidate)) add(target->dependents, name);
      for (const auto& dependency : process->config.depends_on_restart)
        for (const auto& candidate : dependency.candidates)
          if (auto* target = find_process(candidate)) {
            add(target->dependents, name);
            add(target->restart_dependents, name);
          }
    }
    if (options.reap_orphans && ::prctl(PR_SET_CHILD_SUBREAPER, 1) != 0)
      log(LogLevel::Warning, "cannot become a child subreaper (" + std::string(std::strerror(errno)) +
                                 "): orphans of managed processes go to init");
    adopt();
    if (options.keep_processes) start_keeper();
    schedule();
  }

  // ----------------------------------------------------------- keeping

  // What a keeper holds for this instance (a manager started with
  // --keep-processes stopped or died) becomes ours again.
  void adopt() {
    if (options.instance_name.empty()) return;
    std::vector<KeptProcess> kept;
    try {
      kept = adopt_from_keeper(options.instance_name, 5.0);
    } catch (const std::exception& e) {
      log(LogLevel::Warning, std::string("cannot adopt processes: ") + e.what());
      return;
    }
    for (KeptProcess& k : kept) {
      Process* p = find_process(k.name);
      const bool runs = !k.ended && k.start_ticks != 0 && process_start_ticks(k.pid) == k.start_ticks;
      if (p == nullptr || !runs || p->child.running()) {
        if (runs) {
          log(LogLevel::Warning, "the previous manager's process '" + k.name + "' (pid " + std::to_string(k.pid) +
                                     ") is not in this config: stopping it");
          ::kill(-k.pid, SIGTERM);
        } else {
          log(LogLevel::Info, "the previous manager's process '" + k.name + "' ended meanwhile");
        }
        if (k.output_fd >= 0) ::close(k.output_fd);
        if (k.pidfd >= 0) ::close(k.pidfd);
        continue;
      }
      p->child = {k.pid, k.pidfd, k.output_fd};
      if (k.pidfd >= 0) watch(k.pidfd);
      if (k.output_fd >= 0) watch(k.output_fd);
      p->phase = Process::Phase::Running;
      p->ready = k.ready || !p->config.has_ready_condition();
      p->adopted = true;
      p->started_at =
          Clock::now() - std::chrono::duration_cast<Clock::duration>(Seconds(seconds_since_start(k.start_ticks)));
      for (const auto& line : k.output) p->output.append(line + "\n", [&](const std::string& l) { write_log(*p, l); });
      note(*p, "adopted (pid " + std::to_string(k.pid) + ") from the previous manager of the instance");
      log(LogLevel::Info, "adopted '" + k.name + "' (pid " + std::to_string(k.pid) + ") from the previous manager");
    }
  }

  static double seconds_since_start(std::uint64_t start_ticks) {
    std::ifstream in("/proc/uptime");
    double uptime = 0;
    in >> uptime;
    const long ticks = ::sysconf(_SC_CLK_TCK);
    return ticks > 0 ? std::max(0.0, uptime - static_cast<double>(start_ticks) / static_cast<double>(ticks)) : 0.0;
  }

  void start_keeper() {
    const std::string problem = keeper.start(options.keeper_command);
    if (!problem.empty()) {
      log(LogLevel::Warning, "--keep-processes: cannot start the process keeper (" + problem +
                                 "); the processes will be stopped with the manager");
      return;
    }
    log(LogLevel::Info, "process keeper started (pid " + std::to_string(keeper.pid()) + ")");
    for (auto& [name, p] : processes)
      if (p->child.running()) keep(*p);
  }

  void keep(const Process& p) {
    KeptProcess k;
    k.name = p.config.name;
    k.pid = p.child.pid;
    k.start_ticks = process_start_ticks(p.child.pid);
    k.ready = p.ready;
    k.output_fd = p.child.output_fd;
    k.pidfd = p.child.pidfd;
    keeper.add(k);
  }

  ~Impl() {
    if (handed_over) {
      // the keeper holds the processes now; only the descriptors are ours to close
      for (auto& [name, p] : processes) forget(p->child);
      for (auto& [name, s] : states) reap_blocking(s->child);
      ::close(epoll_fd);
      ::close(timer_fd);
      return;
    }
    kill_everything();
    for (auto& [name, process] : processes) reap_blocking(process->child);
    for (auto& [name, state] : states) reap_blocking(state->child);
    if (epoll_fd >= 0) ::close(epoll_fd);
    if (timer_fd >= 0) ::close(timer_fd);
  }

  // ------------------------------------------------------------ basics

  void log(LogLevel level, const std::string& text) const {
    if (options.log) options.log(level, text);
  }

  void watch(int fd) {
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.fd = fd;
    ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &event);
  }

  void unwatch(int& fd) {
    if (fd < 0) return;
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
    ::close(fd);
    fd = -1;
  }

  template <typename Map>
  static auto* find_in(Map& map, const std::string& name) {
    const auto it = map.find(name);
    return it == map.end() ? nullptr : it->second.get();
  }
  Process* find_process(const std::string& name) { return find_in(processes, name); }
  const Process* find_process(const std::string& name) const { return find_in(processes, name); }
  State* find_state(const std::string& name) { return find_in(states, name); }
  const State* find_state(const std::string& name) const { return find_in(states, name); }
  const GroupConfig* find_group(const std::string& name) const {
    for (const auto& group : groups)
      if (group.name == name) return &group;
    return nullptr;
  }

  // A line of the manager's own in a process's output (and its log file);
  // ready_regex and warning_regex look at the process's lines only.
  void note(Process& p, const std::string& text) {
    p.output.flush([&](const std::string& line) { on_line(p, line); });
    p.output.append("[ln_manager] " + text + "\n", [&](const std::string& line) { write_log(p, line); });
  }

  // --------------------------------------------------------- requests

  void request(const std::string& name, const std::string& action, const std::string& alt_command) {
    if (shutting_down) throw RequestError(LNE_REQUEST_FAILED, "the manager is shutting down");
    if (Process* p = find_process(name)) return request_process(*p, action, alt_command);
    if (State* s = find_state(name)) return request_state(*s, action);
    if (const GroupConfig* g = find_group(name)) return request_group(*g, action);
    throw RequestError(LNE_INVALID_PARAMETER, "there is no process, state or group '" + name + "'");
  }

  void request_process(Process& p, const std::string& action, const std::string& alt_command) {
    if (!alt_command.empty() && action != "start" && action != "restart")
      throw RequestError(LNE_INVALID_PARAMETER, "an alt_command goes with start or restart");
    if (!alt_command.empty()) {
      const auto& alts = p.config.alt_commands;
      if (std::none_of(alts.begin(), alts.end(), [&](const auto& a) { return a.first == alt_command; }))
        throw RequestError(LNE_INVALID_PARAMETER,
                           "process '" + p.config.name + "' has no alt_command '" + alt_command + "'");
    }
    if (action == "start") {
      if (!alt_command.empty()) p.alt_command = alt_command;
      want_up(p);
    } else if (action == "stop") {
      if (p.config.has_flag("disable_stop") && p.phase != Process::Phase::Stopped)
        throw RequestError(LNE_REQUEST_FAILED, "process '" + p.config.name + "' has the flag disable_stop");
      want_down(p, false);
    } else if (action == "restart") {
      if (p.config.has_flag("disable_stop") && p.phase != Process::Phase::Stopped)
        throw RequestError(LNE_REQUEST_FAILED, "process '" + p.config.name + "' has the flag disable_stop");
      if (!alt_command.empty()) p.alt_command = alt_command;
      if (p.phase == Process::Phase::Stopped)
        want_up(p);
      else
        want_down(p, true);
    } else {
      throw RequestError(LNE_INVALID_PARAMETER, "a process can start, stop or restart, not '" + action + "'");
    }
    reconcile();
  }

  void request_state(State& s, const std::string& action) {
    if (action == "up" || action == "start") {
      want_state(s, Goal::Up);
    } else if (action == "down" || action == "stop") {
      want_state(s, Goal::Down);
    } else if (action == "check") {
      s.check_requested = true;
      s.failed = false;
      s.error.clear();
    } else {
      throw RequestError(LNE_INVALID_PARAMETER, "a state can go up, down or be checked, not '" + action + "'");
    }
    reconcile();
  }

  void request_group(const GroupConfig& group, const std::string& action) {
    if (action != "start" && action != "stop" && action != "restart")
      throw RequestError(LNE_INVALID_PARAMETER, "a group can start, stop or restart, not '" + action + "'");
    for (const auto& member : group.members) {
      if (Process* p = find_process(member)) {
        if (action != "start" && p->config.has_flag("disable_stop") && p->phase != Process::Phase::Stopped) {
          log(LogLevel::Info, "group '" + group.name + "': not stopping '" + member + "' (flag disable_stop)");
          continue;
        }
        if (action == "start")
          want_up(*p);
        else if (action == "restart" && p->phase != Process::Phase::Stopped)
          want_down(*p, true);
        else if (action == "restart")
          want_up(*p);
        else
          want_down(*p, false);
      } else if (State* s = find_state(member); s && action == "start") {
        want_state(*s, Goal::Up);  // a group stop leaves its states as they are
      }
    }
    reconcile();
  }

  void want_up(Process& p) {
    if (p.goal == Goal::Up && p.phase != Process::Phase::Stopped) return;
    p.goal = Goal::Up;
    p.passive = false;
    p.requested_at = Clock::now();
    p.start_request = ++start_requests;
    p.restart_after_stop = false;
    if (!p.restarting) {
      p.failed = false;
      p.error.clear();
      p.restart_at.reset();
    }
  }

  void want_down(Process& p, bool then_up) {
    p.goal = Goal::Down;
    p.passive = false;
    p.requested_at = Clock::now();
    p.restart_after_stop = then_up;
    p.restarting = false;
    p.restart_at.reset();
  }

  void want_state(State& s, Goal goal) {
    s.goal = goal;
    s.requested_at = Clock::now();
    s.checked_for_goal = s.commanded_for_goal = false;
    s.failed = false;
    s.error.clear();
  }

  std::string start_provider(const std::string& what) {
    std::string best;
    double best_priority = -INFINITY;
    auto consider = [&](const std::string& name, const std::vector<std::pair<std::string, double>>& provides) {
      for (const auto& [provided, priority] : provides)
        if (provided == what && priority > best_priority) {
          best = name;
          best_priority = priority;
        }
    };
    for (const auto& name : process_order) consider(name, processes.at(name)->config.provides);
    for (const auto& name : state_order) consider(name, states.at(name)->config.provides);
    if (best.empty())
      throw RequestError(LNE_NO_PROVIDER_FOUND, "nothing provides '" + what +
                                                    "': no client offers it and no process or state of the config "
                                                    "lists it under provides");
    if (shutting_down) throw RequestError(LNE_START_PROVIDER_FAILED, "the manager is shutting down");
    if (Process* p = find_process(best)) {
      if (p->phase == Process::Phase::Stopped && p->goal != Goal::Up) {
        log(LogLevel::Info, "needs_provider '" + what + "': starting process '" + best + "'");
        want_up(*p);
      }
    } else if (State* s = find_state(best); s && s->goal != Goal::Up) {
      log(LogLevel::Info, "needs_provider '" + what + "': bringing state '" + best + "' up");
      want_state(*s, Goal::Up);
    }
    reconcile();
    return best;
  }

  std::string failure_of(const std::string& name) const {
    if (const Process* p = find_process(name)) return p->failed ? p->error : "";
    if (const State* s = find_state(name)) return s->failed ? s->error : "";
    return "";
  }

  // -------------------------------------------------- the state machine

  // Moves every object towards its goal until nothing changes any more.
  // Processes step in the order their starts were asked for, so that the
  // dependencies of a process start in the order it lists them (as in LN 2.9).
  void reconcile() {
    std::vector<Process*> order;
    for (const auto& name : process_order) order.push_back(processes.at(name).get());
    for (int pass = 0; pass < 64; ++pass) {
      changed = false;
      std::stable_sort(order.begin(), order.end(),
                       [](const Process* a, const Process* b) { return a->start_request < b->start_request; });
      const std::uint64_t asked_before_this_pass = start_requests;
      for (Process* p : order)
        if (p->start_request <= asked_before_this_pass) step(*p);  // (the others: next pass, in order)
      for (const auto& name : state_order) step(*states.at(name));
      if (!changed) break;
    }
    schedule();
  }

  void mark_changed() { changed = true; }

  void fail(Process& p, const std::string& reason) {
    p.failed = true;
    p.error = reason;
    p.failed_at = Clock::now();
    p.goal = Goal::None;
    p.restarting = false;
    p.restart_at.reset();
    log(LogLevel::Warning, "process '" + p.config.name + "': " + reason);
    note(p, reason);
    mark_changed();
  }

  void fail(State& s, const std::string& reason) {
    s.failed = true;
    s.error = reason;
    s.failed_at = Clock::now();
    s.goal = Goal::None;
    log(LogLevel::Warning, "state '" + s.config.name + "': " + reason);
    s.output.append("[ln_manager] " + reason + "\n", {});
    mark_changed();
  }

  void step(Process& p) {
    if (p.goal == Goal::Up)
      step_up(p);
    else if (p.goal == Goal::Down)
      step_down(p);
  }

  void step_up(Process& p) {
    using Phase = Process::Phase;
    if (p.phase == Phase::Stopping) return;
    if (p.phase == Phase::Running) {
      if (p.ready) {
        p.goal = Goal::None;
        mark_changed();
      }
      return;
    }
    if (shutting_down) {
      p.goal = Goal::None;
      return;
    }
    if (p.restart_at && Clock::now() < *p.restart_at) return;
    if (p.config.command.empty() && p.alt_command.empty()) return fail(p, "cannot start: it has no command");
    if (!p.config.remote_host.empty())
      return fail(p, "cannot start: it runs on node '" + p.config.node + "' (host '" + p.config.remote_host +
                         "'); ln_core's manager runs processes on its own host only (no remote daemons)");
    bool waiting = false;
    for (const auto& name : p.config.start_before) {
      Process& before = *processes.at(name);
      const bool ran_since = before.stopped_at > p.requested_at || before.failed_at > p.requested_at;
      if (ran_since && before.phase == Phase::Stopped && before.goal != Goal::Up) {
        if (before.failed || !before.last_stop_successful)
          return fail(p, "cannot start: start_before '" + name + "' did not end successfully (" +
                             (before.failed ? before.error : before.last_exit) + ")");
        continue;
      }
      waiting = true;
      if (before.phase == Phase::Stopped && before.goal == Goal::None) {
        log(LogLevel::Info, "starting '" + name + "' before '" + p.config.name + "' (start_before)");
        want_up(before);
        mark_changed();
      }
    }
    if (waiting) return;
    for (const auto* list : {&p.config.depends_on, &p.config.depends_on_restart})
      for (const auto& dependency : *list) {
        std::string problem;
        if (!dependency_met(dependency, p.requested_at, p.passive, problem)) {
          if (!problem.empty()) return fail(p, "cannot start: " + problem);
          waiting = true;
        }
      }
    if (waiting) return;
    start(p);
  }

  // Whether `dependency` is satisfied; if not, asks a candidate to start.
  // `problem` tells why it never will (a candidate that failed after
  // `since`; earlier failures are retried).
  bool dependency_met(const Dependency& dependency, Clock::time_point since, bool passive, std::string& problem) {
    for (const auto& name : dependency.candidates) {
      if (const Process* d = find_process(name); d && d->phase == Process::Phase::Running && d->ready) return true;
      if (const State* s = find_state(name); s && state_satisfies(*s, dependency.down, since)) return true;
    }
    std::string ended;  // what ran for this request and ended without error, so does not run
    for (const auto& name : dependency.candidates) {
      if (Process* d = find_process(name)) {
        const bool restarting = d->goal == Goal::Down && d->restart_after_stop;
        if (d->goal == Goal::Up || restarting || d->phase != Process::Phase::Stopped) return false;  // on its way
        if (passive) continue;  // it does not come back by itself
        if (d->failed && d->failed_at >= since) continue;
        if (!d->failed && d->stopped_at >= since) {
          if (ended.empty()) ended = "dependency '" + name + "' ended (" + d->last_exit + ")";
          continue;
        }
        log(LogLevel::Info, "starting dependency '" + name + "'");
        want_up(*d);
        mark_changed();
        return false;
      }
      State& s = *states.at(name);
      const Goal goal = dependency.down ? Goal::Down : Goal::Up;
      if (s.goal == goal) return false;
      if (s.failed && s.failed_at >= since) continue;
      want_state(s, goal);
      mark_changed();
      return false;
    }
    const std::string& first = dependency.candidates.front();
    const std::string failure = failure_of(first);
    if (failure.empty() && !ended.empty()) {
      problem = ended;
      return false;
    }
    problem = "dependency '" + first + "' " + (failure.empty() ? std::string("does not run") : "failed: " + failure);
    return false;
  }

  bool state_satisfies(const State& s, bool down, Clock::time_point since) const {
    const State::Value want = down ? State::Value::Down : State::Value::Up;
    return s.value == want && fresh(s, since) && s.command_kind.empty();
  }

  // Whether what is known of a state may be used by a request made at
  // `since`: learned after it, or within min_check_interval.
  static bool fresh(const State& s, Clock::time_point since) {
    if (s.value == State::Value::Unknown) return false;
    if (s.config.check.empty()) return true;
    return s.checked_at &&
           (*s.checked_at >= since || Seconds(Clock::now() - *s.checked_at).count() < s.config.min_check_interval);
  }

  void step_down(Process& p) {
    using Phase = Process::Phase;
    if (p.phase == Phase::Stopping) return;
    if (p.phase == Phase::Stopped) {
      p.failed = false;
      p.error.clear();
      p.restarting = false;
      p.restart_at.reset();
      if (p.restart_after_stop) {
        p.restart_after_stop = false;
        p.goal = Goal::Up;  // `passive` stays as the stop set it
        p.requested_at = Clock::now();
      } else {
        p.goal = Goal::None;
      }
      mark_changed();
      return;
    }
    // Running: what depends on it stops first.
    const bool stop_all_dependents = shutting_down;
    const auto& dependents = stop_all_dependents ? p.dependents : p.restart_dependents;
    bool waiting = false;
    if (stop_all_dependents || !p.config.has_flag("dont_stop_dependent_procs")) {
      for (const auto& name : dependents) {
        Process& d = *processes.at(name);
        if (d.phase == Phase::Stopped) continue;
        waiting = true;
        if (d.goal != Goal::Down) {
          log(LogLevel::Info, "stopping '" + name + "' first: it depends on '" + p.config.name + "'");
          want_down(d, p.restart_after_stop && !shutting_down);
          mark_changed();
        }
      }
    }
    if (waiting) return;
    terminate(p);
  }

  void terminate(Process& p) {
    p.stop_expected = true;
    p.phase = Process::Phase::Stopping;
    const int signal = p.config.term_timeout > 0 ? p.config.term_signal : SIGKILL;
    ::kill(-p.child.pid, signal);
    log(LogLevel::Info,
        "stopping '" + p.config.name + "' (pid " + std::to_string(p.child.pid) + ", " + signal_name(signal) + ")");
    if (p.config.term_timeout > 0) p.kill_at = after(p.config.term_timeout);
    mark_changed();
  }

  // ----------------------------------------------------------- starting

  void start(Process& p) {
    const std::string command = process_command(p.config, p.alt_command);
    std::string problem;
    SpawnRequest request;
    request.argv = process_argv(p.config, command, problem);
    if (!problem.empty()) return fail(p, "cannot start: " + problem);
    request.search_path = p.config.has_flag("use_execvpe");
    request.environment = process_environment(p.config, launch);
    request.directory = process_directory(p.config);
    request.pty = !p.config.has_flag("no_pty");
    request.policy = p.config.policy;
    request.priority = p.config.priority;
    request.affinity = p.config.affinity;
    request.nice = p.config.nice;
    request.limits = p.config.resource_limits;
    request.death_signal = options.stop_with_manager ? p.config.term_signal : 0;
    SpawnedChild child;
    try {
      child = spawn_child(request);
    } catch (const SpawnError& e) {
      return fail(p, std::string("cannot start: ") + e.what());
    }
    p.child = {child.pid, child.pidfd, child.output_fd};
    watch(child.pidfd);
    watch(child.output_fd);
    p.phase = Process::Phase::Running;
    p.started_at = Clock::now();
    p.failed = false;
    p.error.clear();
    p.ready = false;
    p.restart_at.reset();
    if (p.restarting) ++p.restarts;
    p.restarting = false;
    const std::string how = p.alt_command.empty() ? "" : " with alt_command '" + p.alt_command + "'";
    p.alt_command.clear();
    log(LogLevel::Info, "started '" + p.config.name + "' (pid " + std::to_string(child.pid) + ")" + how);
    note(p, "started '" + p.config.name + "' (pid " + std::to_string(child.pid) + ")" + how + ": " + command);
    for (const auto& warning : child.warnings) {
      log(LogLevel::Warning, "process '" + p.config.name + "': " + warning);
      note(p, "warning: " + warning);
    }
    if (!p.config.has_ready_condition())
      become_ready(p, "");
    else if (p.config.ready_time)
      p.ready_at = after(*p.config.ready_time);
    keep(p);
    mark_changed();
  }

  void become_ready(Process& p, const std::string& why) {
    if (p.ready) return;
    p.ready = true;
    p.ready_at.reset();
    if (p.child.running()) keep(p);  // the keeper tells the next manager it is ready
    if (p.config.has_ready_condition()) log(LogLevel::Info, "'" + p.config.name + "' is ready" + why);
    for (const auto& dependency : p.config.start_on_ready)
      request_dependency(dependency, "start_on_ready of '" + p.config.name + "'");
    mark_changed();
  }

  // start_on_ready / start_on_successful_stop: each entry starts (or brings
  // up / down) its first candidate.
  void request_dependency(const Dependency& dependency, const std::string& why) {
    if (shutting_down || dependency.candidates.empty()) return;
    const std::string& name = dependency.candidates.front();
    if (Process* d = find_process(name)) {
      if (d->phase == Process::Phase::Stopped && d->goal != Goal::Up) {
        log(LogLevel::Info, "starting '" + name + "' (" + why + ")");
        want_up(*d);
      }
    } else if (State* s = find_state(name)) {
      want_state(*s, dependency.down ? Goal::Down : Goal::Up);
    }
    mark_changed();
  }

  // ------------------------------------------------------------- output

  void write_log(Process& p, const std::string& line) {
    if (!p.log) return;
    const std::string problem = p.log->write_line(line);
    if (problem != p.log_problem && !problem.empty())
      log(LogLevel::Warning, "process '" + p.config.name + "': " + problem);
    p.log_problem = problem;
  }

  void on_line(Process& p, const std::string& line) {
    write_log(p, line);
    if (p.phase == Process::Phase::Running && !p.ready && p.ready_regex && p.ready_regex->search(line))
      become_ready(p, " (its output matched ready_regex)");
    if (p.warning_regex && p.warning_regex->search(line))
      log(LogLevel::Warning, "process '" + p.config.name +
                                 "': " + (p.config.warning_msg.empty() ? line : p.config.warning_msg + ": " + line));
  }

  // Reads what is there; false once the output has ended.
  bool read_output(Child& child, OutputRing& ring, const std::function<void(const std::string&)>& on) {
    std::array<char, 16384> buffer;
    for (int round = 0; round < 64; ++round) {
      const ssize_t n = ::read(child.output_fd, buffer.data(), buffer.size());
      if (n > 0) {
        ring.append(std::string_view(buffer.data(), static_cast<std::size_t>(n)), on);
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);  // EIO: the pty's other side is closed
    }
    return true;
  }

  void process_output(Process& p) {
    auto on = [&](const std::string& line) { on_line(p, line); };
    if (!read_output(p.child, p.output, on)) unwatch(p.child.output_fd);
    // a prompt without newline may be what ready_regex waits for
    if (p.phase == Process::Phase::Running && !p.ready && p.ready_regex && !p.output.partial().empty() &&
        p.ready_regex->search(p.output.partial()))
      become_ready(p, " (its output matched ready_regex)");
  }

  // --------------------------------------------------------------- exits

  void process_exited(Process& p) {
    int code = 0, status = 0;
    const Reaped reaped = reap_child(p.child.pidfd, p.child.pid, code, status);
    if (reaped == Reaped::Running) return;
    keeper.remove(p.config.name);
    if (p.child.output_fd >= 0) {
      read_output(p.child, p.output, [&](const std::string& line) { on_line(p, line); });
      unwatch(p.child.output_fd);
    }
    p.output.flush([&](const std::string& line) { on_line(p, line); });
    unwatch(p.child.pidfd);
    const pid_t pid = p.child.pid;
    p.child.pid = 0;
    sweep_until = after(orphan_term_timeout);
    const bool killed_by_us = p.kill_at.has_value() && code != CLD_EXITED && status == SIGKILL;
    collect_leftovers(pid, p.config.name, killed_by_us ? SIGKILL : p.config.term_signal, p.config.term_timeout);
    const std::string how = reaped == Reaped::Ended
                                ? describe_exit(code, status)
                                : std::string("exit status unknown (adopted from an earlier manager)");
    p.last_exit = how;
    p.adopted = false;
    p.stopped_at = Clock::now();
    const double ran = Seconds(p.stopped_at - p.started_at).count();
    const bool expected = p.stop_expected || shutting_down;
    p.phase = Process::Phase::Stopped;
    p.ready = false;
    p.stop_expected = false;
    p.kill_at.reset();
    p.ready_at.reset();
    mark_changed();
    const std::string what = "'" + p.config.name + "' (pid " + std::to_string(pid) + ")";
    if (expected) {
      p.last_stop_successful = true;
      log(LogLevel::Info, "stopped " + what + ": " + how);
      note(p, "stopped (" + how + ")");
      if (p.config.has_flag("user_stop_is_successful_stop"))
        for (const auto& d : p.config.start_on_successful_stop)
          request_dependency(d, "start_on_successful_stop of '" + p.config.name + "'");
      return;
    }
    const bool successful = reaped == Reaped::Ended && code == CLD_EXITED && status == 0;
    const bool no_error =
        p.config.has_flag("no_error_on_stop") || (successful && p.config.has_flag("no_error_on_successful_stop"));
    p.last_stop_successful = no_error;
    if (no_error) {
      log(LogLevel::Info, what + " ended: " + how);
      note(p, "ended (" + how + ")");
      if (p.goal == Goal::Up) p.goal = Goal::None;  // it ended before it was ready: done, not started again
      for (const auto& d : p.config.start_on_successful_stop)
        request_dependency(d, "start_on_successful_stop of '" + p.config.name + "'");
    } else {
      log(LogLevel::Warning, what + " terminated unexpectedly: " + how);
      note(p, "terminated unexpectedly (" + how + ")");
      if (p.config.auto_restart_interval) {
        schedule_restart(p, ran);
      } else {
        p.failed = true;
        p.error = "terminated unexpectedly (" + how + ")";
        p.failed_at = p.stopped_at;
        if (p.goal == Goal::Up) p.goal = Goal::None;
      }
    }
    for (const auto& name : p.dependents) {
      Process& d = *processes.at(name);
      if (d.phase != Process::Phase::Running) continue;
      if (std::find(p.restart_dependents.begin(), p.restart_dependents.end(), name) != p.restart_dependents.end()) {
        log(LogLevel::Info, "stopping '" + name + "': it depends on '" + p.config.name + "' (depends_on_restart)");
        want_down(d, true);
        d.passive = true;  // starts again when (if) its dependency is back
      } else if (!no_error) {
        log(LogLevel::Warning, "'" + name + "' depends on '" + p.config.name + "', which is no longer running");
      }
    }
  }

  // The first restart comes after auto_restart_interval; each further one
  // that follows a run shorter than stable_run_seconds waits twice as long
  // as the one before, up to longest_restart_delay (or the interval, if
  // larger).
  void schedule_restart(Process& p, double ran) {
    const double interval = *p.config.auto_restart_interval;
    p.quick_failures = ran < stable_run_seconds ? p.quick_failures + 1 : 1;
    double delay = interval;
    if (p.quick_failures > 1) {
      const double base = std::max(interval, 0.1);
      delay = std::min(base * std::pow(2.0, std::min(p.quick_failures - 1, 20u)),
                       std::max(longest_restart_delay, interval));
    }
    p.restart_at = after(delay);
    p.restarting = true;
    p.goal = Goal::Up;
    p.requested_at = Clock::now();
    log(LogLevel::Info, "restarting '" + p.config.name + "' in " + seconds_text(delay) + " (restart " +
                            std::to_string(p.restarts + 1) + ")");
    note(p, "restarting in " + seconds_text(delay));
  }

  // What is left of a child's process group gets `signal`, then SIGKILL.
  void collect_leftovers(pid_t group, const std::string& owner, int signal, double timeout) {
    if (!process_group_alive(group)) return;
    ::kill(-group, signal);
    Leftover leftover{group, owner, after(signal == SIGKILL ? 0 : timeout), signal == SIGKILL};
    log(LogLevel::Info, "'" + owner + "' ended, its process group " + std::to_string(group) +
                            " did not: " + signal_name(signal) + " to it");
    leftovers.push_back(leftover);
  }

  // ------------------------------------------------------------ states

  void step(State& s) {
    if (!s.command_kind.empty()) return;
    if (!s.config.unsupported.empty() || !s.config.remote_host.empty()) {
      if (s.goal != Goal::None || s.check_requested) {
        s.check_requested = false;
        fail(s, s.config.unsupported.empty() ? "runs on host '" + s.config.remote_host +
                                                   "'; ln_core's manager runs commands on its own host only"
                                             : s.config.unsupported);
      }
      return;
    }
    if (s.check_requested) {
      s.check_requested = false;
      if (s.config.check.empty()) return fail(s, "has no check command");
      return run_state_command(s, "check");
    }
    if (s.goal == Goal::None) {
      if (s.next_auto_check && Clock::now() >= *s.next_auto_check && !s.config.check.empty() && !shutting_down)
        run_state_command(s, "check");
      return;
    }
    if (shutting_down) {
      s.goal = Goal::None;
      return;
    }
    const bool up = s.goal == Goal::Up;
    const State::Value want = up ? State::Value::Up : State::Value::Down;
    if (s.value == want && fresh(s, s.requested_at)) {
      s.goal = Goal::None;
      mark_changed();
      return;
    }
    if (!fresh(s, s.requested_at) && !s.config.check.empty() && !s.checked_for_goal) {
      s.checked_for_goal = true;
      return run_state_command(s, "check");
    }
    if (s.value == want) {
      s.goal = Goal::None;
      mark_changed();
      return;
    }
    if (s.commanded_for_goal)
      return fail(s, std::string("is still ") + (up ? "DOWN after its up command" : "UP after its down command"));
    const std::string& command = up ? s.config.up : s.config.down;
    if (command.empty())
      return fail(s, std::string("is ") + (up ? "DOWN and has no up" : "UP and has no down") + " command");
    if (up) {
      bool waiting = false;
      for (const auto* list : {&s.config.depends_on, &s.config.depends_on_restart})
        for (const auto& dependency : *list) {
          std::string problem;
          if (!dependency_met(dependency, s.requested_at, false, problem)) {
            if (!problem.empty()) return fail(s, "cannot go up: " + problem);
            waiting = true;
          }
        }
      if (waiting) return;
    }
    s.commanded_for_goal = true;
    run_state_command(s, up ? "up" : "down");
  }

  void run_state_command(State& s, const std::string& kind) {
    const std::string& command = kind == "check" ? s.config.check : kind == "up" ? s.config.up : s.config.down;
    SpawnRequest request;
    request.argv = {"/bin/sh", "-c", command};
    const bool own_address = !options.manager_address.empty();
    for (char** entry = environ; *entry != nullptr; ++entry)
      if (!own_address || std::strncmp(*entry, "LN_MANAGER=", 11) != 0) request.environment.emplace_back(*entry);
    if (own_address) request.environment.push_back("LN_MANAGER=" + options.manager_address);
    request.directory = "/tmp";  // where LN 2.9's daemon runs them
    request.pty = false;
    request.death_signal = options.stop_with_manager ? SIGTERM : 0;
    SpawnedChild child;
    try {
      child = spawn_child(request);
    } catch (const SpawnError& e) {
      return fail(s, "cannot run its " + kind + " command: " + e.what());
    }
    s.child = {child.pid, child.pidfd, child.output_fd};
    s.command_kind = kind;
    watch(child.pidfd);
    watch(child.output_fd);
    s.output.append("[ln_manager] " + kind + ": " + command + "\n", {});
    log(LogLevel::Debug, "state '" + s.config.name + "': " + kind + " (pid " + std::to_string(child.pid) + ")");
    mark_changed();
  }

  void state_command_exited(State& s) {
    int code = 0, status = 0;
    if (reap_child(s.child.pidfd, s.child.pid, code, status) == Reaped::Running) return;
    if (s.child.output_fd >= 0) {
      read_output(s.child, s.output, {});
      unwatch(s.child.output_fd);
    }
    s.output.flush({});
    unwatch(s.child.pidfd);
    collect_leftovers(s.child.pid, "state " + s.config.name, SIGTERM, orphan_term_timeout);
    sweep_until = after(orphan_term_timeout);
    s.child.pid = 0;
    s.kill_at.reset();
    const std::string kind = s.command_kind;
    s.command_kind.clear();
    mark_changed();
    const bool success = code == CLD_EXITED && status == 0;
    const std::string how = describe_exit(code, status);
    s.output.append("[ln_manager] " + kind + " ended: " + how + "\n", {});
    if (shutting_down) return;
    const auto previous = s.value;
    if (kind == "check") {
      s.value = success ? State::Value::Up : State::Value::Down;
      s.checked_at = Clock::now();
      if (s.config.auto_check_interval) s.next_auto_check = after(*s.config.auto_check_interval);
    } else if (!success) {
      return fail(s, "its " + kind + " command failed (" + how + ")");
    } else if (s.config.has_flag("need_check_after_up") && !s.config.check.empty()) {
      s.value = State::Value::Unknown;
      s.checked_for_goal = false;
    } else {
      s.value = kind == "up" ? State::Value::Up : State::Value::Down;
      s.checked_at = Clock::now();
    }
    if (s.value != previous && s.value != State::Value::Unknown)
      log(LogLevel::Info, "state '" + s.config.name + "' is " + (s.value == State::Value::Up ? "UP" : "DOWN"));
  }

  // -------------------------------------------------- orphans, timers

  // With reap_orphans: children this manager did not start are orphans of
  // its processes' descendants; they get SIGTERM, then SIGKILL.
  void sweep_orphans() {
    if (!options.reap_orphans) return;
    std::set<pid_t> known;
    for (const auto& [name, p] : processes)
      if (p->child.running()) known.insert(p->child.pid);
    for (const auto& [name, s] : states)
      if (s->child.running()) known.insert(s->child.pid);
    if (keeper.running()) known.insert(keeper.pid());
    for (pid_t pid : list_children()) {
      if (known.count(pid) || foreign.count(pid) || is_helper_child(pid)) continue;
      std::string command;
      std::getline(std::ifstream("/proc/" + std::to_string(pid) + "/cmdline"), command, '\0');
      log(LogLevel::Info, "stopping orphaned process " + std::to_string(pid) + " (" + command +
                              "): its parent, started by this manager, ended");
      ::kill(pid, SIGTERM);
      foreign[pid] = {after(orphan_term_timeout), false};
    }
    for (auto it = foreign.begin(); it != foreign.end();) {
      int status = 0;
      if (::waitpid(it->first, &status, WNOHANG) == it->first || (errno == ECHILD && ::kill(it->first, 0) != 0)) {
        it = foreign.erase(it);
        continue;
      }
      if (!it->second.killed && Clock::now() >= it->second.kill_at) {
        ::kill(it->first, SIGKILL);
        it->second.killed = true;
      }
      ++it;
    }
  }

  bool anything_runs() const {
    for (const auto& [name, p] : processes)
      if (p->child.running() && !handed_over) return true;
    for (const auto& [name, s] : states)
      if (s->child.running()) return true;
    return false;
  }

  void check_deadlines() {
    const auto now = Clock::now();
    for (auto& [name, p] : processes) {
      if (p->kill_at && now >= *p->kill_at && p->child.running()) {
        log(LogLevel::Warning, "'" + name + "' did not stop within " + seconds_text(p->config.term_timeout) +
                                   " after " + signal_name(p->config.term_signal) + ": SIGKILL");
        note(*p, "did not stop in time: SIGKILL");
        ::kill(-p->child.pid, SIGKILL);
        p->kill_at = Clock::time_point::max();  // sent; only the exit is awaited now
      }
      if (p->ready_at && now >= *p->ready_at && p->phase == Process::Phase::Running)
        become_ready(*p, " (ready_time " + seconds_text(*p->config.ready_time) + " passed)");
      if (p->restart_at && now >= *p->restart_at) mark_changed();
    }
    for (auto& [name, s] : states)
      if (s->kill_at && now >= *s->kill_at && s->child.running()) {
        ::kill(-s->child.pid, SIGKILL);
        s->kill_at = Clock::time_point::max();
      }
    for (auto it = leftovers.begin(); it != leftovers.end();) {
      if (!process_group_alive(it->group)) {
        it = leftovers.erase(it);
        continue;
      }
      if (!it->killed && now >= it->kill_at) {
        log(LogLevel::Info,
            "process group " + std::to_string(it->group) + " of '" + it->owner + "' is still there: SIGKILL");
        ::kill(-it->group, SIGKILL);
        it->killed = true;
      }
      ++it;
    }
    if (sweeping()) sweep_orphans();
  }

  // Orphans appear when a process (or a state's command) ends, a moment
  // after its exit: look for them while anything runs and for a while after
  // something ended.
  bool sweeping() const {
    return options.reap_orphans &&
           (anything_runs() || !foreign.empty() || shutting_down || (sweep_until && Clock::now() < *sweep_until));
  }

  // Arms the timer for the next deadline (or a short poll while SIGKILLed
  // groups are on their way out).
  void schedule() {
    std::optional<Clock::time_point> next;
    auto consider = [&](const std::optional<Clock::time_point>& t) {
      if (t && *t != Clock::time_point::max() && (!next || *t < *next)) next = *t;
    };
    for (const auto& [name, p] : processes) {
      consider(p->kill_at);
      consider(p->ready_at);
      consider(p->restart_at);
    }
    for (const auto& [name, s] : states) {
      consider(s->kill_at);
      if (s->goal == Goal::None && s->config.check.size() && s->command_kind.empty()) consider(s->next_auto_check);
    }
    for (const auto& leftover : leftovers) consider(leftover.killed ? after(0.05) : leftover.kill_at);
    if (sweeping()) {
      const bool soon = !foreign.empty() || (sweep_until && Clock::now() < *sweep_until);
      consider(after(soon ? 0.1 : orphan_sweep_interval));
    }
    itimerspec spec{};
    if (next) {
      const auto wait = std::max<Clock::duration>(*next - Clock::now(), std::chrono::milliseconds(1));
      const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count();
      spec.it_value.tv_sec = static_cast<time_t>(ns / 1000000000);
      spec.it_value.tv_nsec = static_cast<long>(ns % 1000000000);
    }
    ::timerfd_settime(timer_fd, 0, &spec, nullptr);
  }

  void handle_events() {
    std::array<epoll_event, 32> events;
    const int count = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), 0);
    for (int i = 0; i < count; ++i) {
      const int fd = events[static_cast<std::size_t>(i)].data.fd;
      if (fd == timer_fd) {
        std::uint64_t expirations;
        (void)!::read(timer_fd, &expirations, sizeof expirations);
        continue;
      }
      for (auto& [name, p] : processes) {
        if (fd >= 0 && fd == p->child.output_fd)
          process_output(*p);
        else if (fd >= 0 && fd == p->child.pidfd)
          process_exited(*p);
      }
      for (auto& [name, s] : states) {
        if (fd >= 0 && fd == s->child.output_fd) {
          if (!read_output(s->child, s->output, {})) unwatch(s->child.output_fd);
        } else if (fd >= 0 && fd == s->child.pidfd) {
          state_command_exited(*s);
        }
      }
    }
    check_deadlines();
    reconcile();
  }

  // ---------------------------------------------------------- shutdown

  void begin_shutdown() {
    if (shutting_down) return;
    shutting_down = true;
    if (keeper.running()) {
      handed_over = true;
      unsigned running = 0;
      for (auto& [name, p] : processes) {
        running += p->child.running();
        p->goal = Goal::None;
        p->restart_at.reset();
      }
      log(LogLevel::Info, "leaving " + std::to_string(running) + " running process(es) to the keeper (pid " +
                              std::to_string(keeper.pid()) + ") for the next manager of instance '" +
                              options.instance_name + "'");
    }
    for (auto& [name, p] : processes) {
      if (handed_over) break;
      p->restart_at.reset();
      p->restarting = false;
      p->restart_after_stop = false;
      p->goal = p->phase == Process::Phase::Running ? Goal::Down : Goal::None;
    }
    for (auto& [name, s] : states) {
      s->goal = Goal::None;
      s->check_requested = false;
      if (s->child.running()) {
        ::kill(-s->child.pid, SIGTERM);
        s->kill_at = after(orphan_term_timeout);
      }
    }
    if (anything_runs()) log(LogLevel::Info, "stopping all processes, dependents first");
    reconcile();
  }

  void kill_everything() {
    for (auto& [name, p] : processes)
      if (p->child.running() && !handed_over) ::kill(-p->child.pid, SIGKILL);
    for (auto& [name, s] : states)
      if (s->child.running()) ::kill(-s->child.pid, SIGKILL);
    for (auto& leftover : leftovers) ::kill(-leftover.group, SIGKILL);
    for (auto& [pid, entry] : foreign) ::kill(pid, SIGKILL);
  }

  static void forget(Child& child) {
    if (child.pidfd >= 0) ::close(child.pidfd);
    if (child.output_fd >= 0) ::close(child.output_fd);
    child = Child{};
  }

  void reap_blocking(Child& child) {
    if (!child.running()) return;
    siginfo_t info{};
    ::waitid(P_PID, static_cast<id_t>(child.pid), &info, WEXITED);
    if (child.pidfd >= 0) ::close(child.pidfd);
    if (child.output_fd >= 0) ::close(child.output_fd);
    child = Child{};
  }

  bool finished() const {
    if (anything_runs() || !foreign.empty()) return false;
    return std::all_of(leftovers.begin(), leftovers.end(), [](const Leftover& l) { return l.killed; });
  }

  // ------------------------------------------------------------ status

  std::vector<ObjectStatus> status() const {
    std::vector<ObjectStatus> rows;
    const auto now = Clock::now();
    for (const auto& name : process_order) {
      const Process& p = *processes.at(name);
      ObjectStatus row;
      row.name = name;
      row.kind = "process";
      row.state = process_state(p);
      row.requested = p.goal == Goal::Up ? "start" : p.goal == Goal::Down ? "stop" : "";
      row.pid = p.child.pid;
      row.uptime = p.child.running() ? Seconds(now - p.started_at).count() : 0;
      row.restarts = p.restarts;
      row.ready = p.ready;
      row.last_exit = p.last_exit;
      row.error = p.failed ? p.error : "";
      row.command = p.config.command;
      for (const auto* list : {&p.config.depends_on, &p.config.depends_on_restart})
        for (const auto& dependency : *list)
          row.depends_on.push_back((dependency.down ? "!" : "") + join(dependency.candidates, "|"));
      rows.push_back(std::move(row));
    }
    for (const auto& name : state_order) {
      const State& s = *states.at(name);
      ObjectStatus row;
      row.name = name;
      row.kind = "state";
      row.state = s.command_kind == "check"       ? "checking"
                  : s.command_kind == "up"        ? "going up"
                  : s.command_kind == "down"      ? "going down"
                  : s.failed                      ? "error"
                  : s.value == State::Value::Up   ? "UP"
                  : s.value == State::Value::Down ? "DOWN"
                                                  : "unknown";
      row.requested = s.check_requested ? "check" : s.goal == Goal::Up ? "up" : s.goal == Goal::Down ? "down" : "";
      row.pid = s.child.pid;
      row.ready = s.value == State::Value::Up && !s.failed;
      row.error = s.failed ? s.error : "";
      row.command = s.config.check;
      for (const auto& dependency : s.config.depends_on)
        row.depends_on.push_back((dependency.down ? "!" : "") + join(dependency.candidates, "|"));
      rows.push_back(std::move(row));
    }
    for (const auto& group : groups) {
      ObjectStatus row;
      row.name = group.name;
      row.kind = "group";
      row.members = group.members;
      unsigned running = 0, total = 0;
      for (const auto& member : group.members)
        if (const Process* p = find_process(member)) {
          ++total;
          running += p->child.running();
        }
      row.state = std::to_string(running) + "/" + std::to_string(total) + " running";
      row.ready = total > 0 && running == total;
      rows.push_back(std::move(row));
    }
    return rows;
  }

  static std::string join(const std::vector<std::string>& items, const char* separator) {
    std::string out;
    for (const auto& item : items) out += (out.empty() ? "" : separator) + item;
    return out;
  }

  static std::string process_state(const Process& p) {
    using Phase = Process::Phase;
    if (p.phase == Phase::Stopping) return "stopping";
    if (p.phase == Phase::Running) return p.ready && p.config.has_ready_condition() ? "ready" : "started";
    if (p.restart_at) return "restarting";
    if (p.goal == Goal::Up) return "starting";
    if (p.failed) return "failed";
    return "stopped";
  }

  OutputRing::Slice output(const std::string& name, std::uint64_t after, std::size_t max) const {
    max = std::min(max == 0 ? max_output_slice : max, max_output_slice);
    if (const Process* p = find_process(name)) return p->output.since(after, max);
    if (const State* s = find_state(name)) return s->output.since(after, max);
    throw RequestError(LNE_INVALID_PARAMETER, "there is no process or state '" + name + "'");
  }

  ProcessControlOptions options;
  LaunchContext launch;
  int epoll_fd = -1;
  int timer_fd = -1;
  std::map<std::string, std::unique_ptr<Process>> processes;
  std::map<std::string, std::unique_ptr<State>> states;
  std::vector<std::string> process_order, state_order;
  std::vector<GroupConfig> groups;
  std::vector<Leftover> leftovers;
  std::map<pid_t, Foreign> foreign;
  std::optional<Clock::time_point> sweep_until;
  KeeperLink keeper;
  bool shutting_down = false;
  bool handed_over = false;  // the keeper holds the processes
  std::uint64_t start_requests = 0;
  bool changed = false;
};

ProcessControl::ProcessControl(const LncSettings& config, ProcessControlOptions options)
    : impl_(std::make_unique<Impl>(config, std::move(options))) {}

ProcessControl::~ProcessControl() = default;

int ProcessControl::fd() const { return impl_->epoll_fd; }

void ProcessControl::handle_events() { impl_->handle_events(); }

bool ProcessControl::knows(const std::string& name) const {
  return impl_->find_process(name) || impl_->find_state(name) || impl_->find_group(name);
}

void ProcessControl::request(const std::string& name, const std::string& action, const std::string& alt_command) {
  impl_->request(name, action, alt_command);
}

std::string ProcessControl::start_provider(const std::string& what) { return impl_->start_provider(what); }

std::string ProcessControl::failure_of(const std::string& name) const { return impl_->failure_of(name); }

std::vector<ObjectStatus> ProcessControl::status() const { return impl_->status(); }

OutputRing::Slice ProcessControl::output(const std::string& name, std::uint64_t after, std::size_t max) const {
  return impl_->output(name, after, max);
}

void ProcessControl::begin_shutdown() { impl_->begin_shutdown(); }

void ProcessControl::kill_all() {
  impl_->kill_everything();
  impl_->schedule();
}

bool ProcessControl::finished() const { return impl_->finished(); }

}  // namespace ln::manager
