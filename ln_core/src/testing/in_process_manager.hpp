// The ln_manager of a test, running in a thread of the test process on
// 127.0.0.1: a free port unless given one (a restart keeps its port), its
// generated definitions in a temporary directory, its log kept for asserts.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "manager/manager.hpp"
#include "testing/temp_dir.hpp"
#include "testing/wait.hpp"

namespace ln::test {

class InProcessManager {
 public:
  /// Changes to the options before the manager is made (after the defaults above).
  using Adjust = std::function<void(manager::ManagerOptions&)>;

  /// Starts on `port` (0: a free one), searching `md_dirs` for definitions.
  explicit InProcessManager(std::vector<std::string> md_dirs, Adjust adjust = {}, std::uint16_t port = 0)
      : md_dirs_(std::move(md_dirs)), adjust_(std::move(adjust)) {
    start(port);
  }
  ~InProcessManager() { stop(); }
  InProcessManager(const InProcessManager&) = delete;
  InProcessManager& operator=(const InProcessManager&) = delete;

  void start(std::uint16_t port = 0) {
    manager::ManagerOptions options;
    options.port = port;
    options.message_definition_dirs = md_dirs_;
    options.generated_definition_dir = generated_.path();
    options.log = [this](manager::LogLevel level, const std::string& text) {
      std::lock_guard<std::mutex> lock(mutex_);
      log_.push_back(std::string(manager::level_name(level)) + ": " + text);
    };
    if (adjust_) adjust_(options);
    manager_ = std::make_unique<manager::Manager>(options);
    // A restart on the same port may briefly race the old socket's teardown.
    for (int attempt = 0;; ++attempt) {
      try {
        manager_->start();
        break;
      } catch (const std::runtime_error&) {
        if (port == 0 || attempt > 100) throw;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    port_ = manager_->port();
    manager_->run_in_thread();
  }
  /// Stops the manager; every client connection drops.
  void stop() {
    if (manager_) manager_->stop();
    manager_.reset();
  }
  void restart() {
    stop();
    start(port_);
  }

  std::uint16_t port() const { return port_; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  manager::Manager& manager() { return *manager_; }

  /// Waits (bounded) until a log line contains `text`.
  bool wait_for_log(const std::string& text,
                    std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) const {
    return wait_until([&] { return count_log(text) > 0; }, timeout);
  }
  /// Everything logged so far, for failure messages.
  std::string log_text() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string out;
    for (const auto& line : log_) out += line + "\n";
    return out;
  }
  std::size_t count_log(const std::string& text) const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t n = 0;
    for (const auto& line : log_) n += line.find(text) != std::string::npos;
    return n;
  }

 private:
  std::vector<std::string> md_dirs_;
  Adjust adjust_;
  TempDir generated_{"ln_manager_generated"};
  mutable std::mutex mutex_;
  std::vector<std::string> log_;
  std::unique_ptr<manager::Manager> manager_;
  std::uint16_t port_ = 0;
};

}  // namespace ln::test
