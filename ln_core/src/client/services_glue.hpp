// Services in the client core: what connects the service data path
// (src/services: Dispatcher, ServiceCaller) to the manager and the peer
// server, plus waiting for providers and availability callbacks.
//
// Ids. The manager hands out a service id per registration, and a new one
// after it restarted. The Dispatcher knows each provider by a local id that
// never changes; the peer server's `call` handshake names the manager's id,
// is translated here, and its ok answer carries the local id, which the
// caller then puts into its frames. So a manager restart only changes the
// translation table (re-registration runs in the reconnect handler), and
// callers that are already connected are not affected at all.
//
// Callers connect to the provider's peer server: its abstract Unix socket
// when both share a host id, else (or when that socket cannot be reached) its
// TCP address (peer_address, TCP_NODELAY). Service frames are byte-order safe.
//
// Availability handlers run in a notifier thread of this object, driven by
// the manager's service_available/service_gone and topic_publisher_available/
// topic_publisher_gone notifications. After a manager restart (which may
// have missed changes) the watched names are looked up once more.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "client/client.hpp"
#include "client/service_logging.hpp"
#include "services/call_state.hpp"
#include "services/dispatch.hpp"

namespace ln::clientlib {

class ServicesGlue : public std::enable_shared_from_this<ServicesGlue> {
 public:
  using AvailabilityHandler = void (*)(void* client, const char* name, int available, void* user_data);

  /// The client's glue, made (and hooked into the client) on first use.
  static std::shared_ptr<ServicesGlue> of(Client& client);
  explicit ServicesGlue(Client& client);
  ~ServicesGlue();
  ServicesGlue(const ServicesGlue&) = delete;
  ServicesGlue& operator=(const ServicesGlue&) = delete;

  Client& client() { return client_; }
  services::Dispatcher& dispatcher() { return dispatcher_; }
  const std::shared_ptr<services::AsyncReactor>& reactor() const { return reactor_; }
  const services::Limits& limits() const { return limits_; }
  const services::WaitPolicy& wait_policy() const { return wait_; }
  /// Service logging (service_logging.hpp); callers of ln_service handles report to it.
  ServiceLogging& logging() { return *logging_; }
  std::shared_ptr<services::CallLog> call_log() const { return logging_; }
  /// True if this client registered a provider named `name`.
  bool provides(const std::string& name);

  /// Opens connections to the provider of `name` (already mapped).
  services::Connector connector(std::string name, std::string interface, std::string signature);

  /// Registers at the manager and makes the provider callable. Throws Failure.
  std::uint32_t register_provider(const std::string& name, const std::string& interface,
                                  std::shared_ptr<const services::ServiceSignature> signature,
                                  services::Handler handler, void* user_data, const char* group);
  /// Unregisters at the manager (errors ignored) and removes the provider.
  services::Status release_provider(std::uint32_t local_id);

  /// 1 once a provider of `name` is registered, 0 after `timeout` (< 0 no
  /// limit, 0 only checks). Throws Failure.
  int wait_for_service(const std::string& name, double timeout);
  /// True if `name` has a publisher (list_topics). Throws Failure.
  bool topic_has_publisher(const std::string& name);
  /// Installs (or with nullptr removes) the availability handler of a
  /// service (`topic` false) or topic publisher. Throws Failure.
  void set_availability_handler(bool topic, const std::string& name, AvailabilityHandler handler, void* user_data);

 private:
  struct Registration {
    std::string name, interface, group;
    bool has_group = false;
    std::string signature;
    std::int64_t manager_id = -1;
  };
  struct Watch {
    AvailabilityHandler handler = nullptr;
    void* user_data = nullptr;
    std::uint64_t generation = 0;
    int delivered = -1;    // state last given to the handler
    bool changed = false;  // a notification came since installing
  };
  struct Event {
    bool topic;
    std::string name;
    int available;
    std::uint64_t generation;  // 0: for whatever handler is current
  };
  using WatchKey = std::pair<bool, std::string>;

  void install_hooks();
  /// Connects to the peer server of the provider described by a
  /// lookup_service answer (Unix socket on the same host, else TCP).
  services::Status connect_to_provider(const protocol::Message& found, UniqueFd& socket);
  void on_call(PeerRequest& request);
  void on_availability_notification(bool topic, const std::string& name, bool available);
  void reregister_all();
  /// Looks the watched names up again (loop thread, after a manager restart).
  void refresh_watches();
  bool service_registered(const std::string& name);
  void notifier_main();
  void deliver(const Event& event);

  Client& client_;
  const services::Limits limits_;
  const services::WaitPolicy wait_;
  services::Dispatcher dispatcher_;
  std::shared_ptr<services::AsyncReactor> reactor_;
  std::shared_ptr<ServiceLogging> logging_;

  std::mutex mutex_;                                           // registrations, ids, watches, events
  std::map<std::uint32_t, Registration> registrations_;        // by local id
  std::map<std::int64_t, std::uint32_t> local_by_manager_id_;  // loop thread writes
  std::uint32_t next_local_id_ = 1;
  std::uint64_t service_changes_ = 0;
  std::condition_variable service_changed_;

  std::map<WatchKey, Watch> watches_;
  std::uint64_t next_generation_ = 1;
  std::deque<Event> events_;
  std::condition_variable events_changed_;
  bool stopping_ = false;
  std::recursive_mutex delivering_;  // held while a handler runs
  std::thread notifier_;
};

}  // namespace ln::clientlib
