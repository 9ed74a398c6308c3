// Test support for the client tests: an in-process ln_manager on a free
// loopback port (restartable on the same port), bounded waiting, and scoped
// environment variables.
#pragma once

#include <stdlib.h>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "manager/manager.hpp"

namespace ln::clienttest {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

#ifndef LN_TEST_MD_DIR
#  error "LN_TEST_MD_DIR must name the test message definitions"
#endif

/// A directory that is removed with everything in it.
class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/ln_client_test_XXXXXX";
    if (!::mkdtemp(pattern)) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    const std::string command = "rm -rf '" + path_ + "'";
    (void)!::system(command.c_str());
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// An ln_manager running in a thread of the test process.
class InProcessManager {
 public:
  /// Starts on `port` (0: any free port).
  explicit InProcessManager(std::uint16_t port = 0) { start(port); }
  ~InProcessManager() { stop(); }

  void start(std::uint16_t port = 0) {
    manager::ManagerOptions options;
    options.port = port;
    options.message_definition_dirs = {LN_TEST_MD_DIR};
    options.generated_definition_dir = generated_.path();
    manager_ = std::make_unique<manager::Manager>(options);
    // A restart on the same port may briefly race the old socket's teardown.
    for (int attempt = 0;; ++attempt) {
      try {
        manager_->start();
        break;
      } catch (const std::runtime_error&) {
        if (attempt > 100) throw;
        std::this_thread::sleep_for(20ms);
      }
    }
    port_ = manager_->port();
    manager_->run_in_thread();
  }
  /// Stops the manager; every client connection drops.
  void stop() { manager_.reset(); }
  void restart() {
    stop();
    start(port_);
  }

  std::uint16_t port() const { return port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

 private:
  TempDir generated_;
  std::unique_ptr<manager::Manager> manager_;
  std::uint16_t port_ = 0;
};

/// Polls `condition` until it holds or `timeout` passes.
inline bool wait_until(const std::function<bool()>& condition, std::chrono::milliseconds timeout = 5000ms) {
  const auto deadline = Clock::now() + timeout;
  while (!condition()) {
    if (Clock::now() >= deadline) return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

/// Sets (or, with nullopt, removes) an environment variable for a scope.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, std::optional<std::string> value) : name_(name) {
    if (const char* old = ::getenv(name)) old_ = old;
    if (value) ::setenv(name, value->c_str(), 1);
    else ::unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) ::setenv(name_.c_str(), old_->c_str(), 1);
    else ::unsetenv(name_.c_str());
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  std::string name_;
  std::optional<std::string> old_;
};

}  // namespace ln::clienttest
