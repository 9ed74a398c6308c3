// Topic loggers on the client side (ln_logger; the manager records, see
// manager/loggers.hpp): as in LN 2.9 the topic list and only_ts stay here
// until enable() hands them to the manager, which keeps the logger under its
// name for every client. A client owns one Logger per name
// (ln_client_get_logger returns the same one again) and the logger owns the
// data of its last download.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "client/logger_data.hpp"

namespace ln::clientlib {

class Client;

class Logger {
 public:
  Logger(Client& client, std::string name);
  ~Logger();
  Logger(const Logger&) = delete;
  Logger& operator=(const Logger&) = delete;

  /// True while `handle` is a Logger that has not been destroyed.
  static bool alive(const void* handle);

  const std::string& name() const { return name_; }
  Client& client() const { return client_; }
  /// Adds a topic, or changes the log size and divisor of one added before.
  /// Throws Failure (LNE_INVALID_PARAMETER: empty name, log size 0).
  void add_topic(const std::string& topic, std::uint64_t log_size, std::uint32_t divisor);
  void clear_topics();
  void set_only_ts(bool only_ts);
  /// Starts a new recording of the topics added (LNE_NO_LOGGER_TOPICS without any).
  void enable();
  void disable();
  /// The manager's recording of this logger; replaces (invalidates) the
  /// data of the previous download.
  LoggerData* download();
  /// LN 2.9's direct download disables the logger, then downloads.
  LoggerData* direct_download();
  void manager_save(const std::string& filename, const std::string& format);

 private:
  struct Entry {
    std::string topic;
    std::uint64_t log_size;
    std::uint32_t divisor;
  };

  Client& client_;
  const std::string name_;
  std::mutex mutex_;
  std::vector<Entry> topics_;
  bool only_ts_ = false;
  std::unique_ptr<LoggerData> data_;
};

/// The loggers of one client (Client::part_state("loggers")).
class ClientLoggers {
 public:
  explicit ClientLoggers(Client& client) : client_(client) {}
  /// The logger of that name, made on first use.
  Logger* get(const std::string& name);

 private:
  Client& client_;
  std::mutex mutex_;
  std::map<std::string, std::unique_ptr<Logger>> loggers_;
};

}  // namespace ln::clientlib
