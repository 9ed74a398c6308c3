// Events (ln_event_connect ...), as LN 2.9 has them: a client connects to an
// event by providing a handler service "<event name>.<client name>"
// (interface ln/event/call: the event's flat data and its call signature)
// in its default service group; whoever emits the event calls that service,
// so the handler runs in the thread that handles the default group, one
// event at a time. For events named "ln.*" the manager is the emitter: the
// connection is announced to it (connect_event, with the flat connect data)
// and its `event` notifications are delivered to the handler service by
// this client's delivery thread, in order. Other events need no manager:
// any program emits them by calling the handler service.
//
// Delivery keeps at most kMaxQueuedEvents events waiting (a program that
// never handles its default group loses the oldest ones, counted in the
// debug log). After a manager restart the connections are announced again
// and the manager's initial sync repeats.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include "client/client.hpp"
#include "client/services_glue.hpp"
#include "services/call_state.hpp"
#include "services/marshal.hpp"

namespace ln::clientlib {

/// The handler service's interface and signature (ln/event/call).
inline constexpr std::string_view kEventCallInterface = "ln/event/call";
inline constexpr std::string_view kEventCallSignature = "uint32_t 4 1,uint8_t* 1 1,uint32_t 4 1,char* 1 1|";

/// ln_event_handler: (ln_client, ln_event_call, user_data).
using EventHandler = void (*)(void* client, void* call, void* user_data);

class EventHub;

/// One event being handled: what ln_event_call points to, during the handler.
class EventCall {
 public:
  static EventCall* from_handle(void* handle) noexcept;
  std::string_view data() const { return data_; }
  /// The client the event arrived at.
  Client& client() const { return *client_; }
  /// ln_event_call_set_data(): `call_signature` must be the one the event
  /// came with ("<definition>: <signature>"; else LNE_SVC_REQ_SET_DATA_WRONG);
  /// fills `call_data`, whose dynamic fields then point into memory of
  /// this call. Malformed event data: LNE_SVC_RECV_REQ.
  services::Status set_data(const char* call_signature, void* call_data);

 private:
  friend class EventHub;
  EventCall(Client* client, std::string_view data, std::string_view signature)
      : client_(client), data_(data), signature_(signature) {}
  ~EventCall() { tag_ = 0; }
  std::uint64_t tag_;
  Client* client_;
  std::string_view data_;
  std::string_view signature_;
  services::Arena arena_;
};

/// What ln_event_connection points to.
class EventConnection {
 public:
  static EventConnection* from_handle(void* handle) noexcept;
  unsigned int id() const { return id_; }
  const std::string& event_name() const { return event_name_; }
  /// The hub it belongs to (expired once its client is gone).
  std::shared_ptr<EventHub> hub() const { return hub_.lock(); }
  ~EventConnection() { tag_ = 0; }

 private:
  friend class EventHub;
  EventConnection() = default;
  std::uint64_t tag_;
  unsigned int id_ = 0;
  std::string event_name_;
  std::string handler_service_;
  bool from_manager_ = false;  // an "ln.*" event
  std::string connect_signature_;
  std::string connect_flat_;
  EventHandler handler_ = nullptr;
  void* user_data_ = nullptr;
  std::uint32_t provider_id_ = 0;
  std::int64_t manager_id_ = -1;                     // connect_event's id (ln.* events, this manager session)
  std::unique_ptr<services::ServiceCaller> caller_;  // delivery: calls the handler service
  std::weak_ptr<EventHub> hub_;
};

class EventHub : public std::enable_shared_from_this<EventHub> {
 public:
  static constexpr std::size_t kMaxQueuedEvents = 10000;

  /// The client's hub, made (and hooked into the client) on first use.
  static std::shared_ptr<EventHub> of(Client& client);
  EventHub(Client& client, std::shared_ptr<ServicesGlue> glue);
  /// Ends delivery (aborting a running call) and releases the handler
  /// services of connections nobody disconnected.
  ~EventHub();
  EventHub(const EventHub&) = delete;
  EventHub& operator=(const EventHub&) = delete;

  /// ln_event_connect_flat(). Throws Failure: LNE_INVALID_SIGNATURE (no
  /// "<definition>: " prefix), LNE_REQUEST_FAILED (already connected to
  /// that event, or the manager refuses).
  EventConnection* connect(const std::string& event_name, const std::string& connect_signature,
                           std::string connect_flat, EventHandler handler, void* user_data);
  /// ln_event_connection_deinit(): no event reaches the handler afterwards
  /// (except one running in the calling thread itself).
  void disconnect(EventConnection* connection);

 private:
  struct Pending {
    unsigned int connection;
    std::string data;
    std::string signature;
  };

  void install_hooks();
  static int handle_call(void* client, void* request, void* user_data);
  void on_event(const protocol::Message& message);  // I/O thread
  void announce_again();                            // I/O thread, after a manager restart
  void deliver_main();
  EventConnection* find_locked(unsigned int id) const;

  Client& client_;
  const std::shared_ptr<ServicesGlue> glue_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<unsigned int, std::unique_ptr<EventConnection>> connections_;
  std::map<std::int64_t, unsigned int> by_manager_id_;
  unsigned int next_id_ = 1;
  std::deque<Pending> queue_;
  std::uint64_t dropped_ = 0;
  unsigned int delivering_ = 0;  // connection whose handler service is being called
  bool stopping_ = false;
  std::thread deliverer_;
};

}  // namespace ln::clientlib
