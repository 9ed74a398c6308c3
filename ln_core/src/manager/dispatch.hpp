// Turns one request of a client into registry operations and a response:
// reads and checks the fields methods.hpp names, never evaluates anything.
#pragma once

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "manager/log.hpp"
#include "manager/registry.hpp"
#include "protocol/wire.hpp"

namespace ln::manager {

class DefinitionStore;
class Loggers;
class ProcessControl;

/// What the manager knows about one connection's conversation.
struct Session {
  std::optional<Id> client;  ///< set by hello, cleared by goodbye
  /// Set by goodbye: close once the response is out.
  bool close_after_response = false;
  /// put_message_definition requests whose text had to be parsed
  /// (max_definitions_per_client).
  std::size_t definitions_put = 0;
};

class Dispatcher {
 public:
  /// `log` receives what handlers report beyond their responses.
  Dispatcher(Registry& registry, DefinitionStore& definitions, std::string manager_version, LogFunction log = {});

  /// The response to `request`; notifications for other clients go to
  /// `out`. Never throws: every failure becomes an error response.
  protocol::Message handle(Session& session, const protocol::Message& request, Outbox& out, const LogFunction& log);
  /// A notification from a client (methods.hpp: only topic_stats counts).
  /// Never throws; what cannot be used is dropped.
  void handle_notification(Session& session, const protocol::Message& notification, const LogFunction& log);
  /// The manager listens at `address` ("IP:PORT") from now on: manager_status
  /// reports it and counts the uptime from here.
  void listening_at(std::string address);
  /// Serves the logger_* methods through `loggers` from now on.
  void serve_loggers(Loggers& loggers) { loggers_ = &loggers; }
  /// handle()'s answer to a request whose response is sent later.
  static protocol::Message deferred();
  static bool is_deferred(const protocol::Message& response);
  /// The processes, states and groups the process_* requests act on
  /// (process_methods.cpp); none until set.
  void set_process_control(ProcessControl* control) { process_control_ = control; }

 private:
  using Handler = protocol::Message (Dispatcher::*)(Session&, const protocol::Message&, Outbox&);

  protocol::Message hello(Session&, const protocol::Message&, Outbox&);
  protocol::Message goodbye(Session&, const protocol::Message&, Outbox&);
  protocol::Message ping(Session&, const protocol::Message&, Outbox&);
  protocol::Message get_message_definition(Session&, const protocol::Message&, Outbox&);
  protocol::Message get_message_definition_for_topic(Session&, const protocol::Message&, Outbox&);
  protocol::Message put_message_definition(Session&, const protocol::Message&, Outbox&);
  protocol::Message publish(Session&, const protocol::Message&, Outbox&);
  protocol::Message publisher_ready(Session&, const protocol::Message&, Outbox&);
  protocol::Message unpublish(Session&, const protocol::Message&, Outbox&);
  protocol::Message subscribe(Session&, const protocol::Message&, Outbox&);
  protocol::Message unsubscribe(Session&, const protocol::Message&, Outbox&);
  protocol::Message register_service(Session&, const protocol::Message&, Outbox&);
  protocol::Message unregister_service(Session&, const protocol::Message&, Outbox&);
  protocol::Message lookup_service(Session&, const protocol::Message&, Outbox&);
  protocol::Message get_service_signature(Session&, const protocol::Message&, Outbox&);
  protocol::Message get_service_signature_for_service(Session&, const protocol::Message&, Outbox&);
  protocol::Message find_services_with_interface(Session&, const protocol::Message&, Outbox&);
  protocol::Message list_clients(Session&, const protocol::Message&, Outbox&);
  protocol::Message list_topics(Session&, const protocol::Message&, Outbox&);
  protocol::Message list_services(Session&, const protocol::Message&, Outbox&);
  protocol::Message manager_status(Session&, const protocol::Message&, Outbox&);
  // process_methods.cpp
  protocol::Message process_list(Session&, const protocol::Message&, Outbox&);
  protocol::Message process_control(Session&, const protocol::Message&, Outbox&);
  protocol::Message process_output(Session&, const protocol::Message&, Outbox&);
  protocol::Message needs_provider(Session&, const protocol::Message&, Outbox&);
  protocol::Message connect_event(Session&, const protocol::Message&, Outbox&);
  protocol::Message disconnect_event(Session&, const protocol::Message&, Outbox&);
  protocol::Message register_as_service_logger(Session&, const protocol::Message&, Outbox&);

  Registry& registry_;
  DefinitionStore& definitions_;
  std::string manager_version_;
  LogFunction log_;
  std::string listen_address_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::map<std::string, Handler, std::less<>> handlers_;
  Loggers* loggers_ = nullptr;
  ProcessControl* process_control_ = nullptr;
};

}  // namespace ln::manager
