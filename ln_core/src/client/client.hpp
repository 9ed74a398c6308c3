// One LN client (ln_client): its registration with the ln_manager, its I/O
// thread, its peer server and the ports it owns.
//
// Set-up calls (publish, subscribe, ...) are requests to the manager made
// from application threads; the I/O thread receives the answers and the
// manager's notifications (publisher_available, subscribers_changed, ...).
//
// Manager restarts: when the connection drops, every port keeps working (the
// data never passes through the manager) and the I/O thread reconnects in the
// background with a bounded backoff, registers again under the same name and
// re-publishes and re-subscribes every port. A publisher keeps its segment, so
// its local subscribers see no gap. Set-up calls made while the manager is
// unreachable fail at once with LNE_LOST_CONNECTION.
//
// Data paths: a publisher on this host (same host id: boot id + network
// namespace) hands its shared-memory segment to the subscriber through its
// peer server (open_segment); a publisher on another host sends the packets
// itself (remote.hpp) to the receive_address given at subscribe time. The
// environment variable LN_CORE_HOST_ID replaces the host id, which lets tests
// exercise the network path on one machine.
//
// Extension points for other parts of the library (services, availability
// callbacks): add_notification_handler(), add_reconnect_handler(),
// peer_server().add_method(), request().
#pragma once

#include <netinet/in.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "client/error_slot.hpp"
#include "client/event_loop.hpp"
#include "client/launch_options.hpp"
#include "client/manager_link.hpp"
#include "client/multi_waiter.hpp"
#include "client/name_mapping.hpp"
#include "client/net.hpp"
#include "client/peer.hpp"
#include "client/ports.hpp"
#include "client/remote.hpp"
#include "client/topic_stats.hpp"

namespace ln::clientlib {

class Client {
 public:
  static constexpr std::chrono::milliseconds kRequestTimeout{20000};

  /// ln_init: LN options from argv, LN_MANAGER as fallback. Throws Failure.
  static std::unique_ptr<Client> create(const char* client_name, int argc, const char* const* argv);
  /// ln_init_to_manager: an explicit "HOST:PORT" (LN_MANAGER if null/empty). Throws Failure.
  static std::unique_ptr<Client> create_to_manager(const char* client_name, const char* manager_address);

  /// Says goodbye to the manager and releases everything the client owns.
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// The granted name; the buffer stays valid for the client's lifetime.
  const char* name() const { return name_; }
  std::int64_t client_id() const { return client_id_.load(); }
  const std::string& host_id() const { return host_id_; }
  ErrorSlot& errors() { return errors_; }
  const std::vector<std::string>& remaining_args() const { return remaining_args_; }
  /// The remaining arguments back to back, each NUL-terminated.
  const std::string& remaining_args_block() const { return remaining_args_block_; }
  const NameMapping& topic_mapping() const { return topic_mapping_; }
  const NameMapping& service_mapping() const { return service_mapping_; }

  // ---- manager requests
  /// True while registered with a manager (not while reconnecting).
  bool registered() const { return registered_.load(); }
  protocol::Message new_request(std::string_view method) { return link_.new_request(method); }
  /// A blocking request; fails at once with LNE_LOST_CONNECTION while no
  /// manager is reachable. Throws Failure. Not from the I/O thread.
  protocol::Message request(protocol::Message message, std::chrono::milliseconds timeout = kRequestTimeout,
                            std::function<void(const protocol::Message&)> in_loop = {});
  /// Round trip to the manager in seconds (timeout < 0: no limit, 0: only
  /// checks the connection and returns 0). Throws Failure.
  double ping(double timeout);

  // ---- topics
  OutPort* publish(const std::string& topic, const std::string& md_name, unsigned buffers);
  void unpublish(OutPort* port);
  InPort* subscribe(const std::string& topic, const std::string& md_name, double rate, unsigned buffers, bool reliable);
  void unsubscribe(InPort* port);
  /// True if `port` is a port of this client.
  bool owns(const PortBase* port) const;

  // ---- multi-waiters (owned by the client)
  MultiWaiter* create_multi_waiter();
  /// False if `waiter` is not one of this client's.
  bool destroy_multi_waiter(MultiWaiter* waiter);

  // ---- debugging (LN_DEBUG, names containing "dbg")
  bool debugging() const { return debug_level_.load(std::memory_order_relaxed) > 0; }
  void debug(const char* format, ...) const __attribute__((format(printf, 2, 3)));
  void vdebug(const char* format, va_list args) const;
  /// ln_client_set_float_parameter("debug"): 0 quiet, > 0 LN_DEBUG output.
  void set_debug_level(int level) { debug_level_.store(level); }
  /// ln_client_set_float_parameter("reconnect_interval"): the longest wait
  /// between two attempts to reach a restarted manager (> 0).
  void set_reconnect_interval(std::chrono::milliseconds interval) { longest_backoff_ms_.store(interval.count()); }

  // ---- extension points (for services and availability callbacks)
  EventLoop& loop() { return loop_; }
  ManagerLink& manager() { return link_; }
  PeerServer& peer_server() { return peer_server_; }
  using NotificationHandler = std::function<void(const protocol::Message&)>;
  /// Runs `handler` in the I/O thread for every notification `method` the
  /// built-in handling does not consume. Call before using the client from
  /// several threads.
  void add_notification_handler(std::string method, NotificationHandler handler);
  /// Runs `handler` in the I/O thread after every re-registration with a
  /// (restarted) manager, to re-establish what the manager forgot. It must
  /// not block; use manager().send_request().
  void add_reconnect_handler(std::function<void()> handler);
  /// Per-client state of the services part of the library
  /// (services_glue.hpp): `make`s it on first use. Released in ~Client once
  /// the I/O thread stopped and the manager link is closed.
  std::shared_ptr<void> services_state(const std::function<std::shared_ptr<void>()>& make);
  /// The same for other parts of the library, by name ("loggers", "events");
  /// released before the services state, which they may use.
  std::shared_ptr<void> part_state(const std::string& part, const std::function<std::shared_ptr<void>()>& make);

 private:
  struct Settings {
    std::string requested_name;
    bool exact = false;
    ManagerAddress address;
    sockaddr_in resolved{};
  };

  static std::unique_ptr<Client> connect(const char* client_name, CommandLine command_line,
                                         const std::optional<std::string>& explicit_address);
  explicit Client(Settings settings, CommandLine command_line);
  void start(UniqueFd connected_socket);
  void register_with_manager();
  protocol::Message hello_request(bool after_restart);
  /// Opens (or moves) the TCP peer server to the IP used towards the manager.
  void listen_for_remote_peers();
  void adopt_hello_response(const protocol::Message& response);
  void set_name(const std::string& name);
  void require_registered() const;

  // I/O thread
  void on_notification(const protocol::Message& message);
  void on_disconnect(const std::string& reason);
  void schedule_reconnect();
  void try_reconnect();
  void on_reconnected();
  void republish(OutPort* port);
  void resubscribe(InPort* port);
  bool handle_subscribe_answer(InPort* port, const protocol::Message& answer);
  void open_publisher_segment(InPort* port, std::uint64_t serial, const protocol::Message& publisher);
  /// `recovered`: the port replaced a corrupted segment (the manager logs it).
  void send_publisher_ready(OutPort* port, bool recovered = false);
  /// topic_stats for the outports whose count is due (topic_stats.hpp);
  /// re-arms itself every PacketCountReports::kPeriod.
  void report_packet_counts();
  /// Makes the port read the inbox of remote data (registry lock held).
  void attach_remote_inbox_locked(InPort* port, std::int64_t subscription_id, std::uint64_t serial);
  /// `may_wait`: a subscriber this port has not counted yet is answered
  /// once subscribers_changed lists it (or after a while).
  void serve_open_segment(PeerRequest& request, bool may_wait = true);
  /// Answers the held open_segment requests whose subscriber is listed now.
  void serve_listed_opens();
  /// subscribers_changed for one of our outports; registry lock held.
  /// Returns true if the port switched to a bigger segment.
  bool update_subscribers_locked(OutPort* port, const protocol::Message& message);
  OutPort* find_outport_locked(std::int64_t topic_id, const std::string& topic) const;
  InPort* find_inport_locked(std::int64_t subscription_id) const;

  /// Per-port registration with the current manager (registry_mutex_).
  struct Registration {
    std::int64_t manager_id = -1;  // topic_id of an outport, subscription_id of an inport
    std::int64_t topic_id = -1;
    std::uint64_t session = 0;          // the manager session it belongs to
    bool in_flight = false;             // a (re-)registration request is out
    std::uint64_t serial = 0;           // tells a port apart from a later one at the same address
    std::string md_requested;           // the message definition as the program gave it
    PacketCountReports packet_reports;  // outports: what the manager knows of the count
    // Outports: each subscription the manager listed (this session's ids;
    // local ones and remote ones) -> the newest sequence when this port
    // first counted it. The subscriber's packets are the later ones:
    // has_subscriber() may turn true before a local subscriber asks for the
    // segment (open_segment), or before a remote one can route our packets.
    std::map<std::int64_t, std::uint64_t> joined_after;
  };

  Settings settings_;
  std::string host_id_;
  std::vector<std::string> remaining_args_;
  std::string remaining_args_block_;
  NameMapping topic_mapping_;
  NameMapping service_mapping_;
  std::atomic<int> debug_level_{0};  // raised by a "dbg" name granted after a restart

  ErrorSlot errors_;
  mutable std::mutex name_mutex_;
  char name_[512] = {};
  std::atomic<std::int64_t> client_id_{-1};
  std::atomic<bool> registered_{false};

  EventLoop loop_;
  ManagerLink link_;
  PeerServer peer_server_;

  // I/O thread only
  std::chrono::milliseconds backoff_{50};
  std::atomic<std::int64_t> longest_backoff_ms_{1000};
  UniqueFd connecting_;
  std::map<std::string, std::vector<NotificationHandler>, std::less<>> notification_handlers_;
  std::vector<std::function<void()>> reconnect_handlers_;
  // open_segment requests held until the port counts their subscriber.
  struct HeldOpen {
    std::uint64_t serial;
    EventLoop::TimerId timer;  // answers it anyway when the manager stays silent
    PeerRequest request;
  };
  std::vector<HeldOpen> held_opens_;
  std::uint64_t last_held_open_ = 0;

  mutable std::mutex registry_mutex_;  // ports, their registrations and the lookup maps
  // Takes `port` out of the bookkeeping (registry_mutex_ held): the port,
  // and its manager-side id when the manager knows it in this session (-1
  // otherwise). Throws LNE_INVALID_PORT_OBJECT for a foreign port.
  template <typename Port>
  std::pair<std::unique_ptr<Port>, std::int64_t> forget_port(std::vector<std::unique_ptr<Port>>& ports,
                                                             std::map<std::int64_t, Port*>& by_id, Port* port,
                                                             const char* kind);

  std::vector<std::unique_ptr<OutPort>> outports_;
  std::vector<std::unique_ptr<InPort>> inports_;
  std::map<const PortBase*, Registration> registrations_;

  // Marks `port` as being (re-)registered, unless it is gone, already
  // registered in this session or already on its way: then nullopt.
  // Returns its serial and requested definition for the request.
  struct ClaimedRegistration {
    std::uint64_t serial;
    std::string md_name;
  };
  std::optional<ClaimedRegistration> claim_registration(const PortBase* port);
  std::map<std::int64_t, OutPort*> outports_by_topic_id_;
  std::map<std::int64_t, InPort*> inports_by_subscription_;
  std::vector<std::unique_ptr<MultiWaiter>> waiters_;
  std::mutex services_mutex_;
  std::shared_ptr<void> services_;
  std::map<std::string, std::shared_ptr<void>> parts_;  // services_mutex_
  // Receives topic data from publishers on other hosts; made with the first
  // subscription (it must be named in the subscribe request).
  std::unique_ptr<RemoteReceiver> receiver_;
};

}  // namespace ln::clientlib
