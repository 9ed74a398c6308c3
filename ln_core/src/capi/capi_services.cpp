// ln.h: services (calling, providing, groups and pools, introspection,
// waiting for providers, availability handlers). The data path is
// src/services; client/services_glue.hpp ties it to the manager and the
// peer server.
#include <sys/uio.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <set>
#include <thread>

#include "capi/capi_support.hpp"
#include "client/services_glue.hpp"
#include "protocol/methods.hpp"
#include "services/call_state.hpp"
#include "services/dispatch.hpp"
#include "services/signature.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::malloc_copy;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::Failure;
using ln::clientlib::ServicesGlue;
namespace services = ln::services;
namespace method = ln::protocol::method;

namespace {

// What an ln_service points to.
struct Service {
  Client* client = nullptr;
  std::shared_ptr<ServicesGlue> glue;
  std::string name;  // after the service name mapping
  std::string interface;
  std::shared_ptr<const services::ServiceSignature> signature;
  std::unique_ptr<services::ServiceCaller> caller;
  services::AsyncCall* async = nullptr;  // the handle's asynchronous call, once started

  std::mutex mutex;  // the provider fields
  services::Handler handler = nullptr;
  void* user_data = nullptr;
  ln_service_fd_handler fd_handler = nullptr;
  void* fd_user_data = nullptr;
  std::uint32_t provider_id = 0;  // 0: not registered
};

std::mutex& live_services_mutex() {
  static std::mutex mutex;
  return mutex;
}
std::set<Service*>& live_services() {
  static std::set<Service*> services;
  return services;
}

Service* service_from(ln_service handle) {
  auto* service = static_cast<Service*>(handle);
  std::lock_guard<std::mutex> lock(live_services_mutex());
  return live_services().count(service) != 0 ? service : nullptr;
}

// 0 or the negative code; the detail goes to the client's error slot.
int report(Client* client, const services::Status& status) {
  if (!status.ok() && client != nullptr) client->errors().set(status.detail());
  return status.code();
}

// A call's result; failures leave their detail for ln_get_error_message().
int call_result(Service* service, int result) {
  if (result != 0) service->client->errors().set(service->caller->last_error());
  return result;
}

std::string flatten(const struct iovec* iov, unsigned iov_len) {
  std::size_t size = 0;
  for (unsigned i = 0; i < iov_len; ++i) size += iov[i].iov_len;
  std::string flat;
  flat.reserve(size);
  for (unsigned i = 0; i < iov_len; ++i) flat.append(static_cast<const char*>(iov[i].iov_base), iov[i].iov_len);
  return flat;
}

void fd_trampoline(void* client, int event, int fd, void* user_data) {
  auto* service = static_cast<Service*>(user_data);
  ln_service_fd_handler handler;
  void* handler_data;
  {
    std::lock_guard<std::mutex> lock(service->mutex);
    handler = service->fd_handler;
    handler_data = service->fd_user_data;
  }
  if (handler != nullptr) handler(client, static_cast<ln_svc_client_event_t>(event), fd, handler_data);
}

int register_in_group(ln_client clnt, ln_service svc, const char* group_name) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  return guarded(client, [&] {
    std::lock_guard<std::mutex> lock(service->mutex);
    if (service->handler == nullptr)
      throw Failure(LNE_SVC_NO_HANDLER,
                    "service '" + service->name + "' has no handler; call ln_service_provider_set_handler first");
    if (service->provider_id != 0)
      throw Failure(LNE_SVC_ALREADY_REGISTERED, "service '" + service->name + "' is already registered");
    service->provider_id = service->glue->register_provider(service->name, service->interface, service->signature,
                                                            service->handler, service->user_data, group_name);
    if (service->fd_handler != nullptr)
      service->glue->dispatcher().set_connection_observer(service->provider_id, fd_trampoline, service);
    return 0;
  });
}

services::Request* provider_request(ln_service_request req) { return services::provider_request(req); }
services::AsyncCall* caller_request(ln_service_request req) { return services::caller_request(req); }

double seconds_left(std::chrono::steady_clock::time_point deadline) {
  return std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
}

// Why the process or state `name` failed ("" while it has not), from the
// manager's process_list.
std::string provider_failure(Client& client, const std::string& name) {
  const auto answer = client.request(client.new_request(method::process_list));
  const auto& names = answer.get_list("names");
  const auto& states = answer.get_list("states");
  const auto& errors = answer.get_list("errors");
  for (std::size_t row = 0; row < names.size() && row < states.size() && row < errors.size(); ++row)
    if (names[row] == name && (states[row] == "failed" || states[row] == "error"))
      return errors[row].empty() ? states[row] : errors[row];
  return "";
}

}  // namespace

extern "C" {

// ------------------------------------------------------------------ handles

int ln_service_init(ln_client clnt, ln_service* svc, const char* service_name, const char* service_interface,
                    const char* signature) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(svc != nullptr, "svc");
    require(service_name != nullptr, "service_name");
    require(service_interface != nullptr, "service_interface");
    require(signature != nullptr, "signature");
    auto service = std::make_unique<Service>();
    services::Status compiled = services::ServiceSignature::compile_shared(signature, service->signature);
    if (!compiled.ok()) throw Failure(LNE_INVALID_SIGNATURE, compiled.detail());
    service->client = client;
    service->glue = ServicesGlue::of(*client);
    service->name = client->service_mapping().apply(service_name);
    service->interface = service_interface;
    service->caller = std::make_unique<services::ServiceCaller>(
        service->signature, service->glue->connector(service->name, service->interface, signature),
        service->glue->reactor(), service->glue->limits(), service->glue->wait_policy(), service->name);
    service->caller->set_call_log(service->glue->call_log(), service->interface);
    {
      std::lock_guard<std::mutex> lock(live_services_mutex());
      live_services().insert(service.get());
    }
    *svc = service.release();
    return 0;
  });
}

int ln_service_deinit(ln_service* svc) {
  if (svc == nullptr) return -LNE_INVALID_PARAMETER;
  Service* service = service_from(*svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  {
    std::lock_guard<std::mutex> lock(live_services_mutex());
    live_services().erase(service);
  }
  std::uint32_t provider_id;
  {
    std::lock_guard<std::mutex> lock(service->mutex);
    provider_id = service->provider_id;
    service->provider_id = 0;
  }
  if (provider_id != 0) service->glue->release_provider(provider_id);
  delete service;  // the caller aborts a running asynchronous call
  *svc = nullptr;
  return 0;
}

// ------------------------------------------------------------------ calling

int ln_service_call(ln_service svc, void* data) { return ln_service_call_with_timeout(svc, data, 0); }

int ln_service_call_with_timeout(ln_service svc, void* data, double timeout) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  return call_result(service, service->caller->call(data, timeout));
}

int ln_service_call_abort(ln_service svc) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  return service->caller->abort();
}

int ln_service_callv(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens,
                     char** response_buffer, uint32_t* response_len, uint8_t* need_swap) {
  return ln_service_callv_with_timeout(svc, iov, iov_len, iov_element_lens, response_buffer, response_len, need_swap,
                                       0);
}

int ln_service_callv_with_timeout(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t*,
                                  char** response_buffer, uint32_t* response_len, uint8_t* need_swap, double timeout) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  if ((iov == nullptr && iov_len != 0) || response_buffer == nullptr || response_len == nullptr)
    return -LNE_INVALID_PARAMETER;
  const int result = call_result(service, service->caller->call_flat(flatten(iov, iov_len), timeout));
  if (need_swap != nullptr) *need_swap = 0;  // frames carry little-endian data; we are little-endian
  if (result != 0) return result;
  const std::string_view response = service->caller->last_response();
  *response_buffer = const_cast<char*>(response.data());
  *response_len = static_cast<uint32_t>(response.size());
  return 0;
}

int ln_service_call_async(ln_service svc, void* data, ln_service_request* req) {
  Service* service = service_from(svc);
  if (service == nullptr || req == nullptr) return -LNE_INVALID_PARAMETER;
  services::AsyncCall* call = nullptr;
  const int result = call_result(service, service->caller->call_async(data, call));
  if (result != 0) return result;
  service->async = call;
  *req = services::to_handle(call);
  return 0;
}

int ln_service_callv_async(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t*, ln_service_request* req) {
  Service* service = service_from(svc);
  if (service == nullptr || req == nullptr || (iov == nullptr && iov_len != 0)) return -LNE_INVALID_PARAMETER;
  services::AsyncCall* call = nullptr;
  const int result = call_result(service, service->caller->call_flat_async(flatten(iov, iov_len), call));
  if (result != 0) return result;
  service->async = call;
  *req = services::to_handle(call);
  return 0;
}

int ln_service_callv_async_get_response(ln_service svc, char** response_buffer, uint32_t* response_len) {
  Service* service = service_from(svc);
  if (service == nullptr || response_buffer == nullptr || response_len == nullptr) return -LNE_INVALID_PARAMETER;
  if (service->async == nullptr) return -LNE_SVC_REQ_NOT_RUNNING;
  int retval = 0;
  const int finished = service->async->finished(&retval);
  if (finished < 0) return finished;
  if (finished == 0) return -LNE_SVC_REQ_RUNNING;
  if (retval != 0) return retval;
  const std::string_view response = service->async->response();
  *response_buffer = const_cast<char*>(response.data());
  *response_len = static_cast<uint32_t>(response.size());
  return 0;
}

int ln_service_callv_async_get_response_data(ln_service svc, void* data) {
  Service* service = service_from(svc);
  if (service == nullptr || data == nullptr) return -LNE_INVALID_PARAMETER;
  if (service->async == nullptr) return -LNE_SVC_REQ_NOT_RUNNING;
  return service->async->response_into(data);
}

// ------------------------------------------------- requests (either side)

int ln_service_request_abort(ln_service_request req) {
  services::AsyncCall* call = caller_request(req);
  return call != nullptr ? call->abort() : -LNE_INVALID_PARAMETER;
}

int ln_service_request_finished(ln_service_request req, int* retval) {
  services::AsyncCall* call = caller_request(req);
  if (call == nullptr || retval == nullptr) return -LNE_INVALID_PARAMETER;
  return call->finished(retval);
}

int ln_service_request_wait(ln_service_request req, double timeout, int* retval) {
  services::AsyncCall* call = caller_request(req);
  if (call == nullptr || retval == nullptr) return -LNE_INVALID_PARAMETER;
  return call->wait(timeout, retval);
}

int ln_service_request_get_finished_notification_fd(ln_service_request req, int* fd) {
  services::AsyncCall* call = caller_request(req);
  if (call == nullptr || fd == nullptr) return -LNE_INVALID_PARAMETER;
  *fd = call->notification_fd();
  return 0;
}

const char* ln_service_request_get_error_message(ln_service_request req) {
  services::AsyncCall* call = caller_request(req);
  return call != nullptr ? call->error_message() : nullptr;
}

int ln_service_request_set_data(ln_service_request req, void* data, const char* signature) {
  services::Request* request = provider_request(req);
  if (request == nullptr || data == nullptr || signature == nullptr) return -LNE_INVALID_PARAMETER;
  return request->set_data(data, signature).code();
}

int ln_service_request_get_request_data(ln_service_request req, char** buffer, uint64_t* buffer_len) {
  services::Request* request = provider_request(req);
  if (request == nullptr || buffer == nullptr || buffer_len == nullptr) return -LNE_INVALID_PARAMETER;
  const std::string_view data = request->request_data();
  *buffer = const_cast<char*>(data.data());
  *buffer_len = data.size();
  return 0;
}

int ln_service_request_respond(ln_service_request req) {
  services::Request* request = provider_request(req);
  return request != nullptr ? request->respond().code() : -LNE_INVALID_PARAMETER;
}

int ln_service_request_respondv(ln_service_request req, struct iovec* iov, unsigned int iov_len) {
  services::Request* request = provider_request(req);
  if (request == nullptr || (iov == nullptr && iov_len != 0)) return -LNE_INVALID_PARAMETER;
  return request->respond_flat(flatten(iov, iov_len)).code();
}

int ln_service_request_respond_data(ln_service_request req, void* data) {
  services::Request* request = provider_request(req);
  if (request == nullptr || data == nullptr) return -LNE_INVALID_PARAMETER;
  return request->respond_data(data).code();
}

int ln_service_request_respond_error(ln_service_request req, int error, const char* message) {
  services::Request* request = provider_request(req);
  if (request == nullptr) return -LNE_INVALID_PARAMETER;
  return request->respond_error(error, message != nullptr ? message : "").code();
}

int ln_service_request_is_aborted(ln_service_request req) {
  services::Request* request = provider_request(req);
  if (request == nullptr) return -LNE_INVALID_PARAMETER;
  return request->is_aborted() ? 1 : 0;
}

// ---------------------------------------------------------------- providing

int ln_service_provider_set_handler(ln_service svc, ln_service_handler handler, void* user_data) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  std::lock_guard<std::mutex> lock(service->mutex);
  if (service->provider_id != 0) return -LNE_SVC_ALREADY_REGISTERED;
  service->handler = reinterpret_cast<services::Handler>(handler);
  service->user_data = user_data;
  return 0;
}

int ln_service_provider_register(ln_client clnt, ln_service svc) { return register_in_group(clnt, svc, nullptr); }

int ln_service_provider_register_in_group(ln_client clnt, ln_service svc, const char* group_name) {
  return register_in_group(clnt, svc, group_name);
}

int ln_service_provider_get_fd(ln_service svc) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  std::lock_guard<std::mutex> lock(service->mutex);
  if (service->provider_id == 0) return -LNE_SVC_NOT_REGISTERED;
  return service->glue->dispatcher().provider_fd(service->provider_id);
}

int ln_service_provider_set_client_fd_handler(ln_service svc, ln_service_fd_handler handler, void* user_data) {
  Service* service = service_from(svc);
  if (service == nullptr) return -LNE_INVALID_PARAMETER;
  std::lock_guard<std::mutex> lock(service->mutex);
  service->fd_handler = handler;
  service->fd_user_data = user_data;
  if (service->provider_id == 0) return 0;  // installed at registration
  return report(service->client,
                service->glue->dispatcher().set_connection_observer(service->provider_id, fd_trampoline, service));
}

// ------------------------------------------------------- groups and pools

#define LN_WITH_GLUE(clnt, expression)                                          \
  Client* client = client_from(clnt);                                           \
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;                    \
  return guarded(client, [&] {                                                  \
    services::Dispatcher& dispatcher = ServicesGlue::of(*client)->dispatcher(); \
    return report(client, expression);                                          \
  })

int ln_wait_and_handle_service_group_requests(ln_client clnt, const char* group_name, double timeout) {
  LN_WITH_GLUE(clnt, dispatcher.wait_and_handle(group_name, timeout));
}

int ln_handle_service_group_in_thread_pool(ln_client clnt, const char* group_name, const char* pool_name) {
  LN_WITH_GLUE(clnt, dispatcher.handle_in_pool(group_name, pool_name));
}

int ln_remove_service_group_from_thread_pool(ln_client clnt_, const char* group_name) {
  LN_WITH_GLUE(clnt_, dispatcher.remove_from_pool(group_name));
}

int ln_unblock_service_group(ln_client clnt_, const char* group_name) {
  LN_WITH_GLUE(clnt_, dispatcher.unblock(group_name));
}

int ln_set_max_threads(ln_client clnt, const char* pool_name, unsigned int n_threads) {
  LN_WITH_GLUE(clnt, dispatcher.set_max_threads(pool_name, n_threads));
}

int ln_thread_pool_setschedparam(ln_client clnt, const char* pool_name, int policy, int priority,
                                 unsigned int affinity_mask) {
  LN_WITH_GLUE(clnt, dispatcher.set_pool_schedparam(pool_name, policy, priority, affinity_mask));
}

#undef LN_WITH_GLUE

// ------------------------------------------------------------ introspection

int ln_get_service_signature(ln_client clnt, const char* service_interface, char** definition, char** signature) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(service_interface != nullptr, "service_interface");
    auto request = client->new_request(method::get_service_signature);
    request.set("interface", service_interface);
    const auto answer = client->request(std::move(request));
    if (definition != nullptr) *definition = malloc_copy(answer.get_string("definition"));
    if (signature != nullptr) *signature = malloc_copy(answer.get_string("signature"));
    return 0;
  });
}

int ln_get_service_signature_for_service(ln_client clnt, const char* service_name, char** service_interface,
                                         char** definition, char** signature) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(service_name != nullptr, "service_name");
    auto request = client->new_request(method::get_service_signature_for_service);
    request.set("name", client->service_mapping().apply(service_name));
    const auto answer = client->request(std::move(request));
    if (service_interface != nullptr) *service_interface = malloc_copy(answer.get_string("interface"));
    if (definition != nullptr) *definition = malloc_copy(answer.get_string("definition"));
    if (signature != nullptr) *signature = malloc_copy(answer.get_string("signature"));
    return 0;
  });
}

int ln_client_find_services_with_interface(ln_client clnt, const char* interface_name, char** services_out) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(interface_name != nullptr, "interface_name");
    require(services_out != nullptr, "services");
    auto request = client->new_request(method::find_services_with_interface);
    request.set("interface", interface_name);
    const auto answer = client->request(std::move(request));
    std::string joined;
    for (const auto& name : answer.get_list("services")) {
      if (!joined.empty()) joined += '\n';
      joined += name;
    }
    *services_out = malloc_copy(joined);
    return 0;
  });
}

int ln_register_as_service_logger(ln_client clnt, const char* logger_service_name,
                                  const char* service_name_patterns_to_log) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(logger_service_name != nullptr, "logger_service_name");
    require(service_name_patterns_to_log != nullptr, "service_name_patterns_to_log");
    ServicesGlue::of(*client)->logging().register_logger(client->service_mapping().apply(logger_service_name),
                                                         service_name_patterns_to_log);
    return 0;
  });
}

// ------------------------------------------------------ waiting, watching

int ln_wait_for_service(ln_client clnt, const char* service_name, double timeout) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(service_name != nullptr, "service_name");
    return ServicesGlue::of(*client)->wait_for_service(client->service_mapping().apply(service_name), timeout);
  });
}

int ln_needs_provider(ln_client clnt, const char* service_or_topic_name, double timeout) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(service_or_topic_name != nullptr, "service_or_topic_name");
    auto glue = ServicesGlue::of(*client);
    const std::string service = client->service_mapping().apply(service_or_topic_name);
    const std::string topic = client->topic_mapping().apply(service_or_topic_name);
    if (glue->wait_for_service(service, 0) == 1 || glue->topic_has_publisher(topic)) return 0;
    // The manager starts the process (or state) whose `provides` names it.
    std::string provider;
    try {
      auto request = client->new_request(method::needs_provider);
      request.set("name", service);
      provider = client->request(std::move(request)).get_string_or("provider", "");
    } catch (const Failure& e) {
      if (e.code() != LNE_MANAGER_TOO_OLD) throw;  // an older manager: only wait
    }
    if (timeout == 0) return 0;  // "only asks"
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::microseconds(static_cast<long long>(std::min(timeout, 1e9) * 1e6));
    auto next_check = std::chrono::steady_clock::now();
    for (;;) {
      if (glue->wait_for_service(service, 0) == 1 || glue->topic_has_publisher(topic)) return 0;
      if (!provider.empty() && std::chrono::steady_clock::now() >= next_check) {
        next_check = std::chrono::steady_clock::now() + std::chrono::milliseconds(250);
        if (const std::string failure = provider_failure(*client, provider); !failure.empty())
          throw Failure(LNE_START_PROVIDER_FAILED, "'" + provider + "', which provides '" +
                                                       std::string(service_or_topic_name) + "', failed: " + failure);
      }
      if (timeout > 0 && seconds_left(deadline) <= 0)
        throw Failure(LNE_NO_PROVIDER_FOUND,
                      "nothing provides '" + std::string(service_or_topic_name) + "' yet" +
                          (provider.empty() ? std::string() : " ('" + provider + "' was started for it)"));
      const double wait = timeout > 0 ? std::min(0.05, std::max(0.0, seconds_left(deadline))) : 0.05;
      if (glue->wait_for_service(service, wait) == 1) return 0;
    }
  });
}

int ln_set_service_availability_handler(ln_client clnt, const char* service_name, ln_availability_handler handler,
                                        void* user_data) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(service_name != nullptr, "service_name");
    ServicesGlue::of(*client)->set_availability_handler(false, client->service_mapping().apply(service_name),
                                                        reinterpret_cast<ServicesGlue::AvailabilityHandler>(handler),
                                                        user_data);
    return 0;
  });
}

int ln_set_publisher_availability_handler(ln_client clnt, const char* topic_name, ln_availability_handler handler,
                                          void* user_data) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(topic_name != nullptr, "topic_name");
    ServicesGlue::of(*client)->set_availability_handler(true, client->topic_mapping().apply(topic_name),
                                                        reinterpret_cast<ServicesGlue::AvailabilityHandler>(handler),
                                                        user_data);
    return 0;
  });
}

}  // extern "C"
