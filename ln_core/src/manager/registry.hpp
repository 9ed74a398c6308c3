// Who is connected and what they publish, subscribe and provide: the
// manager's state and the rules that govern it. No sockets here; every change
// that others must hear about is queued as a notification in an Outbox.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "manager/events.hpp"
#include "manager/manager.hpp"
#include "protocol/wire.hpp"

namespace ln::manager {

class DefinitionStore;

/// Clients, topics, subscriptions and services share one id sequence, so an
/// id of one kind passed where another is expected is never mistaken.
using Id = std::int64_t;

struct Outgoing {
  Id client;
  protocol::Message message;
};
using Outbox = std::vector<Outgoing>;

struct ClientHello {
  std::string program_name;
  bool exact = false;
  std::int64_t pid = 0;
  std::string host_name;
  std::string host_id;
  std::int64_t uid = -1;
  std::int64_t library_version = 0;
  std::string peer_socket;
  std::string peer_address;
  std::string previous_name;
};

struct Client {
  Id id = 0;
  std::string name;
  ClientHello hello;
  std::size_t ports = 0;  ///< topics it publishes, subscriptions and services (max_ports_per_client)
};

struct Subscription {
  Id id = 0;
  Id client = 0;
  Id topic = 0;
  std::int64_t buffers = 1;
  double rate = -1;
  bool reliable = false;
  std::string receive_address;
};

/// A topic exists while it has a publisher or subscribers. Its definition is
/// fixed by whoever came first and kept by value (the definition store may
/// reload).
struct Topic {
  Id id = 0;
  std::string name;
  std::string definition;
  std::string hash;
  std::int64_t message_size = 0;
  std::optional<Id> publisher;
  std::int64_t publisher_buffers = 0;
  /// Set by publisher_ready: subscribers are only told about a publisher
  /// whose shared-memory segment exists.
  bool publisher_ready = false;
  std::int64_t segment_generation = 0;
  std::vector<Id> subscriptions;  ///< in subscription order
  /// The publisher's packet count (topic_stats) when it was last learned,
  /// and the rate over the interval that ended then.
  std::int64_t packets = 0;
  double rate = 0;
  std::chrono::steady_clock::time_point counted_at{};
};

struct Service {
  Id id = 0;
  std::string name;
  std::string interface;
  std::string signature;
  std::string group;
  Id provider = 0;
};

/// A client's connection to ln.resource_event (events.hpp).
struct EventConnection {
  Id id = 0;
  Id client = 0;
  std::string handler;    ///< the client's service that receives the events
  std::string interface;  ///< the definition named in the connect signature
  ResourceFilter filter;
};

/// A service logger: a service of `client` (interface ln/log_service) that
/// callers and providers of the services its patterns match send copies of
/// requests and responses to.
struct ServiceLogger {
  Id client = 0;
  std::vector<std::string> patterns;  ///< fnmatch patterns; "!pattern" excludes
};

struct SubscribeRequest {
  std::string topic;
  std::string definition;  ///< may carry "|hash"; "" = whatever the topic uses
  std::int64_t buffers = 1;
  double rate = -1;
  bool reliable = false;
  std::string receive_address;
};

/// Largest `buffers` a publish or subscribe may ask for.
constexpr std::int64_t max_topic_buffers = 65536;

/// Publishers report their packet count about once a second while it
/// changes: a rate older than this is from a publisher that stopped
/// reporting (stalled, or a library without topic_stats) and shows as 0.
constexpr std::chrono::seconds topic_rate_lifetime{3};

/// `value` in the shortest text that reads back as the same double ("10", "0.5").
std::string shortest_text(double value);

/// All operations throw RequestError and change nothing when they refuse.
class Registry {
 public:
  /// `limits` (max_topic_shm, max_client_shm) must outlive the registry.
  Registry(DefinitionStore& definitions, const ManagerLimits& limits) : definitions_(definitions), limits_(limits) {}
  const ManagerLimits& limits() const { return limits_; }

  // ------------------------------------------------------------- clients
  const Client& add_client(ClientHello hello);
  /// Releases everything the client owns and tells the others.
  void remove_client(Id client, Outbox& out);
  const Client& client(Id id) const;

  // -------------------------------------------------------------- topics
  const Topic& publish(Id client, const std::string& topic, const std::string& definition, std::int64_t buffers,
                       Outbox& out);
  /// `packets`, when known, starts a new rate interval (methods.hpp).
  void publisher_ready(Id client, Id topic, std::int64_t segment_generation, std::optional<std::int64_t> packets,
                       Outbox& out);
  /// A topic_stats report of the topic's publisher. Throws RequestError
  /// (LNE_PORT_NOT_FOUND) for a topic the client does not publish.
  void count_packets(Id client, Id topic, std::int64_t packets);
  void unpublish(Id client, Id topic, Outbox& out);
  const Subscription& subscribe(Id client, const SubscribeRequest& request, Outbox& out);
  void unsubscribe(Id client, Id subscription, Outbox& out);

  const Topic& topic_named(const std::string& name) const;
  const Topic& topic(Id id) const { return topics_.at(id); }
  /// The largest buffers any subscriber of `topic` asked for (0: none).
  std::int64_t subscriber_buffers(const Topic& topic) const;
  /// Sets the publisher fields of publisher_available (and of a subscribe
  /// response) for a topic whose publisher is ready.
  void set_publisher_fields(const Topic& topic, protocol::Message& message) const;
  /// The subscribers_changed notification for the topic's publisher.
  protocol::Message subscribers_changed(const Topic& topic) const;
  bool definition_in_use(const std::string& definition) const;
  /// Packets per second as list_topics shows it now (0 once stale).
  double current_rate(const Topic& topic) const;

  // --------------------------------------------------------- recorder taps
  /// A tap: the manager's own recorder (manager/recorder.hpp) reading topic
  /// `topic`'s segment like a subscriber on the publisher's host, listed in
  /// subscribers_changed's `local` ids and counted in subscriber_buffers, but
  /// not as a subscriber (has_subscriber, list_topics, list_clients). Kept by
  /// topic name, also while the topic has no publisher or does not exist.
  Id add_tap(const std::string& topic, std::int64_t buffers, Outbox& out);
  void set_tap_buffers(Id tap, std::int64_t buffers, Outbox& out);
  void remove_tap(Id tap, Outbox& out);

  // ------------------------------------------------------------ services
  const Service& register_service(Id client, const std::string& name, const std::string& interface,
                                  const std::string& signature, const std::string& group, Outbox& out);
  void unregister_service(Id client, Id service, Outbox& out);
  /// The provider of `name`, checked against the caller's interface ("" =
  /// any) and signature ("" = not checked).
  const Service& lookup_service(const std::string& name, const std::string& interface,
                                const std::string& signature) const;
  const Service& service_named(const std::string& name) const;
  std::vector<std::string> services_with_interface(const std::string& interface) const;

  // -------------------------------------------------------------- events
  /// Connects `client` to ln.resource_event (the only event there is;
  /// others: LNE_REQUEST_FAILED) and queues the initial sync.
  /// `signature` is "<definition>: <connect signature>".
  const EventConnection& connect_event(Id client, const std::string& name, const std::string& signature,
                                       const std::string& connect_data, const std::string& handler, Outbox& out);
  void disconnect_event(Id client, Id connection);

  // ----------------------------------------------------- service logging
  /// ln_register_as_service_logger(): `logger_service` must be a service of
  /// `client` (LNE_SVC_NOT_REGISTERED) with interface ln/log_service.
  /// Patterns are comma-separated (LN 2.9). Tells the other clients about
  /// the services they provide or call that it logs (add_service_logger).
  void register_service_logger(Id client, const std::string& logger_service, const std::string& patterns, Outbox& out);
  /// The loggers that get copies of `service`'s calls from `client`: every
  /// logger of another client whose patterns match (never the logger itself).
  std::vector<std::string> loggers_of(const std::string& service, Id client) const;
  /// `client` calls `service` (lookup_service): it hears of loggers added later.
  void note_caller(Id client, const std::string& service);

  // ------------------------------------------------------- introspection
  const std::map<Id, Client>& clients() const { return clients_; }
  const std::map<Id, Topic>& topics() const { return topics_; }
  const std::map<Id, Subscription>& subscriptions() const { return subscriptions_; }
  const std::map<Id, Service>& services() const { return services_; }

 private:
  struct ResolvedDefinition {
    std::string name;
    std::string hash;
    std::int64_t message_size = 0;
  };
  ResolvedDefinition resolve_for_topic(const std::string& topic, const std::string& definition);
  void check_topic_definition(const Topic& topic, const ResolvedDefinition& wanted) const;
  /// The buffers the topic's segment has now: its publisher's and its subscribers' largest.
  std::int64_t segment_history(const Topic& topic) const;
  /// Refuses (RequestError naming the limit) a segment of `history` buffers
  /// for topic `name` with packets of `message_size` bytes, if it exceeds
  /// max_topic_shm or makes `publisher`'s topics exceed max_client_shm.
  /// `topic_id`: the topic's current segment, not counted twice (0: new).
  void check_shared_memory(const std::string& name, std::int64_t message_size, std::int64_t history,
                           std::optional<Id> publisher, Id topic_id, const std::string& asked_by) const;
  Topic& create_topic(const std::string& name, const ResolvedDefinition& definition);
  /// Refuses (RequestError) one more topic, subscription or service of a client at max_ports_per_client.
  void check_port_quota(Id client) const;
  Topic& owned_topic(Id client, Id topic);
  void notify_publisher(const Topic& topic, Outbox& out) const;
  static void restart_packet_count(Topic& topic, std::int64_t packets);
  void erase_topic_if_unused(Id topic);
  void notify_all_clients(const protocol::Message& message, Outbox& out) const;
  /// `event` to every event connection whose filter accepts it.
  void emit(const ResourceEvent& event, Outbox& out) const;
  void send_event(const EventConnection& connection, const ResourceEvent& event, Outbox& out) const;

  DefinitionStore& definitions_;
  const ManagerLimits& limits_;
  Id last_id_ = 0;
  std::map<Id, Client> clients_;
  std::map<std::string, Id> client_names_;
  std::map<Id, Topic> topics_;
  std::map<std::string, Id> topic_names_;
  std::map<Id, Subscription> subscriptions_;
  std::map<Id, Service> services_;
  std::map<std::string, Id> service_names_;
  struct Tap {
    std::string topic;
    std::int64_t buffers = 1;
  };
  std::map<Id, Tap> taps_;
  void notify_publisher_of(const std::string& topic, Outbox& out) const;
  std::map<Id, EventConnection> event_connections_;
  std::map<std::string, ServiceLogger> service_loggers_;  // by logger service name
  std::map<Id, std::set<std::string>> called_services_;   // by client
};

}  // namespace ln::manager
