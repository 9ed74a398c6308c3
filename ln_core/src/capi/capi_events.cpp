// ln.h: events (client/events.hpp does the work).
#include "capi/capi_support.hpp"
#include "client/events.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::EventCall;
using ln::clientlib::EventConnection;
using ln::clientlib::EventHandler;
using ln::clientlib::EventHub;
using ln::clientlib::Failure;
namespace services = ln::services;

namespace {

int connect(ln_client clnt, ln_event_connection* conn, const char* event_name, const char* connect_signature,
            const std::function<std::string(const std::string& side_signature)>& flat_connect_data,
            ln_event_handler handler, void* user_data) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(conn != nullptr, "conn");
    require(event_name != nullptr, "event_name");
    require(connect_signature != nullptr, "connect_signature");
    require(handler != nullptr, "handler");
    const std::string signature = connect_signature;
    const std::size_t colon = signature.find(": ");
    if (colon == std::string::npos || colon == 0)
      throw Failure(LNE_INVALID_SIGNATURE, "connect signature '" + signature +
                                               "' does not read '<definition>: <signature>' (pass the generated "
                                               "*_CONNECT_SIGNATURE)");
    std::string flat = flat_connect_data(signature.substr(colon + 2));
    *conn = EventHub::of(*client)->connect(event_name, signature, std::move(flat),
                                           reinterpret_cast<EventHandler>(handler), user_data);
    return 0;
  });
}

}  // namespace

extern "C" {

int ln_event_connect(ln_client clnt, ln_event_connection* conn, const char* event_name, const char* connect_signature,
                     void* connect_data, ln_event_handler handler, void* user_data) {
  return connect(
      clnt, conn, event_name, connect_signature,
      [&](const std::string& side) {
        services::MessageLayout layout;
        const services::Status compiled = services::MessageLayout::compile(side, layout);
        if (!compiled.ok()) throw Failure(LNE_INVALID_SIGNATURE, "invalid connect signature: " + compiled.detail());
        require(connect_data != nullptr || layout.empty(), "connect_data");
        std::string flat;
        const services::Status flattened = services::flatten(layout, connect_data, services::Limits{}, flat);
        if (!flattened.ok()) throw Failure(-flattened.code(), "connect data: " + flattened.detail());
        return flat;
      },
      handler, user_data);
}

int ln_event_connect_flat(ln_client clnt, ln_event_connection* conn, const char* event_name,
                          const char* connect_signature, void* connect_data_flat, uint32_t connect_data_flat_len,
                          ln_event_handler handler, void* user_data) {
  return connect(
      clnt, conn, event_name, connect_signature,
      [&](const std::string&) {
        require(connect_data_flat != nullptr || connect_data_flat_len == 0, "connect_data_flat");
        return std::string(static_cast<const char*>(connect_data_flat), connect_data_flat_len);
      },
      handler, user_data);
}

int ln_event_connection_deinit(ln_event_connection* conn) {
  if (conn == nullptr) return -LNE_INVALID_PARAMETER;
  EventConnection* connection = EventConnection::from_handle(*conn);
  if (connection == nullptr) return -LNE_INVALID_PARAMETER;
  if (auto hub = connection->hub())
    hub->disconnect(connection);
  else
    delete connection;  // its client is gone, and with it everything else of the connection
  *conn = nullptr;
  return 0;
}

unsigned int ln_event_connection_get_id(ln_event_connection conn) {
  EventConnection* connection = EventConnection::from_handle(conn);
  return connection != nullptr ? connection->id() : 0;
}

int ln_event_call_set_data(ln_event_call call, const char* call_signature, void* call_data) {
  EventCall* event = EventCall::from_handle(call);
  if (event == nullptr) return -LNE_INVALID_PARAMETER;
  const services::Status filled = event->set_data(call_signature, call_data);
  if (!filled.ok()) event->client().errors().set(filled.detail());
  return filled.code();
}

int ln_event_call_get_buffer(ln_event_call call, void** ptr, uint32_t* len) {
  EventCall* event = EventCall::from_handle(call);
  if (event == nullptr || ptr == nullptr || len == nullptr) return -LNE_INVALID_PARAMETER;
  *ptr = const_cast<char*>(event->data().data());
  *len = static_cast<uint32_t>(event->data().size());
  return 0;
}

}  // extern "C"
