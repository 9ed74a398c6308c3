// The real ln_manager executable: start-up line, config, signals, exit
// codes, and running out of file descriptors. Every child is bounded and
// killed by its PID.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include <fstream>
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
                       "process ignored\n"
                       "command: sleep 1\n");
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
  EXPECT_NE(log.find("the section type 'process' is not supported"), std::string::npos) << log;
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

}  // namespace
}  // namespace ln::manager::testing
