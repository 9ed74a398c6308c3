// Test support for the client tests: the in-process ln_manager and temporary
// directory of src/testing/, bounded waiting (test_waiting.hpp), scoped
// environment variables and child processes.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <ln/ln.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <initializer_list>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "client/test_waiting.hpp"
#include "testing/in_process_manager.hpp"
#include "testing/temp_dir.hpp"

extern char** environ;

namespace ln::clienttest {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

#ifndef LN_TEST_MD_DIR
#error "LN_TEST_MD_DIR must name the test message definitions"
#endif

using test::TempDir;

/// The in-process manager (testing/in_process_manager.hpp) with the client
/// tests' definitions (LN_TEST_MD_DIR) unless told other directories.
class InProcessManager : public test::InProcessManager {
 public:
  explicit InProcessManager(std::uint16_t port = 0, std::vector<std::string> md_dirs = {LN_TEST_MD_DIR})
      : test::InProcessManager(std::move(md_dirs), {}, port) {}
};

/// A C API client of the manager at `address` (nullptr, and a test failure, when it cannot connect).
inline ln_client connect_to(const std::string& address, const char* name) {
  ln_client client = nullptr;
  EXPECT_EQ(ln_init_to_manager(&client, name, address.c_str()), 0) << name << ": " << address;
  return client;
}

/// Deinitialises each client that is not nullptr (the end of a test's clients).
inline void deinit_clients(std::initializer_list<ln_client*> clients) {
  for (ln_client* c : clients)
    if (*c != nullptr) ln_deinit(c);
}

/// A list of lines that handler threads add to and the test reads.
struct LockedLines {
  std::mutex mutex;
  std::vector<std::string> lines;
  void add(const std::string& line) {
    std::lock_guard<std::mutex> lock(mutex);
    lines.push_back(line);
  }
  std::vector<std::string> copy() {
    std::lock_guard<std::mutex> lock(mutex);
    return lines;
  }
};

/// Sets (or, with nullopt, removes) an environment variable for a scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = ::getenv(name)) old_ = old;
    if (value)
      ::setenv(name, value->c_str(), 1);
    else
      ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_.c_str(), old_->c_str(), 1);
    else
      ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

/// A program of this test, its stdout and stderr captured; killed if still
/// running at the end.
class ChildProcess {
 public:
  ChildProcess(const std::vector<std::string>& args, const std::string& manager_address,
               const std::vector<std::string>& extra_env = {}) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
    output_ = fds[0];
    std::vector<std::string> env_strings;
    for (char** e = environ; *e != nullptr; ++e) {
      if (std::strncmp(*e, "LN_", 3) != 0) env_strings.emplace_back(*e);
    }
    env_strings.push_back("LN_MANAGER=" + manager_address);
    for (const std::string& entry : extra_env) env_strings.push_back(entry);
    std::vector<char*> env;
    for (auto& s : env_strings) env.push_back(s.data());
    env.push_back(nullptr);
    std::vector<std::string> arg_strings = args;
    std::vector<char*> argv;
    for (auto& s : arg_strings) argv.push_back(s.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
    const int error = ::posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), env.data());
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    if (error != 0) throw std::runtime_error("posix_spawn " + args[0] + ": " + std::strerror(error));
  }
  ~ChildProcess() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    ::close(output_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  /// The next output line starting with `prefix`, or "" after `timeout`.
  std::string wait_for_line(const std::string& prefix, std::chrono::milliseconds timeout = 10s) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      for (auto newline = buffer_.find('\n'); newline != std::string::npos; newline = buffer_.find('\n')) {
        std::string line = buffer_.substr(0, newline);
        buffer_.erase(0, newline + 1);
        if (line.compare(0, prefix.size(), prefix) == 0) return line;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return "";
      pollfd readable{output_, POLLIN, 0};
      if (::poll(&readable, 1, static_cast<int>(left)) <= 0) continue;
      char chunk[4096];
      const ssize_t n = ::read(output_, chunk, sizeof chunk);
      if (n <= 0) return "";
      buffer_.append(chunk, static_cast<size_t>(n));
    }
  }
  /// Exit status, or -1 if it did not exit within `timeout`.
  int wait(std::chrono::milliseconds timeout = 15s) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      int status = 0;
      const pid_t done = ::waitpid(pid_, &status, WNOHANG);
      if (done == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      if (Clock::now() >= deadline) return -1;
      std::this_thread::sleep_for(5ms);
    }
  }
  void kill(int signal) { ::kill(pid_, signal); }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int output_ = -1;
  std::string buffer_;
};

/// A test with its own in-process manager (no topic maps from the environment) and C API clients
/// of it.
class OwnManagerTest : public ::testing::Test {
 protected:
  ln_client connect(const char* name) { return connect_to(manager_.address(), name); }

  ScopedEnv no_topic_map_{"LN_MAP_TOPICS", std::nullopt};
  InProcessManager manager_;
};

}  // namespace ln::clienttest
