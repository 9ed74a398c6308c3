#include "manager/registry.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "ln/md/message_definition.hpp"
#include "manager/definitions.hpp"
#include "manager/limits.hpp"
#include "manager/names.hpp"
#include "manager/request_error.hpp"
#include "protocol/methods.hpp"
#include "transport/shm_ring.hpp"

namespace ln::manager {
namespace {

namespace method = protocol::method;

constexpr std::size_t max_address_size = 255;
constexpr std::size_t max_signature_size = 64 * 1024;

void require(bool ok, int code, const std::string& text) {
  if (!ok) throw RequestError(code, text);
}

void check_name(const std::optional<std::string>& problem) {
  if (problem) throw RequestError(LNE_INVALID_PARAMETER, *problem);
}

void check_buffers(std::int64_t buffers) {
  require(buffers >= 1 && buffers <= max_topic_buffers, LNE_INVALID_PARAMETER,
          "buffers must lie within 1.." + std::to_string(max_topic_buffers) + ", not " + std::to_string(buffers));
}

void check_rate(double rate) {
  require(rate == -1 || rate == -2 || rate == -3 || (std::isfinite(rate) && rate > 0), LNE_INVALID_PARAMETER,
          "rate must be -1 (every packet), -2 or -3 (on request) or a positive number of packets per second, not " +
              shortest_text(rate));
}

}  // namespace

std::string shortest_text(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

// ----------------------------------------------------------------- clients

const Client& Registry::add_client(ClientHello hello) {
  check_name(client_name_problem(hello.program_name));
  require(hello.peer_socket.size() <= max_address_size && hello.peer_address.size() <= max_address_size &&
              hello.host_name.size() <= max_address_size && hello.host_id.size() <= max_address_size,
          LNE_INVALID_PARAMETER, "host or peer address fields are longer than 255 bytes");
  auto taken = [this](const std::string& name) { return client_names_.count(name) > 0; };
  std::string name;
  if (hello.exact) {
    if (taken(hello.program_name)) {
      const Client& holder = clients_.at(client_names_.at(hello.program_name));
      throw RequestError(LNE_CLNT_NAME_IN_USE, "client name '" + hello.program_name + "' is already in use (pid " +
                                                   std::to_string(holder.hello.pid) + " on " + holder.hello.host_name +
                                                   ")");
    }
    name = hello.program_name;
  } else if (!hello.previous_name.empty() && !client_name_problem(hello.previous_name) && !taken(hello.previous_name)) {
    name = hello.previous_name;  // a client coming back after a manager restart
  } else {
    name = unique_client_name(hello.program_name, taken);
  }
  const Id id = ++last_id_;
  client_names_[name] = id;
  Client& client = clients_[id];
  client.id = id;
  client.name = name;
  client.hello = std::move(hello);
  return client;
}

void Registry::remove_client(Id id, Outbox& out) {
  if (!clients_.count(id)) return;
  for (auto it = event_connections_.begin(); it != event_connections_.end();)
    it = it->second.client == id ? event_connections_.erase(it) : std::next(it);
  called_services_.erase(id);
  std::vector<Id> published, subscribed, provided;
  for (const auto& [topic_id, topic] : topics_)
    if (topic.publisher == id) published.push_back(topic_id);
  for (const auto& [subscription_id, subscription] : subscriptions_)
    if (subscription.client == id) subscribed.push_back(subscription_id);
  for (const auto& [service_id, service] : services_)
    if (service.provider == id) provided.push_back(service_id);
  for (Id topic : published) unpublish(id, topic, out);
  for (Id subscription : subscribed) unsubscribe(id, subscription, out);
  for (Id service : provided) unregister_service(id, service, out);
  client_names_.erase(clients_.at(id).name);
  clients_.erase(id);
  // Nothing more is ever delivered to the client that is leaving.
  out.erase(std::remove_if(out.begin(), out.end(), [id](const Outgoing& o) { return o.client == id; }), out.end());
}

const Client& Registry::client(Id id) const { return clients_.at(id); }

// ------------------------------------------------------------------ topics

Registry::ResolvedDefinition Registry::resolve_for_topic(const std::string& topic, const std::string& definition) {
  const md::Definition& resolved = definitions_.resolve(definition);
  require(resolved.kind == md::Kind::Plain, LNE_INVALID_PARAMETER,
          "message definition '" + resolved.name + "' is a " + (resolved.is_service() ? "service" : "event") +
              " definition; topic '" + topic + "' needs a plain one");
  if (auto dynamic = first_dynamic_field(resolved))
    throw RequestError(LNE_INVALID_PARAMETER,
                       "message definition '" + resolved.name + "' has the dynamic field '" + *dynamic +
                           "'; topics carry fixed-size packets only (use a fixed array and a count field)");
  return {resolved.name, resolved.hash, static_cast<std::int64_t>(md::packet_size(resolved))};
}

void Registry::check_topic_definition(const Topic& topic, const ResolvedDefinition& wanted) const {
  require(wanted.name == topic.definition, LNE_REQUEST_FAILED,
          "you requested message_definition '" + wanted.name + "' but topic '" + topic.name + "' uses '" +
              topic.definition + "'");
  require(wanted.hash == topic.hash, LNE_WRONG_MD_HASH,
          "message definition '" + wanted.name + "' now has hash " + wanted.hash + ", but topic '" + topic.name +
              "' was set up with hash " + topic.hash + " (the definition changed meanwhile)");
}

std::int64_t Registry::segment_history(const Topic& topic) const {
  return std::max(topic.publisher ? topic.publisher_buffers : 0, subscriber_buffers(topic));
}

namespace {

std::uint64_t segment_bytes(std::int64_t message_size, std::int64_t history) {
  const std::uint64_t size =
      transport::topic_segment_size(static_cast<std::uint32_t>(message_size), static_cast<std::uint32_t>(history));
  return size != 0 ? size : ~std::uint64_t{0};  // beyond what the transport can make: over every limit
}

// The most buffers whose segment stays within `limit` (0 if not even one).
std::int64_t buffers_within(std::int64_t message_size, std::uint64_t limit) {
  std::int64_t fits = 0, too_many = max_topic_buffers + 1;
  while (too_many - fits > 1) {
    const std::int64_t middle = fits + (too_many - fits) / 2;
    (segment_bytes(message_size, middle) <= limit ? fits : too_many) = middle;
  }
  return fits;
}

}  // namespace

void Registry::check_shared_memory(const std::string& name, std::int64_t message_size, std::int64_t history,
                                   std::optional<Id> publisher, Id topic_id, const std::string& asked_by) const {
  const std::uint64_t needed = segment_bytes(message_size, history);
  const std::string what = "topic '" + name + "': " + std::to_string(history) + " buffers of " +
                           byte_text(static_cast<std::uint64_t>(message_size)) + " packets" + asked_by +
                           " need a shared-memory segment of " + byte_text(needed);
  if (needed > limits_.max_topic_shm) {
    const std::int64_t most = buffers_within(message_size, limits_.max_topic_shm);
    throw RequestError(LNE_SHM_IS_TOO_BIG, what + ", more than the manager allows per topic (max_topic_shm " +
                                               byte_text(limits_.max_topic_shm) + "); at most " + std::to_string(most) +
                                               " buffers fit");
  }
  if (!publisher) return;
  std::uint64_t others = 0;
  for (const auto& [id, topic] : topics_)
    if (id != topic_id && topic.publisher == publisher)
      others += segment_bytes(topic.message_size, segment_history(topic));
  if (others + needed > limits_.max_client_shm)
    throw RequestError(LNE_SHM_IS_TOO_BIG, what + "; with the " + byte_text(others) + " of the other topics client '" +
                                               clients_.at(*publisher).name +
                                               "' publishes, that is more than the manager allows per client "
                                               "(max_client_shm " +
                                               byte_text(limits_.max_client_shm) + ")");
}

void Registry::check_port_quota(Id client) const {
  const Client& owner = clients_.at(client);
  require(owner.ports < limits_.max_ports_per_client, LNE_REQUEST_FAILED,
          "client '" + owner.name + "' has " + std::to_string(owner.ports) +
              " topics it publishes, subscriptions and services, as many as the manager allows per client "
              "(max_ports_per_client)");
}

Topic& Registry::create_topic(const std::string& name, const ResolvedDefinition& definition) {
  const Id id = ++last_id_;
  Topic& topic = topics_[id];
  topic.id = id;
  topic.name = name;
  topic.definition = definition.name;
  topic.hash = definition.hash;
  topic.message_size = definition.message_size;
  topic_names_[name] = id;
  return topic;
}

Topic& Registry::owned_topic(Id client, Id id) {
  const auto it = topics_.find(id);
  require(it != topics_.end() && it->second.publisher == client, LNE_PORT_NOT_FOUND,
          "you do not publish a topic with id " + std::to_string(id));
  return it->second;
}

const Topic& Registry::publish(Id client, const std::string& name, const std::string& definition, std::int64_t buffers,
                               Outbox& out) {
  check_name(topic_name_problem(name));
  check_buffers(buffers);
  const auto existing = topic_names_.find(name);
  if (existing != topic_names_.end()) {
    const Topic& topic = topics_.at(existing->second);
    if (topic.publisher)
      throw RequestError(LNE_REQUEST_FAILED, "topic '" + name + "' already published by client '" +
                                                 clients_.at(*topic.publisher).name + "'");
  }
  const ResolvedDefinition wanted = resolve_for_topic(name, definition);
  if (existing != topic_names_.end()) check_topic_definition(topics_.at(existing->second), wanted);
  {
    const Topic* known = existing != topic_names_.end() ? &topics_.at(existing->second) : nullptr;
    const std::int64_t subscribers = known ? subscriber_buffers(*known) : 0;
    check_shared_memory(name, wanted.message_size, std::max(buffers, subscribers), client, known ? known->id : 0,
                        subscribers > buffers ? " (its subscribers ask for " + std::to_string(subscribers) + ")" : "");
  }

  check_port_quota(client);
  Topic& topic = existing != topic_names_.end() ? topics_.at(existing->second) : create_topic(name, wanted);
  ++clients_.at(client).ports;
  topic.publisher = client;
  topic.publisher_buffers = buffers;
  topic.publisher_ready = false;
  topic.segment_generation = 0;
  restart_packet_count(topic, 0);
  notify_publisher(topic, out);  // the publisher always learns the current subscribers first-hand
  emit({"topic_new_publisher", topic.name, topic.definition, clients_.at(client).name}, out);
  return topic;
}

void Registry::publisher_ready(Id client, Id id, std::int64_t segment_generation, std::optional<std::int64_t> packets,
                               Outbox& out) {
  Topic& topic = owned_topic(client, id);
  if (!topic.publisher_ready) {
    auto message = protocol::Message::notification(method::topic_publisher_available);
    message.set("name", topic.name).set("publisher", clients_.at(client).name);
    notify_all_clients(message, out);
  }
  topic.publisher_ready = true;
  topic.segment_generation = segment_generation;
  if (packets) {
    topic.packets = *packets;
    topic.counted_at = std::chrono::steady_clock::now();
  }
  for (Id subscription_id : topic.subscriptions) {
    const Subscription& subscription = subscriptions_.at(subscription_id);
    auto message = protocol::Message::notification(method::publisher_available);
    message.set("subscription_id", subscription.id).set("topic_id", topic.id);
    set_publisher_fields(topic, message);
    out.push_back({subscription.client, std::move(message)});
  }
}

void Registry::unpublish(Id client, Id id, Outbox& out) {
  Topic& topic = owned_topic(client, id);
  emit({"topic_del_publisher", topic.name, topic.definition, clients_.at(client).name}, out);
  const bool was_announced = topic.publisher_ready;
  --clients_.at(client).ports;
  topic.publisher.reset();
  topic.publisher_ready = false;
  topic.publisher_buffers = 0;
  restart_packet_count(topic, 0);
  if (was_announced) {
    for (Id subscription_id : topic.subscriptions) {
      const Subscription& subscription = subscriptions_.at(subscription_id);
      auto message = protocol::Message::notification(method::publisher_gone);
      message.set("subscription_id", subscription.id).set("topic_id", topic.id);
      out.push_back({subscription.client, std::move(message)});
    }
    auto message = protocol::Message::notification(method::topic_publisher_gone);
    message.set("name", topic.name);
    notify_all_clients(message, out);
  }
  erase_topic_if_unused(id);
}

void Registry::restart_packet_count(Topic& topic, std::int64_t packets) {
  topic.packets = packets;
  topic.rate = 0;
  topic.counted_at = std::chrono::steady_clock::now();
}

void Registry::count_packets(Id client, Id id, std::int64_t packets) {
  Topic& topic = owned_topic(client, id);
  if (packets < topic.packets) return restart_packet_count(topic, packets);
  const auto now = std::chrono::steady_clock::now();
  const double seconds = std::chrono::duration<double>(now - topic.counted_at).count();
  // Two reports in the same instant say nothing about the rate.
  if (seconds > 0) topic.rate = static_cast<double>(packets - topic.packets) / seconds;
  topic.packets = packets;
  topic.counted_at = now;
}

double Registry::current_rate(const Topic& topic) const {
  if (!topic.publisher || std::chrono::steady_clock::now() - topic.counted_at > topic_rate_lifetime) return 0;
  return topic.rate;
}

const Subscription& Registry::subscribe(Id client, const SubscribeRequest& request, Outbox& out) {
  check_name(topic_name_problem(request.topic));
  check_buffers(request.buffers);
  check_rate(request.rate);
  require(request.receive_address.size() <= max_address_size, LNE_INVALID_PARAMETER,
          "receive_address is longer than 255 bytes");
  const auto existing = topic_names_.find(request.topic);
  Topic* topic = existing != topic_names_.end() ? &topics_.at(existing->second) : nullptr;
  std::optional<ResolvedDefinition> wanted;
  if (request.definition.empty()) {
    require(topic != nullptr, LNE_PORT_NOT_FOUND,
            "topic '" + request.topic +
                "' is not known yet; name its message definition to subscribe before it "
                "is published");
  } else {
    wanted = resolve_for_topic(request.topic, request.definition);
    if (topic) check_topic_definition(*topic, *wanted);
  }
  check_port_quota(client);
  if (!topic || request.buffers > segment_history(*topic))
    check_shared_memory(request.topic, topic ? topic->message_size : wanted->message_size, request.buffers,
                        topic ? topic->publisher : std::nullopt, topic ? topic->id : 0,
                        " (asked for by this subscriber)");
  if (!topic) topic = &create_topic(request.topic, *wanted);
  const Id id = ++last_id_;
  Subscription& subscription = subscriptions_[id];
  subscription.id = id;
  subscription.client = client;
  ++clients_.at(client).ports;
  subscription.topic = topic->id;
  subscription.buffers = request.buffers;
  subscription.rate = request.rate;
  subscription.reliable = request.reliable;
  subscription.receive_address = request.receive_address;
  topic->subscriptions.push_back(id);
  notify_publisher(*topic, out);
  emit({"topic_new_subscriber", topic->name, topic->definition, clients_.at(client).name}, out);
  return subscription;
}

void Registry::unsubscribe(Id client, Id id, Outbox& out) {
  const auto it = subscriptions_.find(id);
  require(it != subscriptions_.end() && it->second.client == client, LNE_PORT_NOT_FOUND,
          "you have no subscription with id " + std::to_string(id));
  const Id topic_id = it->second.topic;
  subscriptions_.erase(it);
  --clients_.at(client).ports;
  Topic& topic = topics_.at(topic_id);
  topic.subscriptions.erase(std::remove(topic.subscriptions.begin(), topic.subscriptions.end(), id),
                            topic.subscriptions.end());
  notify_publisher(topic, out);
  emit({"topic_del_subscriber", topic.name, topic.definition, clients_.at(client).name}, out);
  erase_topic_if_unused(topic_id);
}

const Topic& Registry::topic_named(const std::string& name) const {
  check_name(topic_name_problem(name));
  const auto it = topic_names_.find(name);
  require(it != topic_names_.end(), LNE_PORT_NOT_FOUND, "topic '" + name + "' is neither published nor subscribed");
  return topics_.at(it->second);
}

std::int64_t Registry::subscriber_buffers(const Topic& topic) const {
  std::int64_t largest = 0;
  for (Id id : topic.subscriptions) largest = std::max(largest, subscriptions_.at(id).buffers);
  for (const auto& entry : taps_)
    if (entry.second.topic == topic.name) largest = std::max(largest, entry.second.buffers);
  return largest;
}

void Registry::set_publisher_fields(const Topic& topic, protocol::Message& message) const {
  const Client& publisher = clients_.at(*topic.publisher);
  message.set("publisher", publisher.name)
      .set("host_id", publisher.hello.host_id)
      .set("peer_socket", publisher.hello.peer_socket)
      .set("peer_address", publisher.hello.peer_address)
      .set("segment_generation", topic.segment_generation);
}

protocol::Message Registry::subscribers_changed(const Topic& topic) const {
  const std::string& publisher_host = clients_.at(*topic.publisher).hello.host_id;
  protocol::StringList local;
  protocol::StringList remote;
  for (Id id : topic.subscriptions) {
    const Subscription& subscription = subscriptions_.at(id);
    // Subscribers on the publisher's host read its segment; the others are
    // fed over the network, by the publisher, to the address they gave.
    if (clients_.at(subscription.client).hello.host_id == publisher_host) {
      local.push_back(std::to_string(subscription.id));
      continue;
    }
    if (subscription.receive_address.empty()) continue;
    remote.push_back(std::to_string(subscription.id) + " " + shortest_text(subscription.rate) + " " +
                     (subscription.reliable ? "1" : "0") + " " + subscription.receive_address);
  }
  for (const auto& [id, tap] : taps_)
    if (tap.topic == topic.name) local.push_back(std::to_string(id));
  auto message = protocol::Message::notification(method::subscribers_changed);
  message.set("topic_id", topic.id)
      .set("subscribers", static_cast<std::int64_t>(topic.subscriptions.size()))
      .set("subscriber_buffers", subscriber_buffers(topic))
      .set("local", std::move(local))
      .set("remote", std::move(remote));
  return message;
}

void Registry::notify_publisher(const Topic& topic, Outbox& out) const {
  if (topic.publisher) out.push_back({*topic.publisher, subscribers_changed(topic)});
}

void Registry::notify_publisher_of(const std::string& topic, Outbox& out) const {
  if (const auto it = topic_names_.find(topic); it != topic_names_.end()) notify_publisher(topics_.at(it->second), out);
}

Id Registry::add_tap(const std::string& topic, std::int64_t buffers, Outbox& out) {
  check_name(topic_name_problem(topic));
  check_buffers(buffers);
  const Id id = ++last_id_;
  taps_[id] = Tap{topic, buffers};
  notify_publisher_of(topic, out);
  return id;
}

void Registry::set_tap_buffers(Id tap, std::int64_t buffers, Outbox& out) {
  check_buffers(buffers);
  const auto it = taps_.find(tap);
  if (it == taps_.end() || it->second.buffers == buffers) return;
  it->second.buffers = buffers;
  notify_publisher_of(it->second.topic, out);
}

void Registry::remove_tap(Id tap, Outbox& out) {
  const auto it = taps_.find(tap);
  if (it == taps_.end()) return;
  const std::string topic = it->second.topic;
  taps_.erase(it);
  notify_publisher_of(topic, out);
}

void Registry::erase_topic_if_unused(Id id) {
  const auto it = topics_.find(id);
  if (it == topics_.end() || it->second.publisher || !it->second.subscriptions.empty()) return;
  topic_names_.erase(it->second.name);
  topics_.erase(it);
}

bool Registry::definition_in_use(const std::string& definition) const {
  return std::any_of(topics_.begin(), topics_.end(),
                     [&](const auto& entry) { return entry.second.definition == definition; });
}

// ---------------------------------------------------------------- services

void Registry::notify_all_clients(const protocol::Message& message, Outbox& out) const {
  for (const auto& entry : clients_) out.push_back({entry.first, message});
}

const Service& Registry::register_service(Id client, const std::string& name, const std::string& interface,
                                          const std::string& signature, const std::string& group, Outbox& out) {
  check_name(service_name_problem(name));
  check_name(definition_name_problem(split_name_and_hash(interface).first));
  require(signature.size() <= max_signature_size, LNE_INVALID_PARAMETER, "the service signature is too long");
  require(group.size() <= max_address_size, LNE_INVALID_PARAMETER, "the service group name is too long");
  const auto existing = service_names_.find(name);
  if (existing != service_names_.end())
    throw RequestError(LNE_SVC_ALREADY_REGISTERED, "service '" + name + "' is already provided by client '" +
                                                       clients_.at(services_.at(existing->second).provider).name + "'");
  check_port_quota(client);
  const Id id = ++last_id_;
  Service& service = services_[id];
  service.id = id;
  service.name = name;
  service.interface = interface;
  service.signature = signature;
  service.group = group;
  service.provider = client;
  ++clients_.at(client).ports;
  service_names_[name] = id;
  auto message = protocol::Message::notification(method::service_available);
  message.set("name", name).set("provider", clients_.at(client).name);
  notify_all_clients(message, out);
  emit({"service_new_provider", name, split_name_and_hash(interface).first, clients_.at(client).name}, out);
  return service;
}

void Registry::unregister_service(Id client, Id id, Outbox& out) {
  const auto it = services_.find(id);
  require(it != services_.end() && it->second.provider == client, LNE_SVC_NOT_REGISTERED,
          "you provide no service with id " + std::to_string(id));
  const std::string name = it->second.name;
  emit({"service_del_provider", name, split_name_and_hash(it->second.interface).first, clients_.at(client).name}, out);
  service_names_.erase(name);
  services_.erase(it);
  --clients_.at(client).ports;
  auto message = protocol::Message::notification(method::service_gone);
  message.set("name", name);
  notify_all_clients(message, out);
  if (service_loggers_.erase(name) > 0) {
    auto gone = protocol::Message::notification(method::del_service_logger);
    gone.set("logger_service", name);
    notify_all_clients(gone, out);
  }
}

const Service& Registry::service_named(const std::string& name) const {
  check_name(service_name_problem(name));
  const auto it = service_names_.find(name);
  require(it != service_names_.end(), LNE_NO_PROVIDER_FOUND, "no client provides service '" + name + "'");
  return services_.at(it->second);
}

const Service& Registry::lookup_service(const std::string& name, const std::string& interface,
                                        const std::string& signature) const {
  const Service& service = service_named(name);
  if (!interface.empty()) {
    const auto [wanted_name, wanted_hash] = split_name_and_hash(interface);
    const auto [provided_name, provided_hash] = split_name_and_hash(service.interface);
    require(wanted_name == provided_name, LNE_REQUEST_FAILED,
            "service '" + name + "' has interface '" + provided_name + "', not the requested '" + wanted_name + "'");
    require(wanted_hash.empty() || provided_hash.empty() || wanted_hash == provided_hash, LNE_WRONG_MD_HASH,
            "service '" + name + "': the provider's interface '" + provided_name + "' has hash " + provided_hash +
                ", the caller's has " + wanted_hash);
  }
  require(signature.empty() || signature == service.signature, LNE_REQUEST_FAILED,
          "service '" + name + "' has signature '" + service.signature + "', but the caller uses '" + signature +
              "': caller and provider were built with different versions of '" + service.interface + "'");
  return service;
}

std::vector<std::string> Registry::services_with_interface(const std::string& interface) const {
  const std::string wanted = split_name_and_hash(interface).first;
  std::vector<std::string> names;
  for (const auto& [name, id] : service_names_)
    if (split_name_and_hash(services_.at(id).interface).first == wanted) names.push_back(name);
  return names;
}

// ------------------------------------------------------------------ events

const EventConnection& Registry::connect_event(Id client, const std::string& name, const std::string& signature,
                                               const std::string& connect_data, const std::string& handler,
                                               Outbox& out) {
  require(name == kResourceEventName, LNE_REQUEST_FAILED,
          "unknown event '" + name + "': this manager provides '" + std::string(kResourceEventName) + "'");
  const std::size_t colon = signature.find(": ");
  require(colon != std::string::npos && colon > 0, LNE_INVALID_SIGNATURE,
          "the connect signature must read '<definition>: <signature>', not '" + signature + "'");
  const std::string interface = signature.substr(0, colon);
  require(signature.compare(colon + 2, std::string::npos, kResourceEventSignature) == 0, LNE_INVALID_SIGNATURE,
          "event '" + name + "' is connected with the four strings of ln/resource_event, not with '" +
              signature.substr(colon + 2) + "'");
  check_name(definition_name_problem(interface));
  check_name(service_name_problem(handler));
  ResourceFilter filter = parse_resource_filter(connect_data);
  const Id id = ++last_id_;
  EventConnection& connection = event_connections_[id];
  connection = {id, client, handler, interface, std::move(filter)};
  // What exists already, client by client: services, then published topics.
  for (const auto& [client_id, provider] : clients_) {
    for (const auto& entry : services_)
      if (entry.second.provider == client_id)
        send_event(connection,
                   {"service_new_provider", entry.second.name, split_name_and_hash(entry.second.interface).first,
                    provider.name},
                   out);
    for (const auto& entry : topics_)
      if (entry.second.publisher == client_id)
        send_event(connection, {"topic_new_publisher", entry.second.name, entry.second.definition, provider.name}, out);
  }
  send_event(connection, {kInitialSyncDone, "", "", ""}, out);
  return connection;
}

void Registry::disconnect_event(Id client, Id id) {
  const auto it = event_connections_.find(id);
  require(it != event_connections_.end() && it->second.client == client, LNE_INVALID_PARAMETER,
          "you have no event connection with id " + std::to_string(id));
  event_connections_.erase(it);
}

void Registry::emit(const ResourceEvent& event, Outbox& out) const {
  for (const auto& entry : event_connections_) send_event(entry.second, event, out);
}

void Registry::send_event(const EventConnection& connection, const ResourceEvent& event, Outbox& out) const {
  if (!filter_accepts(connection.filter, event)) return;
  auto message = protocol::Message::notification(method::event);
  message.set("event_connection_id", connection.id)
      .set("handler", connection.handler)
      .set("data", flatten_resource_event(event))
      .set("signature", connection.interface + ": " + std::string(kResourceEventSignature));
  out.push_back({connection.client, std::move(message)});
}

// --------------------------------------------------------- service logging

void Registry::register_service_logger(Id client, const std::string& logger_service, const std::string& patterns,
                                       Outbox& out) {
  const auto found = service_names_.find(logger_service);
  require(found != service_names_.end() && services_.at(found->second).provider == client, LNE_SVC_NOT_REGISTERED,
          "'" + logger_service + "' is not a service of yours: register it before making it a service logger");
  const std::string interface = split_name_and_hash(services_.at(found->second).interface).first;
  require(interface == "ln/log_service", LNE_INVALID_PARAMETER,
          "service logger '" + logger_service + "' has interface '" + interface + "', not ln/log_service");
  require(patterns.size() <= max_signature_size, LNE_INVALID_PARAMETER, "the logger's patterns are too long");
  ServiceLogger logger{client, {}};
  for (std::size_t start = 0; start <= patterns.size();) {
    const std::size_t comma = std::min(patterns.find(',', start), patterns.size());
    logger.patterns.push_back(patterns.substr(start, comma - start));
    start = comma + 1;
  }
  if (service_loggers_.count(logger_service) > 0) {  // new patterns: the clients start over
    auto gone = protocol::Message::notification(method::del_service_logger);
    gone.set("logger_service", logger_service);
    notify_all_clients(gone, out);
  }
  service_loggers_[logger_service] = std::move(logger);
  auto tell = [&](Id other, const std::string& service) {
    const std::vector<std::string> loggers = loggers_of(service, other);
    if (std::find(loggers.begin(), loggers.end(), logger_service) == loggers.end()) return;
    auto message = protocol::Message::notification(method::add_service_logger);
    message.set("service", service).set("logger_service", logger_service);
    out.push_back({other, std::move(message)});
  };
  for (const auto& entry : services_) tell(entry.second.provider, entry.second.name);
  for (const auto& [caller, services] : called_services_)
    for (const std::string& service : services) tell(caller, service);
}

std::vector<std::string> Registry::loggers_of(const std::string& service, Id client) const {
  std::vector<std::string> loggers;
  for (const auto& [name, logger] : service_loggers_) {
    if (logger.client == client || name == service) continue;  // LN 2.9: no logging of one's own calls
    bool excluded = false, included = false;
    for (const std::string& pattern : logger.patterns) {
      if (!pattern.empty() && pattern[0] == '!')
        excluded = excluded || glob_match(pattern.substr(1), service);
      else
        included = included || glob_match(pattern, service);
    }
    if (included && !excluded) loggers.push_back(name);
  }
  return loggers;
}

void Registry::note_caller(Id client, const std::string& service) {
  if (clients_.count(client) > 0) called_services_[client].insert(service);
}

}  // namespace ln::manager
