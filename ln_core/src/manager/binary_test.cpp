// The real ln_manager executable: start-up line, config, signals, exit
// codes, running out of file descriptors, and the lifecycle of the
// processes it runs (stop order, orphans, SIGKILL, --keep-processes). Every child is bounded and
// killed by its PID.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

class ManagerProcess {
 public:
  /// Starts ln_manager with `args`; `max_files` > 0 limits its descriptors.
  ManagerProcess(const TempDir& dir, std::vector<std::string> args, rlim_t max_files = 0)
      : stderr_file_(dir.path() + "/stderr." + std::to_string(++started_)) {
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    args.insert(args.begin(), LN_MANAGER_BINARY);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], 1);
      const int err = ::open(stderr_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      ::dup2(err, 2);
      if (max_files > 0) {
        const rlimit limit{max_files, max_files};
        ::setrlimit(RLIMIT_NOFILE, &limit);
      }
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    stdout_fd_ = out[0];
  }
  ~ManagerProcess() {
    if (pid_ > 0 && !exit_status_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    ::close(stdout_fd_);
  }

  /// The port from "ln_manager: listening on HOST:PORT", or 0.
  std::uint16_t wait_listening(Clock::duration timeout = default_timeout) {
    const auto deadline = Clock::now() + timeout;
    std::string text;
    while (text.find('\n') == std::string::npos) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return 0;
      pollfd p{stdout_fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      char buffer[256];
      const ssize_t n = ::read(stdout_fd_, buffer, sizeof buffer);
      if (n <= 0) return 0;
      text.append(buffer, static_cast<std::size_t>(n));
    }
    const std::string prefix = "ln_manager: listening on 127.0.0.1:";
    if (text.rfind(prefix, 0) != 0) return 0;
    return static_cast<std::uint16_t>(std::stoul(text.substr(prefix.size())));
  }

  /// The exit status, if the process ends within `timeout`.
  std::optional<int> wait_exit(Clock::duration timeout = default_timeout) {
    const auto deadline = Clock::now() + timeout;
    while (!exit_status_ && Clock::now() < deadline) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        break;
      }
      std::this_thread::sleep_for(5ms);  // polling the child's state, bounded by the deadline
    }
    return exit_status_;
  }

  void signal(int number) const { ::kill(pid_, number); }

  /// What it wrote to stdout (and not read yet) until it closed it.
  std::string stdout_text(Clock::duration timeout = default_timeout) {
    const auto deadline = Clock::now() + timeout;
    std::string text;
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd p{stdout_fd_, POLLIN, 0};
      if (left <= 0 || ::poll(&p, 1, static_cast<int>(left)) <= 0) return text;
      char buffer[4096];
      const ssize_t n = ::read(stdout_fd_, buffer, sizeof buffer);
      if (n <= 0) return text;
      text.append(buffer, static_cast<std::size_t>(n));
    }
  }

  std::string stderr_text() const {
    std::ifstream in(stderr_file_);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

 private:
  static inline int started_ = 0;
  std::string stderr_file_;
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::optional<int> exit_status_;
};

class BinaryTest : public ::testing::Test {
 protected:
  BinaryTest() {
    write_test_definitions(dir);
    config = dir.write("test.lnc",
                       "instance\n"
                       "name: binary_test\n"
                       "manager: :0\n"
                       "gen_message_definition_path: %(CURDIR)/gen\n"
                       "add_message_definition_dir: %(CURDIR)/md\n"
                       "hosts\n"
                       "robot: arch:x86_64\n"
                       "process not_started\n"
                       "command: /bin/sleep 1\n");
  }

  TempDir dir;
  std::string config;
};

TEST_F(BinaryTest, ServesClientsAndExitsCleanlyOnSigterm) {
  ManagerProcess manager(dir, {"-c", config, "--without-gui", "--log-level", "debug"});
  const std::uint16_t port = manager.wait_listening();
  ASSERT_NE(port, 0) << manager.stderr_text();
  TestClient client(port);
  ASSERT_FALSE(client.hello("probe").is_error());
  const Message md = client.call("get_message_definition", [](Message& m) { m.set("name", "mt/point"); });
  EXPECT_FALSE(md.is_error()) << md.error_text();
  manager.signal(SIGTERM);
  EXPECT_EQ(manager.wait_exit(), 0);
  const std::string log = manager.stderr_text();
  EXPECT_NE(log.find("instance 'binary_test'"), std::string::npos) << log;
  EXPECT_NE(log.find("the section type 'hosts' is not supported"), std::string::npos) << log;
  EXPECT_EQ(log.find("started 'not_started'"), std::string::npos) << "processes start when asked to";
  EXPECT_NE(log.find("client 'probe'"), std::string::npos) << log;
}

TEST_F(BinaryTest, SigintAlsoExitsCleanlyAndListenOverridesTheConfig) {
  ManagerProcess manager(dir, {"-c", config, "--listen", "127.0.0.1:0", "-i", "renamed", "--log-level", "warning"});
  const std::uint16_t port = manager.wait_listening();
  ASSERT_NE(port, 0) << manager.stderr_text();
  manager.signal(SIGINT);
  EXPECT_EQ(manager.wait_exit(), 0);
  EXPECT_EQ(manager.stderr_text().find("info:"), std::string::npos) << "--log-level warning hides info lines";
}

// As in LN 2.9, -i renames the instance once the config is read: what the
// config derives from %(instance_name) stays as written.
TEST_F(BinaryTest, RenamedInstanceCheckShowsTheConfigsDerivedValuesAndTheStartLinks) {
  const std::string lnc = dir.write("renamed.lnc",
                                    "instance\nname: from_config\nmanager: :0\n"
                                    "process camera\ncommand: /bin/echo %(instance_name)\n"
                                    "provides: camera.image\nstart_on_ready: viewer\n"
                                    "process setup\ncommand: /bin/true\nstart_on_successful_stop: camera\n"
                                    "process viewer\ncommand: /bin/true\nstart_before: setup\n");
  ManagerProcess check(dir, {"-c", lnc, "-i", "renamed", "--check"});
  const std::string out = check.stdout_text();
  EXPECT_EQ(check.wait_exit(), 0) << check.stderr_text();
  EXPECT_NE(out.find("instance renamed, manager at"), std::string::npos) << out;
  EXPECT_NE(out.find("command: /bin/echo from_config\n"), std::string::npos) << out;
  EXPECT_NE(out.find("  provides: camera.image\n"), std::string::npos) << out;
  EXPECT_NE(out.find("  start_on_ready: viewer\n"), std::string::npos) << out;
  EXPECT_NE(out.find("  start_on_successful_stop: camera\n"), std::string::npos) << out;
  EXPECT_NE(out.find("  start_before: setup\n"), std::string::npos) << out;
}

TEST_F(BinaryTest, ConfigErrorsExitWithStatus2AndFileLine) {
  const std::string broken = dir.write("broken.lnc", "instance\nname: %(no_such_define)\n");
  ManagerProcess manager(dir, {"-c", broken});
  EXPECT_EQ(manager.wait_exit(), 2);
  EXPECT_NE(manager.stderr_text().find(broken + ":2: there is no define 'no_such_define'"), std::string::npos)
      << manager.stderr_text();
}

TEST_F(BinaryTest, CommandLineErrorsAndHelp) {
  ManagerProcess unknown(dir, {"--console"});
  EXPECT_EQ(unknown.wait_exit(), 2);
  ManagerProcess both(dir, {"--listen", "127.0.0.1:0", "-p", "0"});
  EXPECT_EQ(both.wait_exit(), 2);
  ManagerProcess help(dir, {"-h"});
  EXPECT_EQ(help.wait_exit(), 0);
}

TEST_F(BinaryTest, RunningOutOfDescriptorsRefusesOnlyNewConnections) {
  ManagerProcess manager(dir, {"--listen", "127.0.0.1:0"}, 16);
  const std::uint16_t port = manager.wait_listening();
  ASSERT_NE(port, 0) << manager.stderr_text();
  std::vector<std::unique_ptr<TestClient>> clients;
  int registered = 0, refused = 0;
  for (int i = 0; i < 14; ++i) {
    auto c = std::make_unique<TestClient>(port);
    try {
      if (!c->hello("client").is_error()) ++registered;
    } catch (const std::runtime_error&) {
      ++refused;  // closed by the manager without an answer
    }
    clients.push_back(std::move(c));
  }
  EXPECT_GT(registered, 0);
  EXPECT_GT(refused, 0);
  EXPECT_NE(manager.stderr_text().find("out of file descriptors"), std::string::npos) << manager.stderr_text();
  EXPECT_FALSE(clients.front()->call("ping").is_error()) << "registered clients keep working";
  clients.clear();
  // Once descriptors are free again, new clients are served.
  const auto deadline = Clock::now() + default_timeout;
  bool served = false;
  while (!served && Clock::now() < deadline) {
    TestClient c(port);
    try {
      served = !c.hello("after").is_error();
    } catch (const std::runtime_error&) {
      // the manager may not have seen all the closes yet
    }
  }
  EXPECT_TRUE(served) << manager.stderr_text();
  manager.signal(SIGTERM);
  EXPECT_EQ(manager.wait_exit(), 0) << manager.stderr_text();
}

// ------------------------------------------------- processes of the config

// A config whose processes record how they stop; %(DIR) is the test's
// directory. `escaper` starts a grandchild in a session of its own, which
// only a subreaper manager can still stop once its parent is gone.
class BinaryProcessTest : public ::testing::Test {
 protected:
  std::string config(const std::string& instance, const std::string& extra = "") {
    const std::string trap =
        "trap 'echo stop %(_PROCESS) >> %(CURDIR)/stops; exit 0' TERM; echo up; "
        "while :; do sleep 0.05; done";
    return dir.write(instance + ".lnc",
                     "instance\nname: " + instance +
                         "\nmanager: :0\n"
                         "process base\ncommand: /bin/sh -c \"" +
                         trap +
                         "\"\nready_regex: ^up\n"
                         "process top\ncommand: /bin/sh -c \"" +
                         trap +
                         "\"\nready_regex: ^up\ndepends_on: base\n"
                         "process escaper\n"
                         "command: /bin/sh -c 'setsid /bin/sleep 1000 & echo $! > %(CURDIR)/grandchild; echo up; "
                         "exec /bin/sleep 1000'\n"
                         "ready_regex: ^up\n"
                         "process counter\n"
                         "command: /bin/sh -c 'i=0; while :; do i=$((i+1)); echo count $i; echo $i > %(CURDIR)/count; "
                         "sleep 0.02; done'\n" +
                         extra);
  }

  std::map<std::string, std::pair<std::string, long>> states(TestClient& client) {
    const Message answer = client.call("process_list");
    std::map<std::string, std::pair<std::string, long>> out;
    for (std::size_t i = 0; i < answer.get_list("names").size(); ++i)
      out[answer.get_list("names")[i]] = {answer.get_list("states")[i], std::stol(answer.get_list("pids")[i])};
    return out;
  }

  // Polls the manager (bounded) until `name` is `state`; its pid.
  long wait_state(TestClient& client, const std::string& name, const std::string& state) {
    const auto deadline = Clock::now() + 10s;
    std::pair<std::string, long> now;
    while (Clock::now() < deadline) {
      now = states(client)[name];
      if (now.first == state) return now.second;
      std::this_thread::sleep_for(5ms);  // polling the manager, bounded
    }
    ADD_FAILURE() << name << " is '" << now.first << "', not '" << state << "'";
    return 0;
  }

  // Runs a manager with --keep-processes that starts `name`, waits until it
  // is in `state` and stops the manager (SIGTERM); the pid it left running.
  long start_kept(const std::string& lnc, const std::string& name, const std::string& state) {
    ManagerProcess first(dir, {"-c", lnc, "--keep-processes", "--start", name});
    const auto client = client_of(first);
    const long pid = wait_state(*client, name, state);
    first.signal(SIGTERM);
    EXPECT_EQ(first.wait_exit(10s), 0) << first.stderr_text();
    EXPECT_NE(first.stderr_text().find("leaving 1 running process(es) to the keeper"), std::string::npos)
        << first.stderr_text();
    return pid;
  }

  long file_pid(const std::string& relative) {
    const auto deadline = Clock::now() + 10s;
    while (Clock::now() < deadline) {
      std::ifstream in(dir.path() + "/" + relative);
      long pid = 0;
      if (in >> pid && pid > 0) return pid;
      std::this_thread::sleep_for(5ms);
    }
    return 0;
  }

  std::string file(const std::string& relative) {
    std::ifstream in(dir.path() + "/" + relative);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  // A registered client of `manager`, once it listens.
  static std::unique_ptr<TestClient> client_of(ManagerProcess& manager) {
    const std::uint16_t port = manager.wait_listening();
    if (port == 0) throw std::runtime_error("the manager does not listen:\n" + manager.stderr_text());
    auto client = std::make_unique<TestClient>(port);
    if (client->hello("probe").is_error()) throw std::runtime_error("the manager refused hello");
    return client;
  }

  TempDir dir;
};

TEST_F(BinaryProcessTest, SigtermStopsDependentsFirstAndLeavesNoOrphan) {
  ManagerProcess manager(dir, {"-c", config("stop_order"), "--start", "top", "--start", "escaper"});
  const auto client = client_of(manager);
  const long top = wait_state(*client, "top", "ready");
  const long escaper = wait_state(*client, "escaper", "ready");
  const long grandchild = file_pid("grandchild");
  ASSERT_TRUE(process_running(grandchild));
  manager.signal(SIGTERM);
  EXPECT_EQ(manager.wait_exit(10s), 0) << manager.stderr_text();
  EXPECT_EQ(file("stops"), "stop top\nstop base\n") << "dependents first";
  for (long pid : {top, escaper, grandchild})
    EXPECT_FALSE(process_running(pid)) << pid << "\n" << manager.stderr_text();
  EXPECT_NE(manager.stderr_text().find("stopping orphaned process " + std::to_string(grandchild)), std::string::npos)
      << manager.stderr_text();
}

// A terminal that hangs up (SIGHUP) stops the manager as SIGTERM does:
// everything stopped, a process that ignores its signal killed.
TEST_F(BinaryProcessTest, SighupStopsLikeSigterm) {
  ManagerProcess manager(dir, {"-c",
                               config("hangup",
                                      "process stubborn\ncommand: /bin/sh -c \"trap '' TERM HUP; echo up; "
                                      "while :; do sleep 0.05; done\"\nready_regex: ^up\nterm_timeout: 0.2\n"),
                               "--start", "top", "--start", "stubborn"});
  const auto client = client_of(manager);
  const long top = wait_state(*client, "top", "ready");
  const long stubborn = wait_state(*client, "stubborn", "ready");
  manager.signal(SIGHUP);
  EXPECT_EQ(manager.wait_exit(10s), 0) << manager.stderr_text();
  EXPECT_EQ(file("stops"), "stop top\nstop base\n") << "dependents first";
  for (long pid : {top, stubborn}) EXPECT_FALSE(process_running(pid)) << pid << "\n" << manager.stderr_text();
  EXPECT_NE(manager.stderr_text().find("received SIGHUP"), std::string::npos) << manager.stderr_text();
}

TEST_F(BinaryProcessTest, AProcessKilledBySigkillLeavesNoOrphan) {
  ManagerProcess manager(dir, {"-c", config("sigkill_process"), "--start", "escaper"});
  const auto client = client_of(manager);
  const long escaper = wait_state(*client, "escaper", "ready");
  const long grandchild = file_pid("grandchild");
  ASSERT_TRUE(process_running(grandchild));
  ::kill(static_cast<pid_t>(escaper), SIGKILL);
  EXPECT_EQ(wait_state(*client, "escaper", "failed"), 0);
  EXPECT_TRUE(wait_process_gone(grandchild, 10s)) << "the subreaper stops what lost its parent\n"
                                                  << manager.stderr_text();
  manager.signal(SIGTERM);
  EXPECT_EQ(manager.wait_exit(10s), 0);
}

TEST_F(BinaryProcessTest, AManagerKilledBySigkillTakesItsProcessesAlong) {
  ManagerProcess manager(dir, {"-c", config("sigkill_manager"), "--start", "top", "--start", "counter"});
  const auto client = client_of(manager);
  const long top = wait_state(*client, "top", "ready");
  const long counter = wait_state(*client, "counter", "started");
  manager.signal(SIGKILL);
  EXPECT_EQ(manager.wait_exit(), 128 + SIGKILL);
  for (long pid : {top, counter}) EXPECT_TRUE(wait_process_gone(pid, 10s)) << "their term_signal comes from the kernel";
}

TEST_F(BinaryProcessTest, KeptProcessesAreAdoptedByTheNextManager) {
  const std::string lnc = config("keep");
  const long counter = start_kept(lnc, "counter", "started");
  EXPECT_TRUE(process_running(counter)) << "it outlived its manager";
  {
    // killed, not stopped: the keeper holds them all the same
    ManagerProcess second(dir, {"-c", lnc, "--keep-processes"});
    const auto client = client_of(second);
    EXPECT_EQ(wait_state(*client, "counter", "started"), counter) << second.stderr_text();
    second.signal(SIGKILL);
    EXPECT_EQ(second.wait_exit(), 128 + SIGKILL);
  }
  ASSERT_TRUE(process_running(counter)) << "a manager that died left it to the keeper";
  // let it print a few lines while only the keeper reads its output
  const long unread = file_pid("count") + 1;
  const auto printing = Clock::now() + 10s;
  while (file_pid("count") < unread + 2 && Clock::now() < printing) std::this_thread::sleep_for(5ms);
  ManagerProcess third(dir, {"-c", lnc});
  const auto client = client_of(third);
  EXPECT_EQ(wait_state(*client, "counter", "started"), counter) << third.stderr_text();
  // what it printed while no manager read it, and what it prints now
  const auto first_output =
      client->call("process_output", [](Message& m) { m.set("name", "counter").set("after", 0); });
  const auto& lines = first_output.get_list("lines");
  ASSERT_FALSE(lines.empty());
  std::string all;
  for (const auto& line : lines) all += line + "\n";
  EXPECT_NE(all.find("count " + std::to_string(unread) + "\n"), std::string::npos)
      << "the keeper kept what it printed while no manager ran:\n"
      << all;
  const auto deadline = Clock::now() + 10s;
  std::int64_t last = first_output.get_int("last");
  while (Clock::now() < deadline &&
         client->call("process_output", [&](Message& m) { m.set("name", "counter").set("after", last); })
             .get_list("lines")
             .empty())
    std::this_thread::sleep_for(5ms);
  EXPECT_GT(
      client->call("process_output", [&](Message& m) { m.set("name", "counter").set("after", 0); }).get_int("last"),
      last)
      << "its output reaches the new manager";
  third.signal(SIGTERM);
  EXPECT_EQ(third.wait_exit(10s), 0) << third.stderr_text();
  EXPECT_FALSE(process_running(counter)) << "a manager without --keep-processes stops what it adopted";
}

// A kept process that printed its ready line for the first manager is ready
// for the next one, which cannot see that line again: what depends on it
// starts at once.
TEST_F(BinaryProcessTest, AKeptProcessThatWasReadyIsReadyWhenAdopted) {
  const std::string lnc = config("keep_ready");
  const long base = start_kept(lnc, "base", "ready");
  ASSERT_TRUE(process_running(base)) << "it outlived its manager";
  ManagerProcess second(dir, {"-c", lnc});
  const auto client = client_of(second);
  EXPECT_EQ(wait_state(*client, "base", "ready"), base) << second.stderr_text();
  client->call("process_control", [](Message& m) { m.set("name", "top").set("action", "start"); });
  wait_state(*client, "top", "ready");
  second.signal(SIGTERM);
  EXPECT_EQ(second.wait_exit(10s), 0) << second.stderr_text();
  EXPECT_TRUE(wait_process_gone(base, 10s));
}

TEST_F(BinaryProcessTest, ASecondSignalKillsAtOnce) {
  ManagerProcess manager(dir, {"-c",
                               config("impatient",
                                      "process stubborn\ncommand: /bin/sh -c \"trap '' TERM; echo up; "
                                      "while :; do sleep 0.05; done\"\nready_regex: ^up\nterm_timeout: 60\n"),
                               "--start", "stubborn"});
  const auto client = client_of(manager);
  const long stubborn = wait_state(*client, "stubborn", "ready");
  manager.signal(SIGTERM);
  EXPECT_EQ(wait_state(*client, "stubborn", "stopping"), stubborn);
  manager.signal(SIGINT);
  EXPECT_EQ(manager.wait_exit(10s), 0) << manager.stderr_text();
  EXPECT_FALSE(process_running(stubborn));
  EXPECT_NE(manager.stderr_text().find("killing all processes"), std::string::npos) << manager.stderr_text();
}

TEST_F(BinaryProcessTest, StartNamesMustExistAndIsolatedTestPicksAPort) {
  ManagerProcess unknown(dir, {"-c", config("names"), "--start", "nobody"});
  EXPECT_EQ(unknown.wait_exit(), 2);
  EXPECT_NE(unknown.stderr_text().find("--start nobody: the config has no process, state or group of that name"),
            std::string::npos);
  ManagerProcess isolated(dir, {"-c", config("names"), "--isolated-test"});
  const std::uint16_t port = isolated.wait_listening();
  ASSERT_NE(port, 0) << isolated.stderr_text();
  EXPECT_NE(isolated.stderr_text().find("instance 'isolated_test_"), std::string::npos) << isolated.stderr_text();
  isolated.signal(SIGTERM);
  EXPECT_EQ(isolated.wait_exit(), 0);
}

}  // namespace
}  // namespace ln::manager::testing
