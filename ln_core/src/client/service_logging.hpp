// Service logging (ln_register_as_service_logger), the client's part. The
// manager tells each client which logger services get copies of the calls
// of which services (methods.hpp: log_services, add_/del_service_logger);
// callers then report every request they sent and providers every response
// they sent (services/call_log.hpp), and this object sends each of them to
// its loggers as an ln/log_service request, the fields as LN 2.9 fills them:
//   client_name (the sender), service_name, service_interface,
//   item_type 0 (request, from the caller) or 1 (response, from the provider),
//   flags: bit 1 set for requests (data starts with LN's request header),
//   completion_time (request: when the call started; response: when it was
//   answered), transfer_time (seconds sending it), request_time (responses:
//   when the request had arrived), peer_address (the provider's socket),
//   client_id and request_id (the caller's client id and the request's id,
//   the same in both items of a call), thread_id (the sender's thread),
//   data: the request as LN 2.9 sends it (u32 size, u16 library version,
//   u32 client id, u32 request id, the flat request) or the response
//   (u32 size, i32 status, and for status 0 the flat response).
//
// Unlike LN 2.9 the logged call never waits for its loggers: items are
// queued (at most kMaxQueuedItems; beyond that the oldest are dropped and
// counted in the debug log) and sent by a thread of this object, in order.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "services/call_log.hpp"
#include "services/call_state.hpp"

namespace ln::clientlib {

class Client;
class ServicesGlue;

class ServiceLogging : public services::CallLog {
 public:
  static constexpr std::size_t kMaxQueuedItems = 10000;

  ServiceLogging(Client& client, ServicesGlue& glue);
  ~ServiceLogging() override;
  ServiceLogging(const ServiceLogging&) = delete;
  ServiceLogging& operator=(const ServiceLogging&) = delete;

  /// Hooks into the client's notifications and reconnects; starts the sender.
  void start();
  /// Ends the sender (aborting a running call); idempotent.
  void stop();

  /// ln_register_as_service_logger() (`logger_service` already mapped).
  /// Throws Failure.
  void register_logger(const std::string& logger_service, const std::string& patterns);
  /// The loggers of `service` (a register_service or lookup_service answer's
  /// log_services); `interface` is kept for the log items of providers.
  void set_loggers(const std::string& service, const std::string& interface, const std::vector<std::string>& loggers);

  void record(const Item& item) override;

 private:
  struct Queued {
    std::string logger;
    std::string request;  // flat ln/log_service request
  };

  void add_logger(const std::string& service, const std::string& logger);
  void remove_logger(const std::string& logger);
  void update_enabled_locked();
  void send_main();

  Client& client_;
  ServicesGlue& glue_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, std::set<std::string>> loggers_;  // by logged service
  std::map<std::string, std::string> interfaces_;         // of provided services
  std::map<std::string, std::string> own_loggers_;        // logger service -> patterns (for reconnects)
  std::deque<Queued> queue_;
  std::uint64_t dropped_ = 0;
  services::ServiceCaller* sending_ = nullptr;  // the call in flight, for stop()
  bool stopping_ = false;
  std::thread sender_;
};

}  // namespace ln::clientlib
