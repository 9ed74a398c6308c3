// The hook of service logging (ln_register_as_service_logger): callers
// report every request they sent, providers every response they sent, to
// a CallLog the client core supplies (client/service_logging.hpp). While
// no logger exists the hook costs one relaxed atomic load per call.
#pragma once

#include <atomic>
#include <cstdint>
#include <string_view>

namespace ln::services {

class CallLog {
 public:
  struct Item {
    std::string_view service;     ///< the service's name
    std::string_view interface;   ///< callers: the interface they asked for ("" on the provider side)
    bool response = false;        ///< false: a request a caller sent; true: a response a provider sent
    std::uint32_t caller_id = 0;  ///< the calling client's id (from the request frame)
    std::uint32_t request_id = 0;
    int result = 0;              ///< responses: 0, or the error the caller gets
    std::string_view flat;       ///< the flat request or (successful) response
    double completion_time = 0;  ///< wall clock: call started / respond() called
    double transfer_time = 0;    ///< seconds spent sending it
    double request_time = 0;     ///< responses: wall clock when the request had arrived
    int fd = -1;                 ///< the call's connection (for the provider's address)
  };

  virtual ~CallLog() = default;
  /// Whether any service is logged at all (then record() is called).
  bool enabled() const { return enabled_.load(std::memory_order_relaxed); }
  /// This client's id, which callers put into their request frames.
  std::uint32_t client_id() const { return client_id_.load(std::memory_order_relaxed); }
  /// Must not block: called on the call path, after the frame is sent.
  virtual void record(const Item& item) = 0;

 protected:
  std::atomic<bool> enabled_{false};
  std::atomic<std::uint32_t> client_id_{0};
};

/// Wall-clock seconds (ln_get_time()), for log items.
double wall_clock_seconds();

}  // namespace ln::services
