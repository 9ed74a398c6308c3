// The manager running the processes, states and groups of a config, over
// the client protocol (process_list, process_control, process_output,
// needs_provider): dependencies, readiness, failures, restarts, stop order,
// what is left of a process's group, output. Every wait is bounded and
// waits for a condition the manager reports.
#include <gtest/gtest.h>

#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "manager/config.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager {
namespace {

using namespace std::chrono_literals;
using testing::Clock;
using testing::Message;
using testing::RunningManager;
using testing::TempDir;
using testing::TestClient;

struct Row {
  std::string state, requested, last_exit, error, ready;
  long pid = 0;
  unsigned restarts = 0;
};

class ProcessControlTest : public ::testing::Test {
 protected:
  // Starts a manager that runs `config` (.lnc text; %(DIR) is the test's
  // directory) and connects a client.
  void start(const std::string& config, const std::function<void(ManagerOptions&)>& configure = {}) {
    std::string text = config;
    for (auto at = text.find("%(DIR)"); at != std::string::npos; at = text.find("%(DIR)"))
      text.replace(at, 6, dir.path());
    auto settings = std::make_shared<LncSettings>(read_lnc_text(text, dir.path() + "/test.lnc", {}));
    manager = std::make_unique<RunningManager>(dir, [&](ManagerOptions& options) {
      options.system = settings;
      if (configure) configure(options);
    });
    client = std::make_unique<TestClient>(manager->port());
    ASSERT_FALSE(client->hello("process_test").is_error());
  }

  std::map<std::string, Row> rows() {
    const Message answer = client->call("process_list");
    std::map<std::string, Row> out;
    const auto& names = answer.get_list("names");
    for (std::size_t i = 0; i < names.size(); ++i) {
      Row row;
      row.state = answer.get_list("states")[i];
      row.requested = answer.get_list("requested")[i];
      row.last_exit = answer.get_list("last_exits")[i];
      row.error = answer.get_list("errors")[i];
      row.ready = answer.get_list("ready")[i];
      row.pid = std::stol(answer.get_list("pids")[i]);
      row.restarts = static_cast<unsigned>(std::stoul(answer.get_list("restarts")[i]));
      out[names[i]] = row;
    }
    return out;
  }

  Row row(const std::string& name) { return rows().at(name); }

  // Polls the manager (bounded) until `name` is in `state`.
  Row wait_state(const std::string& name, const std::string& state, Clock::duration timeout = 10s) {
    const auto deadline = Clock::now() + timeout;
    Row current;
    do {
      current = row(name);
      if (current.state == state && current.requested.empty()) return current;
      std::this_thread::sleep_for(5ms);  // polling our own manager, not waiting on a peer
    } while (Clock::now() < deadline);
    ADD_FAILURE() << name << " did not reach '" << state << "' (now '" << current.state << "', error '" << current.error
                  << "', last exit '" << current.last_exit << "')\n"
                  << manager->log_text();
    return current;
  }

  Message control(const std::string& name, const std::string& action) {
    return client->call("process_control", [&](Message& m) { m.set("name", name).set("action", action); });
  }

  std::vector<std::string> output(const std::string& name) {
    return client->call("process_output", [&](Message& m) { m.set("name", name).set("after", 0); }).get_list("lines");
  }

  std::string file(const std::string& relative) {
    std::ifstream in(dir.path() + "/" + relative);
    std::stringstream content;
    content << in.rdbuf();
    return content.str();
  }

  // Waits (bounded) until the file holds `text`.
  bool wait_file(const std::string& relative, const std::string& text, Clock::duration timeout = 10s) {
    const auto deadline = Clock::now() + timeout;
    do {
      if (file(relative).find(text) != std::string::npos) return true;
      std::this_thread::sleep_for(5ms);
    } while (Clock::now() < deadline);
    return false;
  }

  static bool alive(long pid) { return testing::process_running(pid); }
  static bool wait_gone(long pid) { return testing::wait_process_gone(pid, 10s); }

  // Stops the manager like SIGTERM does and waits for its loop to end.
  void stop_manager() {
    client.reset();
    manager.reset();
  }

  TempDir dir;
  std::unique_ptr<RunningManager> manager;
  std::unique_ptr<TestClient> client;
};

TEST_F(ProcessControlTest, StartsDependenciesFirstAndWaitsForReadiness) {
  start(
      "process camera\n"
      "command: /bin/sh -c 'echo camera >> %(DIR)/order; sleep 0.3; echo camera ready; exec sleep 1000'\n"
      "ready_regex: camera ready\n"
      "process tracker\n"
      "command: /bin/sh -c 'echo tracker >> %(DIR)/order; echo tracking; exec sleep 1000'\n"
      "ready_regex: ^tracking$\n"
      "depends_on: camera\n"
      "process viewer\n"
      "command: /bin/sh -c 'echo viewer >> %(DIR)/order; exec sleep 1000'\n"
      "depends_on: tracker\n");
  EXPECT_FALSE(control("viewer", "start").is_error());
  EXPECT_EQ(row("viewer").state, "starting") << "it waits for what it depends on";
  const Row viewer = wait_state("viewer", "started");
  EXPECT_NE(viewer.pid, 0);
  ASSERT_TRUE(wait_file("order", "viewer"));
  EXPECT_EQ(row("camera").state, "ready");
  EXPECT_EQ(row("tracker").state, "ready");
  EXPECT_EQ(file("order"), "camera\ntracker\nviewer\n") << "each only after its dependency was ready";
  const auto lines = output("camera");
  std::string all;
  for (const auto& line : lines) all += "[" + line + "]";
  EXPECT_NE(std::find(lines.begin(), lines.end(), "camera ready"), lines.end())
      << "pty output, without \\r: " << all << "\n"
      << manager->log_text();
}

TEST_F(ProcessControlTest, DependenciesStartInTheOrderTheyAreListed) {
  start(
      "process first_in_file\n"
      "command: /bin/sleep 1000\n"
      "process second_in_file\n"
      "command: /bin/sleep 1000\n"
      "process top\n"
      "command: /bin/sleep 1000\n"
      "depends_on: second_in_file, first_in_file\n");
  EXPECT_FALSE(control("top", "start").is_error());
  wait_state("top", "started");
  const std::string log = manager->log_text();
  const auto second = log.find("started 'second_in_file'"), first = log.find("started 'first_in_file'");
  ASSERT_NE(second, std::string::npos) << log;
  ASSERT_NE(first, std::string::npos) << log;
  EXPECT_LT(second, first) << "as depends_on lists them (LN 2.9), not in config order\n" << log;
}

TEST_F(ProcessControlTest, ReadyTimeAndStartOnReady) {
  start(
      "process slow\n"
      "command: /bin/sleep 1000\n"
      "ready_time: 0.3\n"
      "start_on_ready: follower\n"
      "process follower\n"
      "command: /bin/sleep 1000\n");
  const auto asked = Clock::now();
  control("slow", "start");
  const Row started = row("slow");
  EXPECT_EQ(started.state, "started");
  EXPECT_EQ(started.ready, "0");
  EXPECT_EQ(started.requested, "start") << "a start is done once it is ready";
  wait_state("slow", "ready");
  EXPECT_GE(Clock::now() - asked, 300ms);
  wait_state("follower", "started");
}

TEST_F(ProcessControlTest, StartFailuresSayWhyAndTheManagerGoesOn) {
  dir.write("not_executable", "#!/bin/sh\n");
  start(
      "process missing\ncommand: /no/such/program --flag\n"
      "process bare\ncommand: sleep 1\n"
      "process no_exec\ncommand: %(DIR)/not_executable\n"
      "process no_dir\ncommand: /bin/true\nchange_directory: /no/such/dir\n"
      "process needs_missing\ncommand: /bin/true\ndepends_on: missing\n"
      "process elsewhere\ncommand: /bin/true\nnode: robot-pc.example\n"
      "process fine\ncommand: /bin/sleep 1000\n");
  for (const char* name : {"missing", "bare", "no_exec", "no_dir", "needs_missing", "elsewhere", "fine"})
    control(name, "start");
  EXPECT_NE(wait_state("missing", "failed").error.find("command not found: '/no/such/program' does not exist"),
            std::string::npos);
  EXPECT_NE(wait_state("bare", "failed").error.find("'sleep' has no directory"), std::string::npos);
  EXPECT_NE(wait_state("no_exec", "failed").error.find("permission denied"), std::string::npos);
  EXPECT_NE(wait_state("no_dir", "failed").error.find("cannot change to its directory: No such file"),
            std::string::npos);
  EXPECT_NE(wait_state("needs_missing", "failed").error.find("dependency 'missing' failed"), std::string::npos);
  EXPECT_NE(wait_state("elsewhere", "failed").error.find("runs on node 'robot-pc.example'"), std::string::npos);
  wait_state("fine", "started");
  EXPECT_NE(manager->count_log("process 'missing': cannot start"), 0u);
  const Message unknown = control("nobody", "start");
  EXPECT_EQ(unknown.error_code(), LNE_INVALID_PARAMETER);
  EXPECT_NE(unknown.error_text().find("there is no process, state or group 'nobody'"), std::string::npos);
}

TEST_F(ProcessControlTest, ExitStatusAndSignalsAreReported) {
  start(
      "process exits\ncommand: /bin/sh -c 'echo bye; exit 3'\n"
      "process killed\ncommand: /bin/sh -c 'kill -9 $$'\n"
      "process done\ncommand: /bin/true\nflags: no_error_on_successful_stop\n");
  control("exits", "start");
  control("killed", "start");
  control("done", "start");
  const Row exits = wait_state("exits", "failed");
  EXPECT_EQ(exits.last_exit, "exit status 3");
  EXPECT_EQ(exits.error, "terminated unexpectedly (exit status 3)");
  EXPECT_EQ(wait_state("killed", "failed").last_exit, "killed by SIGKILL");
  const Row done = wait_state("done", "stopped");
  EXPECT_EQ(done.last_exit, "exit status 0");
  EXPECT_EQ(done.error, "");
  EXPECT_TRUE(manager->wait_for_log("'exits' (pid"));
  EXPECT_NE(manager->count_log("terminated unexpectedly: exit status 3"), 0u);
  const auto lines = output("exits");
  EXPECT_NE(std::find(lines.begin(), lines.end(), "bye"), lines.end());
  EXPECT_NE(std::find(lines.begin(), lines.end(), "[ln_manager] terminated unexpectedly (exit status 3)"), lines.end());
}

TEST_F(ProcessControlTest, AutoRestartBacksOff) {
  start(
      "process flaky\n"
      "command: /bin/sh -c 'date +%s.%N >> %(DIR)/starts; exit 1'\n"
      "auto_restart_interval: 0.1\n");
  control("flaky", "start");
  const auto deadline = Clock::now() + 15s;
  std::vector<double> times;
  while (times.size() < 5 && Clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
    std::istringstream starts(file("starts"));
    times.clear();
    for (double t; starts >> t;) times.push_back(t);
  }
  ASSERT_GE(times.size(), 5u) << manager->log_text();
  EXPECT_GE(row("flaky").restarts, 4u);
  // 0.1 s after the first exit, then twice as long each time it failed at once
  const double minimum[] = {0.1, 0.2, 0.4, 0.8};
  for (std::size_t i = 0; i < 4; ++i) EXPECT_GE(times[i + 1] - times[i], minimum[i]) << "restart " << i + 1;
  control("flaky", "stop");
  const Row stopped = wait_state("flaky", "stopped");
  EXPECT_EQ(stopped.pid, 0);
}

TEST_F(ProcessControlTest, StopsDependentsFirstAndKillsWhatIgnoresItsSignal) {
  const std::string trap =
      "trap 'echo stop %(_PROCESS) >> %(DIR)/stops; exit 0' TERM; echo up; while :; do sleep 0.05; done";
  start("process base\ncommand: /bin/sh -c \"" + trap +
        "\"\nready_regex: up\n"
        "process middle\ncommand: /bin/sh -c \"" +
        trap +
        "\"\nready_regex: up\ndepends_on: base\n"
        "process top\ncommand: /bin/sh -c \"" +
        trap +
        "\"\nready_regex: up\ndepends_on_restart: middle\n"
        "process stubborn\ncommand: /bin/sh -c \"trap '' TERM INT; echo up; while :; do sleep 0.05; done\"\n"
        "ready_regex: up\nterm_signal: SIGINT\nterm_timeout: 0.3\n");
  control("top", "start");
  control("stubborn", "start");
  wait_state("top", "ready");
  const long stubborn = wait_state("stubborn", "ready").pid;
  // an explicit stop stops the depends_on_restart dependents first
  control("middle", "stop");
  wait_state("middle", "stopped");
  EXPECT_EQ(row("top").state, "stopped");
  EXPECT_EQ(row("base").state, "ready") << "a stop does not stop what it depends on";
  EXPECT_EQ(file("stops"), "stop top\nstop middle\n");
  control("stubborn", "stop");
  EXPECT_EQ(wait_state("stubborn", "stopped").last_exit, "killed by SIGKILL");
  EXPECT_TRUE(manager->count_log("did not stop within 0.3 s after SIGINT: SIGKILL") > 0);
  EXPECT_FALSE(alive(stubborn));

  // the manager's shutdown: everything, dependents first
  control("top", "start");
  wait_state("top", "ready");
  ::unlink((dir.path() + "/stops").c_str());
  stop_manager();
  EXPECT_EQ(file("stops"), "stop top\nstop middle\nstop base\n");
}

TEST_F(ProcessControlTest, RestartAlsoRestartsDependentsWithDependsOnRestart) {
  start(
      "process server\ncommand: /bin/sh -c 'echo up; exec sleep 1000'\nready_regex: up\n"
      "process client\ncommand: /bin/sleep 1000\ndepends_on_restart: server\n"
      "process viewer\ncommand: /bin/sleep 1000\ndepends_on: server\n");
  control("client", "start");
  control("viewer", "start");
  const long client_pid = wait_state("client", "started").pid;
  const long viewer_pid = wait_state("viewer", "started").pid;
  const long server_pid = row("server").pid;
  control("server", "restart");
  const auto deadline = Clock::now() + 10s;
  while ((row("server").pid == server_pid || row("client").pid == client_pid || row("client").state != "started") &&
         Clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  EXPECT_NE(row("server").pid, server_pid);
  EXPECT_NE(row("client").pid, client_pid) << "depends_on_restart: restarted with it";
  EXPECT_EQ(row("viewer").pid, viewer_pid) << "depends_on: left running";

  // when the server dies, its depends_on_restart dependents stop and wait
  ::kill(static_cast<pid_t>(row("server").pid), SIGKILL);
  EXPECT_EQ(wait_state("server", "failed").last_exit, "killed by SIGKILL");
  EXPECT_NE(wait_state("client", "failed").error.find("dependency 'server' failed"), std::string::npos)
      << manager->log_text();
  EXPECT_TRUE(manager->count_log("'viewer' depends on 'server', which is no longer running") > 0);
}

TEST_F(ProcessControlTest, ADependencyNamedInBothListsStopsItsDependentOnce) {
  start(
      "process server\ncommand: /bin/sh -c 'echo up; exec sleep 1000'\nready_regex: up\nauto_restart_interval: 0.1\n"
      "process client\ncommand: /bin/sleep 1000\ndepends_on: server\ndepends_on_restart: server\n");
  control("client", "start");
  const long client_pid = wait_state("client", "started").pid;
  ::kill(static_cast<pid_t>(row("server").pid), SIGKILL);
  const auto deadline = Clock::now() + 10s;
  while ((row("client").pid == client_pid || row("client").state != "started") && Clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  EXPECT_NE(row("client").pid, client_pid) << "restarted with the server";
  EXPECT_EQ(manager->count_log("stopping 'client': it depends on 'server' (depends_on_restart)"), 1u)
      << manager->log_text();
}

TEST_F(ProcessControlTest, NothingOfAProcessGroupOutlivesIt) {
  start(
      "process parent\n"
      "command: /bin/sh -c '/bin/sleep 1000 & echo $! > %(DIR)/child; echo started child; wait'\n"
      "ready_regex: started child\n");
  control("parent", "start");
  const long parent = wait_state("parent", "ready").pid;
  ASSERT_TRUE(wait_file("child", "\n"));
  const long child = std::stol(file("child"));
  ASSERT_TRUE(alive(child));
  ::kill(static_cast<pid_t>(parent), SIGKILL);
  wait_state("parent", "failed");
  EXPECT_TRUE(wait_gone(child)) << "its child got the term signal when it died\n" << manager->log_text();

  ::unlink((dir.path() + "/child").c_str());
  control("parent", "start");
  wait_state("parent", "ready");
  ASSERT_TRUE(wait_file("child", "\n"));
  const long second = std::stol(file("child"));
  ASSERT_NE(second, child);
  stop_manager();
  EXPECT_TRUE(wait_gone(second)) << "a manager that stops leaves nothing behind";
}

TEST_F(ProcessControlTest, OutputIsABoundedRingAndCanBeLogged) {
  start(
      "process chatty\n"
      "command: /bin/sh -c 'i=1; while [ $i -le 100 ]; do echo line $i; i=$((i+1)); done'\n"
      "flags: no_error_on_successful_stop, no_pty\n"
      "max_output_lines: 10\n"
      "output_logfile: %(DIR)/chatty.log\n"
      "output_logfile_size_limit: 400b\n"
      "output_logfile_keep_count: 2\n");
  control("chatty", "start");
  wait_state("chatty", "stopped");
  const Message all = client->call("process_output", [&](Message& m) { m.set("name", "chatty").set("after", 0); });
  const auto lines = all.get_list("lines");
  ASSERT_EQ(lines.size(), 10u);
  EXPECT_EQ(lines.back(), "[ln_manager] ended (exit status 0)");
  EXPECT_EQ(lines[lines.size() - 2], "line 100");
  EXPECT_GT(all.get_int("dropped"), 90);
  const std::int64_t last = all.get_int("last");
  const Message none = client->call("process_output", [&](Message& m) { m.set("name", "chatty").set("after", last); });
  EXPECT_TRUE(none.get_list("lines").empty()) << "nothing new after the last line";
  EXPECT_EQ(none.get_int("dropped"), 0);
  // rotated at 400 bytes: the newest lines in the file, older ones in .1 and .2
  EXPECT_NE(file("chatty.log").find("[ln_manager] ended"), std::string::npos);
  EXPECT_LE(file("chatty.log").size(), 400u);
  EXPECT_FALSE(file("chatty.log.2").empty());
  EXPECT_TRUE(file("chatty.log.3").empty()) << "keep_count 2";
}

TEST_F(ProcessControlTest, EnvironmentAsLn29GivesIt) {
  ::setenv("LN_PC_TEST_PASS", "passed", 1);
  // The manager's own search path must not be empty, whatever the build
  // installs: the ASan build has no installed definitions.
  const std::string definitions = dir.path() + "/definitions";
  dir.write("definitions/placeholder", "double a\n");
  start(
      "process env\n"
      "command: /usr/bin/env\n"
      "environment: EXTRA=1, LN_MESSAGE_DEFINITION_DIRS=/configured\n"
      "pass_environment: LN_PC_TEST_*\n"
      "map_topic: a => b\n"
      "flags: no_error_on_successful_stop\n",
      [&](ManagerOptions& options) { options.message_definition_dirs = {definitions}; });
  control("env", "start");
  wait_state("env", "stopped");
  std::map<std::string, std::string> env;
  for (const auto& line : output("env"))
    if (const auto equals = line.find('='); equals != std::string::npos && line.rfind("[ln_manager]", 0) != 0)
      env[line.substr(0, equals)] = line.substr(equals + 1);
  EXPECT_EQ(env["LN_MANAGER"], "127.0.0.1:" + std::to_string(manager->port()));
  EXPECT_EQ(env["LN_PROGRAM_NAME"], "env");
  EXPECT_EQ(env["TERM"], "xterm");
  EXPECT_EQ(env["EXTRA"], "1");
  EXPECT_EQ(env["LN_PC_TEST_PASS"], "passed");
  EXPECT_EQ(env["LN_MAP_TOPICS"], "a|b");
  EXPECT_EQ(env["LN_MESSAGE_DEFINITION_DIRS"].rfind("/configured:" + definitions, 0), 0u)
      << "the manager's search path follows: " << env["LN_MESSAGE_DEFINITION_DIRS"];
  EXPECT_EQ(env.count("HOME"), 0u) << "a minimal environment: nothing passed that was not asked for";
}

// The flag set_user_and_home adds USER and HOME of the manager's user, as
// LN 2.9's daemon does; a configured value stays.
TEST_F(ProcessControlTest, SetUserAndHomeAddsTheManagersUser) {
  start(
      "process both\ncommand: /usr/bin/env\nflags: set_user_and_home, no_error_on_successful_stop\n"
      "process own_home\ncommand: /usr/bin/env\nenvironment: HOME=/configured\n"
      "flags: set_user_and_home, no_error_on_successful_stop\n");
  control("both", "start");
  control("own_home", "start");
  wait_state("both", "stopped");
  wait_state("own_home", "stopped");
  const passwd* account = ::getpwuid(::geteuid());
  ASSERT_NE(account, nullptr);
  auto has = [&](const std::string& name, const std::string& line) {
    const auto lines = output(name);
    return std::find(lines.begin(), lines.end(), line) != lines.end();
  };
  EXPECT_TRUE(has("both", std::string("USER=") + account->pw_name)) << manager->log_text();
  EXPECT_TRUE(has("both", std::string("HOME=") + account->pw_dir));
  EXPECT_TRUE(has("own_home", "HOME=/configured"));
  EXPECT_FALSE(has("own_home", std::string("HOME=") + account->pw_dir));
}

// Without change_directory a process starts in /tmp, as LN 2.9's daemon
// starts it, not in the manager's working directory.
TEST_F(ProcessControlTest, ProcessesStartInTmpUnlessChangeDirectorySaysOtherwise) {
  dir.write("sub/placeholder", "");
  start(
      "process where\ncommand: /bin/pwd\nflags: no_error_on_successful_stop\n"
      "process there\ncommand: /bin/pwd\nchange_directory: %(DIR)/sub\nflags: no_error_on_successful_stop\n");
  control("where", "start");
  control("there", "start");
  wait_state("where", "stopped");
  wait_state("there", "stopped");
  const auto where = output("where");
  const auto there = output("there");
  EXPECT_NE(std::find(where.begin(), where.end(), "/tmp"), where.end()) << manager->log_text();
  EXPECT_NE(std::find(there.begin(), there.end(), dir.path() + "/sub"), there.end()) << manager->log_text();
}

TEST_F(ProcessControlTest, StatesCheckGoUpAndDown) {
  start(
      "state flag\n"
      "check: test -f %(DIR)/flag\n"
      "up: touch %(DIR)/flag\n"
      "down: rm %(DIR)/flag\n"
      "min_check_interval: 0\n"
      "state broken\n"
      "check: false\n"
      "up: exit 2\n"
      "process user\n"
      "command: /bin/sleep 1000\n"
      "depends_on: flag\n");
  control("flag", "check");
  wait_state("flag", "DOWN");
  control("user", "start");
  wait_state("user", "started");
  EXPECT_EQ(row("flag").state, "UP") << "brought up for its dependent";
  EXPECT_EQ(::access((dir.path() + "/flag").c_str(), F_OK), 0) << "its up command ran";
  control("flag", "down");
  wait_state("flag", "DOWN");
  control("broken", "up");
  EXPECT_NE(wait_state("broken", "error").error.find("its up command failed (exit status 2)"), std::string::npos);
}

// State commands run in /tmp, as LN 2.9's daemon runs them, with this
// manager's address also when the manager's own environment names another.
TEST_F(ProcessControlTest, StateCommandsRunInTmpWithThisManager) {
  ::setenv("LN_MANAGER", "elsewhere:1234", 1);
  start("state where\ncheck: pwd > %(DIR)/where; echo $LN_MANAGER >> %(DIR)/where\n");
  control("where", "check");
  wait_state("where", "UP");
  ::unsetenv("LN_MANAGER");
  EXPECT_EQ(file("where"), "/tmp\n127.0.0.1:" + std::to_string(manager->port()) + "\n");
}

TEST_F(ProcessControlTest, GroupsStartBeforeAndSuccessfulStops) {
  start(
      "process prepare\ncommand: /bin/sh -c 'echo prepare >> %(DIR)/order'\nflags: no_error_on_successful_stop\n"
      "start_on_successful_stop: announce\n"
      "process announce\ncommand: /bin/sh -c 'echo announce >> %(DIR)/order'\nflags: no_error_on_successful_stop\n"
      "process worker\ncommand: /bin/sh -c 'echo worker >> %(DIR)/order; exec sleep 1000'\nstart_before: prepare\n"
      "process helper\ncommand: /bin/sleep 1000\n"
      "group all\nmembers: worker, helper\n");
  control("all", "start");
  wait_state("worker", "started");
  wait_state("helper", "started");
  ASSERT_TRUE(wait_file("order", "announce")) << "start_on_successful_stop of prepare";
  ASSERT_TRUE(wait_file("order", "worker"));
  EXPECT_EQ(file("order").rfind("prepare\n", 0), 0u) << "start_before ran to completion first";
  control("all", "stop");
  wait_state("worker", "stopped");
  wait_state("helper", "stopped");
}

// A job that ends well before its ready line (or ready_time) is done: it is
// not started again, neither for its own start request nor for a dependent,
// which fails with the reason instead.
TEST_F(ProcessControlTest, AJobThatEndsWellBeforeItIsReadyIsNotStartedAgain) {
  start(
      "process job\ncommand: /bin/sh -c 'echo run >> %(DIR)/runs'\nready_regex: ^never\n"
      "flags: no_error_on_successful_stop\n"
      "process after\ncommand: /bin/sleep 1000\ndepends_on: job\n");
  control("job", "start");
  const Row job = wait_state("job", "stopped");
  EXPECT_EQ(job.last_exit, "exit status 0");
  EXPECT_EQ(job.error, "");
  auto runs = [&] {
    const std::string text = file("runs");
    return std::count(text.begin(), text.end(), '\n');
  };
  EXPECT_EQ(runs(), 1);
  control("after", "start");
  EXPECT_NE(wait_state("after", "failed").error.find("dependency 'job' ended (exit status 0)"), std::string::npos);
  EXPECT_EQ(row("job").requested, "");
  EXPECT_EQ(runs(), 2) << "started once more for 'after', then not again";
}

TEST_F(ProcessControlTest, UserStopIsSuccessfulStopStartsWhatFollowsAStop) {
  start(
      "process service\ncommand: /bin/sleep 1000\nflags: user_stop_is_successful_stop\n"
      "start_on_successful_stop: cleanup\n"
      "process plain\ncommand: /bin/sleep 1000\nstart_on_successful_stop: plain_cleanup\n"
      "process cleanup\ncommand: /bin/sh -c 'echo cleanup >> %(DIR)/runs'\nflags: no_error_on_successful_stop\n"
      "process plain_cleanup\ncommand: /bin/true\nflags: no_error_on_successful_stop\n");
  control("plain", "start");
  wait_state("plain", "started");
  control("plain", "stop");
  wait_state("plain", "stopped");
  const Row plain_cleanup = row("plain_cleanup");
  EXPECT_EQ(plain_cleanup.requested + plain_cleanup.last_exit, "") << "a stop asked for is no successful stop";
  control("service", "start");
  wait_state("service", "started");
  control("service", "stop");
  wait_state("service", "stopped");
  ASSERT_TRUE(wait_file("runs", "cleanup")) << "with the flag it is";
}

TEST_F(ProcessControlTest, NiceAffinityAndResourceLimitsApply) {
  start(
      "process tuned\n"
      "command: /bin/sh -c 'echo nice $(cut -d\\  -f19 /proc/self/stat); grep Cpus_allowed_list /proc/self/status; "
      "echo files $(ulimit -n)'\n"
      "nice: 7\n"
      "affinity: 0\n"
      "set_resource_limits: NOFILE=64\n"
      "flags: no_error_on_successful_stop\n");
  control("tuned", "start");
  wait_state("tuned", "stopped");
  std::string all;
  for (const auto& line : output("tuned")) all += line + "\n";
  EXPECT_NE(all.find("nice 7\n"), std::string::npos) << all;
  EXPECT_NE(all.find("Cpus_allowed_list:\t0\n"), std::string::npos) << all;
  EXPECT_NE(all.find("files 64\n"), std::string::npos) << all;
}

TEST_F(ProcessControlTest, AutoCheckIntervalFollowsAState) {
  start(
      "state door\n"
      "check: test -f %(DIR)/open\n"
      "auto_check_interval: 0.1\n");
  wait_state("door", "DOWN");
  dir.write("open", "");
  wait_state("door", "UP");
  ::unlink((dir.path() + "/open").c_str());
  wait_state("door", "DOWN");
}

TEST_F(ProcessControlTest, NeedsProviderStartsTheConfiguredProvider) {
  start(
      "process provider\ncommand: /bin/sleep 1000\nprovides: robot.svc\n"
      "process better\ncommand: /bin/sleep 1000\nprovides: robot.svc:5\n");
  const Message answer = client->call("needs_provider", [&](Message& m) { m.set("name", "robot.svc"); });
  ASSERT_FALSE(answer.is_error()) << answer.error_text();
  EXPECT_EQ(answer.get_string("provider"), "better") << "the highest priority";
  wait_state("better", "started");
  EXPECT_EQ(row("provider").state, "stopped");
  const Message none = client->call("needs_provider", [&](Message& m) { m.set("name", "nobody.svc"); });
  EXPECT_EQ(none.error_code(), LNE_NO_PROVIDER_FOUND);
}

}  // namespace
}  // namespace ln::manager
