#include "manager/dispatch.hpp"

#include <unistd.h>

#include <cmath>
#include <limits>
#include <set>

#include "ln/md/message_definition.hpp"
#include "manager/definitions.hpp"
#include "manager/loggers.hpp"
#include "manager/request_error.hpp"
#include "protocol/methods.hpp"

namespace ln::manager {
namespace {

namespace method = protocol::method;
using protocol::Message;
using protocol::StringList;

// Ids travel as int64; ids the manager hands out are positive.
Id get_id(const Message& request, std::string_view key) {
  return request.get_int(key, 1, std::numeric_limits<std::int64_t>::max());
}

void set_bundle(Message& response, DefinitionBundle bundle) {
  response.set("name", std::move(bundle.name))
      .set("hash", std::move(bundle.hash))
      .set("message_size", bundle.message_size)
      .set("names", std::move(bundle.names))
      .set("texts", std::move(bundle.texts));
}

std::string join(const std::set<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ",") + item;
  return out;
}

}  // namespace

Dispatcher::Dispatcher(Registry& registry, DefinitionStore& definitions, std::string manager_version, LogFunction log)
    : registry_(registry),
      definitions_(definitions),
      manager_version_(std::move(manager_version)),
      log_(std::move(log)) {
  handlers_ = {
      {std::string(method::hello), &Dispatcher::hello},
      {std::string(method::goodbye), &Dispatcher::goodbye},
      {std::string(method::ping), &Dispatcher::ping},
      {std::string(method::get_message_definition), &Dispatcher::get_message_definition},
      {std::string(method::get_message_definition_for_topic), &Dispatcher::get_message_definition_for_topic},
      {std::string(method::put_message_definition), &Dispatcher::put_message_definition},
      {std::string(method::publish), &Dispatcher::publish},
      {std::string(method::publisher_ready), &Dispatcher::publisher_ready},
      {std::string(method::unpublish), &Dispatcher::unpublish},
      {std::string(method::subscribe), &Dispatcher::subscribe},
      {std::string(method::unsubscribe), &Dispatcher::unsubscribe},
      {std::string(method::register_service), &Dispatcher::register_service},
      {std::string(method::unregister_service), &Dispatcher::unregister_service},
      {std::string(method::lookup_service), &Dispatcher::lookup_service},
      {std::string(method::get_service_signature), &Dispatcher::get_service_signature},
      {std::string(method::get_service_signature_for_service), &Dispatcher::get_service_signature_for_service},
      {std::string(method::find_services_with_interface), &Dispatcher::find_services_with_interface},
      {std::string(method::list_clients), &Dispatcher::list_clients},
      {std::string(method::list_topics), &Dispatcher::list_topics},
      {std::string(method::list_services), &Dispatcher::list_services},
      {std::string(method::manager_status), &Dispatcher::manager_status},
      {std::string(method::process_list), &Dispatcher::process_list},
      {std::string(method::process_control), &Dispatcher::process_control},
      {std::string(method::process_output), &Dispatcher::process_output},
      {std::string(method::needs_provider), &Dispatcher::needs_provider},
      {std::string(method::connect_event), &Dispatcher::connect_event},
      {std::string(method::disconnect_event), &Dispatcher::disconnect_event},
      {std::string(method::register_as_service_logger), &Dispatcher::register_as_service_logger},
  };
}

Message Dispatcher::deferred() { return Message::notification("(answered later)"); }

bool Dispatcher::is_deferred(const Message& response) {
  return response.kind() == protocol::Kind::Notification && response.get_string_or("method", "") == "(answered later)";
}

void Dispatcher::listening_at(std::string address) {
  listen_address_ = std::move(address);
  started_ = std::chrono::steady_clock::now();
}

void Dispatcher::handle_notification(Session& session, const Message& notification, const LogFunction& log) {
  const std::string name = notification.get_string_or("method", "");
  if (name != method::topic_stats || !session.client) {
    if (log) log(LogLevel::Debug, "ignored the notification '" + name + "'");
    return;
  }
  try {
    registry_.count_packets(*session.client, get_id(notification, "topic_id"),
                            notification.get_int("packets", 0, std::numeric_limits<std::int64_t>::max()));
  } catch (const std::exception& e) {
    // A report may race an unpublish; nothing a client sends this way is answered.
    if (log) log(LogLevel::Debug, "dropped the notification '" + name + "': " + e.what());
  }
}

Message Dispatcher::handle(Session& session, const Message& request, Outbox& out, const LogFunction& log) {
  std::string name = "(none)";
  try {
    name = request.get_string("method");
    const auto handler = handlers_.find(name);
    const bool for_loggers = loggers_ != nullptr && Loggers::handles(name);
    if (handler == handlers_.end() && !for_loggers)
      throw RequestError(LNE_MANAGER_TOO_OLD, "this manager does not know the method '" + name + "'");
    if (!session.client && (for_loggers || handler->second != &Dispatcher::hello))
      throw RequestError(LNE_CLIENT_NOT_INITIALIZED, "say hello first: '" + name + "' needs a registered client");
    if (for_loggers) {
      auto response = loggers_->handle(*session.client, request, out);
      return response ? std::move(*response) : deferred();
    }
    return (this->*handler->second)(session, request, out);
  } catch (const RequestError& e) {
    return Message::error_response_to(request, e.code(), e.what());
  } catch (const protocol::ProtocolError& e) {
    // Missing fields and wrong types: the request is answered, not the
    // connection dropped, so a client bug shows up as a clear error.
    return Message::error_response_to(request, LNE_INVALID_PARAMETER,
                                      "invalid '" + name + "' request: " + std::string(e.what()));
  } catch (const std::exception& e) {
    if (log) log(LogLevel::Error, "internal error while handling '" + name + "': " + e.what());
    return Message::error_response_to(request, LNE_INTERNAL_ERROR, "internal manager error: " + std::string(e.what()));
  }
}

Message Dispatcher::hello(Session& session, const Message& request, Outbox&) {
  if (session.client)
    throw RequestError(LNE_REGISTER_DENIED, "this connection is already registered as client '" +
                                                registry_.client(*session.client).name + "'");
  ClientHello hello;
  hello.program_name = request.get_string("program_name");
  hello.exact = request.get_bool_or("exact", false);
  hello.pid = request.get_int_or("pid", 0);
  hello.host_name = request.get_string_or("host_name", "");
  hello.host_id = request.get_string_or("host_id", "");
  hello.uid = request.get_int_or("uid", -1);
  hello.library_version = request.get_int_or("library_version", 0);
  hello.peer_socket = request.get_string_or("peer_socket", "");
  hello.peer_address = request.get_string_or("peer_address", "");
  hello.previous_name = request.get_string_or("previous_name", "");
  const Client& client = registry_.add_client(std::move(hello));
  session.client = client.id;
  return Message::response_to(request)
      .set("client_name", client.name)
      .set("client_id", client.id)
      .set("manager_version", manager_version_);
}

Message Dispatcher::goodbye(Session& session, const Message& request, Outbox& out) {
  registry_.remove_client(*session.client, out);
  session.client.reset();
  session.close_after_response = true;
  return Message::response_to(request);
}

Message Dispatcher::ping(Session&, const Message& request, Outbox&) { return Message::response_to(request); }

Message Dispatcher::get_message_definition(Session&, const Message& request, Outbox&) {
  const md::Definition& definition = definitions_.resolve(request.get_string("name"));
  Message response = Message::response_to(request);
  set_bundle(response, definitions_.bundle(definition));
  return response;
}

Message Dispatcher::get_message_definition_for_topic(Session&, const Message& request, Outbox&) {
  const Topic& topic = registry_.topic_named(request.get_string("topic"));
  const md::Definition& definition = definitions_.resolve(topic.definition);
  Message response = Message::response_to(request);
  set_bundle(response, definitions_.bundle(definition));
  return response;
}

Message Dispatcher::put_message_definition(Session& session, const Message& request, Outbox&) {
  const auto stored = definitions_.put(
      request.get_string("name"), request.get_string("text"),
      [this](const std::string& name) { return registry_.definition_in_use(name); }, session.definitions_put);
  return Message::response_to(request).set("name", stored.name).set("hash", stored.hash);
}

Message Dispatcher::publish(Session& session, const Message& request, Outbox& out) {
  const Topic& topic = registry_.publish(*session.client, request.get_string("topic"),
                                         request.get_string("message_definition"), request.get_int("buffers"), out);
  return Message::response_to(request)
      .set("topic_id", topic.id)
      .set("message_size", topic.message_size)
      .set("hash", topic.hash)
      .set("subscriber_buffers", registry_.subscriber_buffers(topic))
      .set("segment_limit", static_cast<std::int64_t>(registry_.limits().max_topic_shm));
}

Message Dispatcher::publisher_ready(Session& session, const Message& request, Outbox& out) {
  constexpr std::int64_t max = std::numeric_limits<std::int64_t>::max();
  std::optional<std::int64_t> packets;
  if (request.has("packets")) packets = request.get_int("packets", 0, max);
  const Id topic_id = get_id(request, "topic_id");
  registry_.publisher_ready(*session.client, topic_id, request.get_int("segment_generation", 0, max), packets, out);
  if (loggers_ != nullptr) loggers_->publisher_ready(registry_.topic(topic_id), out);
  if (request.has("recovered") && log_)
    log_(LogLevel::Warning, "client '" + registry_.client(*session.client).name +
                                "' found the shared-memory segment of topic '" + registry_.topic(topic_id).name +
                                "' corrupted and replaced it (" + std::to_string(request.get_int("recovered", 0, max)) +
                                " times so far); a subscriber process of that topic writes where it must not");
  return Message::response_to(request);
}

Message Dispatcher::unpublish(Session& session, const Message& request, Outbox& out) {
  registry_.unpublish(*session.client, get_id(request, "topic_id"), out);
  return Message::response_to(request);
}

Message Dispatcher::subscribe(Session& session, const Message& request, Outbox& out) {
  SubscribeRequest wanted;
  wanted.topic = request.get_string("topic");
  wanted.definition = request.get_string("message_definition");
  wanted.buffers = request.get_int("buffers");
  wanted.rate = request.get_double("rate");
  wanted.reliable = request.get_bool("reliable");
  wanted.receive_address = request.get_string_or("receive_address", "");
  const Subscription& subscription = registry_.subscribe(*session.client, wanted, out);
  const Topic& topic = registry_.topic(subscription.topic);
  Message response = Message::response_to(request);
  response.set("subscription_id", subscription.id)
      .set("topic_id", topic.id)
      .set("message_size", topic.message_size)
      .set("hash", topic.hash)
      .set("message_definition", topic.definition);
  if (topic.publisher && topic.publisher_ready) registry_.set_publisher_fields(topic, response);
  return response;
}

Message Dispatcher::unsubscribe(Session& session, const Message& request, Outbox& out) {
  registry_.unsubscribe(*session.client, get_id(request, "subscription_id"), out);
  return Message::response_to(request);
}

Message Dispatcher::register_service(Session& session, const Message& request, Outbox& out) {
  const Service& service =
      registry_.register_service(*session.client, request.get_string("name"), request.get_string("interface"),
                                 request.get_string("signature"), request.get_string_or("group", ""), out);
  return Message::response_to(request)
      .set("service_id", service.id)
      .set("log_services", registry_.loggers_of(service.name, *session.client));
}

Message Dispatcher::unregister_service(Session& session, const Message& request, Outbox& out) {
  registry_.unregister_service(*session.client, get_id(request, "service_id"), out);
  return Message::response_to(request);
}

Message Dispatcher::lookup_service(Session& session, const Message& request, Outbox&) {
  const Service& service = registry_.lookup_service(request.get_string("name"), request.get_string_or("interface", ""),
                                                    request.get_string_or("signature", ""));
  registry_.note_caller(*session.client, service.name);
  const Client& provider = registry_.client(service.provider);
  return Message::response_to(request)
      .set("interface", service.interface)
      .set("signature", service.signature)
      .set("provider", provider.name)
      .set("host_id", provider.hello.host_id)
      .set("peer_socket", provider.hello.peer_socket)
      .set("peer_address", provider.hello.peer_address)
      .set("service_id", service.id)
      .set("log_services", registry_.loggers_of(service.name, *session.client));
}

Message Dispatcher::get_service_signature(Session&, const Message& request, Outbox&) {
  const md::Definition& definition = definitions_.resolve(request.get_string("interface"));
  DefinitionBundle bundle = definitions_.bundle(definition);
  Message response = Message::response_to(request);
  response.set("definition", bundle.texts.front()).set("signature", md::signature(definition));
  set_bundle(response, std::move(bundle));
  return response;
}

Message Dispatcher::get_service_signature_for_service(Session&, const Message& request, Outbox&) {
  const Service& service = registry_.service_named(request.get_string("name"));
  const md::Definition& definition = definitions_.resolve(service.interface);
  DefinitionBundle bundle = definitions_.bundle(definition);
  Message response = Message::response_to(request);
  // The provider's signature: the one lookup_service compares with.
  response.set("interface", service.interface)
      .set("definition", bundle.texts.front())
      .set("signature", service.signature);
  set_bundle(response, std::move(bundle));
  return response;
}

Message Dispatcher::find_services_with_interface(Session&, const Message& request, Outbox&) {
  return Message::response_to(request).set("services",
                                           registry_.services_with_interface(request.get_string("interface")));
}

Message Dispatcher::list_clients(Session&, const Message& request, Outbox&) {
  StringList names, ids, pids, hosts, host_ids, published, subscribed, services;
  for (const auto& [id, client] : registry_.clients()) {
    std::set<std::string> publishes, subscribes, provides;
    for (const auto& entry : registry_.topics())
      if (entry.second.publisher == id) publishes.insert(entry.second.name);
    for (const auto& entry : registry_.subscriptions())
      if (entry.second.client == id) subscribes.insert(registry_.topic(entry.second.topic).name);
    for (const auto& entry : registry_.services())
      if (entry.second.provider == id) provides.insert(entry.second.name);
    names.push_back(client.name);
    ids.push_back(std::to_string(id));
    pids.push_back(std::to_string(client.hello.pid));
    hosts.push_back(client.hello.host_name);
    host_ids.push_back(client.hello.host_id);
    published.push_back(join(publishes));
    subscribed.push_back(join(subscribes));
    services.push_back(join(provides));
  }
  return Message::response_to(request)
      .set("names", std::move(names))
      .set("ids", std::move(ids))
      .set("pids", std::move(pids))
      .set("hosts", std::move(hosts))
      .set("host_ids", std::move(host_ids))
      .set("published", std::move(published))
      .set("subscribed", std::move(subscribed))
      .set("services", std::move(services));
}

Message Dispatcher::list_topics(Session&, const Message& request, Outbox&) {
  StringList names, ids, definitions, hashes, sizes, publishers, subscribers, packets, rates;
  for (const auto& [id, topic] : registry_.topics()) {
    names.push_back(topic.name);
    ids.push_back(std::to_string(id));
    definitions.push_back(topic.definition);
    hashes.push_back(topic.hash);
    sizes.push_back(std::to_string(topic.message_size));
    publishers.push_back(topic.publisher ? registry_.client(*topic.publisher).name : "");
    subscribers.push_back(std::to_string(topic.subscriptions.size()));
    packets.push_back(std::to_string(topic.publisher ? topic.packets : 0));
    rates.push_back(shortest_text(std::round(registry_.current_rate(topic) * 1000) / 1000));
  }
  return Message::response_to(request)
      .set("names", std::move(names))
      .set("ids", std::move(ids))
      .set("definitions", std::move(definitions))
      .set("hashes", std::move(hashes))
      .set("message_sizes", std::move(sizes))
      .set("publishers", std::move(publishers))
      .set("subscribers", std::move(subscribers))
      .set("packets", std::move(packets))
      .set("rates", std::move(rates));
}

Message Dispatcher::list_services(Session&, const Message& request, Outbox&) {
  StringList names, ids, interfaces, signatures, providers, groups;
  for (const auto& [id, service] : registry_.services()) {
    names.push_back(service.name);
    ids.push_back(std::to_string(id));
    interfaces.push_back(service.interface);
    signatures.push_back(service.signature);
    providers.push_back(registry_.client(service.provider).name);
    groups.push_back(service.group);
  }
  return Message::response_to(request)
      .set("names", std::move(names))
      .set("ids", std::move(ids))
      .set("interfaces", std::move(interfaces))
      .set("signatures", std::move(signatures))
      .set("providers", std::move(providers))
      .set("groups", std::move(groups));
}

Message Dispatcher::manager_status(Session&, const Message& request, Outbox&) {
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  return Message::response_to(request)
      .set("version", manager_version_)
      .set("pid", static_cast<std::int64_t>(::getpid()))
      .set("address", listen_address_)
      .set("uptime", uptime)
      .set("clients", static_cast<std::int64_t>(registry_.clients().size()))
      .set("topics", static_cast<std::int64_t>(registry_.topics().size()))
      .set("services", static_cast<std::int64_t>(registry_.services().size()))
      .set("message_definition_dirs", definitions_.search_dirs());
}

Message Dispatcher::connect_event(Session& session, const Message& request, Outbox& out) {
  const EventConnection& connection =
      registry_.connect_event(*session.client, request.get_string("name"), request.get_string("signature"),
                              request.get_string("connect_data"), request.get_string("handler"), out);
  return Message::response_to(request).set("event_connection_id", connection.id);
}

Message Dispatcher::disconnect_event(Session& session, const Message& request, Outbox&) {
  registry_.disconnect_event(*session.client, get_id(request, "event_connection_id"));
  return Message::response_to(request);
}

Message Dispatcher::register_as_service_logger(Session& session, const Message& request, Outbox& out) {
  registry_.register_service_logger(*session.client, request.get_string("logger_service"),
                                    request.get_string("patterns"), out);
  return Message::response_to(request);
}

}  // namespace ln::manager
