/// @file ln/cppwrapper_impl.h
/// @brief Inline definitions of the C++ API declared in ln/cppwrapper.h
///        (include that header, not this one).
#ifndef LN_CPPWRAPPER_IMPL_H
#define LN_CPPWRAPPER_IMPL_H

#include "cppwrapper.h"

namespace ln {
namespace detail {

/// The LN code behind a negative return value; LNE_UNKNOWN outside the table.
inline ln_error_t error_from_return(int ret) {
  const int code = ret < 0 ? -ret : ret;
  if (code >= LNE_CHECK_ERRNO && code <= LNE_WRONG_MD_HASH) return static_cast<ln_error_t>(code);
  return LNE_UNKNOWN;
}

/// Throws for a failed call: @p ret < 0 is an LN code, > 0 a service
/// provider's own error code. @p detail is extra text (may be empty/null).
[[noreturn]] inline void throw_failure(int ret, const std::string& context, const char* extra) {
  std::string message = context + ": ";
  ln_error_t error = LNE_UNKNOWN;
  int error_code = 0;
  if (ret > 0) {
    message += "service provider failed the call with error " + std::to_string(ret);
    error = LNE_USER_DEFINED_ERROR;
    error_code = ret;
  } else {
    message += ln_format_error(ret);
    if (ret < 0) error = error_from_return(ret);
  }
  if (extra != nullptr && extra[0] != '\0') {
    message += ": ";
    message += extra;
  }
  throw exception(message, error, error_code);
}

/// printf-style formatting for the LN 2.9 throw_error() family.
inline std::string vformat(const char* format, va_list args) LN_PRINTF_FORMAT(1, 0);
inline std::string vformat(const char* format, va_list args) {
  char buffer[1024];
  const int length = vsnprintf(buffer, sizeof buffer, format, args);
  if (length < 0) return format;
  return buffer;  // longer texts are cut; these are error messages
}

/// Runs a program's callback, keeping its exceptions out of the library.
template <typename Callback>
void run_guarded(ln_client clnt, const char* what, const Callback& callback) noexcept {
  try {
    callback();
  } catch (const std::exception& e) {
    ln_debug(clnt, "exception in %s dropped: %s", what, e.what());
  } catch (...) {
    ln_debug(clnt, "exception in %s dropped", what);
  }
}

/// Copies a malloc()ed C string into @p target and frees it (null: empty).
inline void take_c_string(char* source, std::string& target) {
  target = source != nullptr ? source : "";
  free(source);
}

/// Releases a result of the ln_list_* functions.
struct free_list {
  void operator()(void* list) const { ln_free_list(list); }
};

/// The names of a NULL-terminated array.
inline std::vector<std::string> string_list(const char* const* names) {
  std::vector<std::string> out;
  for (; names != nullptr && *names != nullptr; ++names) out.push_back(*names);
  return out;
}

/// Calls an ln_list_* function and converts its rows with @p convert.
template <typename Info, typename Row, typename Convert>
std::vector<Info> list_rows(ln_client clnt, int (*list)(ln_client, Row**, unsigned int*), const char* context,
                            Convert convert) {
  Row* rows = nullptr;
  unsigned int count = 0;
  const int ret = list(clnt, &rows, &count);
  if (ret < 0) throw_failure(ret, context, ln_get_error_message(clnt));
  const std::unique_ptr<Row, free_list> owned(rows);
  std::vector<Info> out;
  out.reserve(count);
  for (unsigned int i = 0; i < count; ++i) out.push_back(convert(rows[i]));
  return out;
}

}  // namespace detail

// ---------------------------------------------------------------- client

struct client::availability_slot {
  client* owner;
  availability_handler_t handler;
};

inline client::client(std::string client_name) : clnt(nullptr), owns_client_(true) {
  connect_with(ln_init(&clnt, client_name.c_str(), 0, nullptr));
}

inline client::client(const char* client_name) : client(std::string(client_name != nullptr ? client_name : "")) {}

inline client::client(std::string client_name, int argc, char* argv[]) : clnt(nullptr), owns_client_(true) {
  connect_with(ln_init(&clnt, client_name.c_str(), argc, argv));
}

inline client::client(std::string client_name, std::string ln_manager) : clnt(nullptr), owns_client_(true) {
  connect_with(ln_init_to_manager(&clnt, client_name.c_str(), ln_manager.c_str()));
}

inline client::client(ln_client existing) : clnt(existing), owns_client_(false) { connect_with(0); }

inline void client::connect_with(int ret) {
  if (ret != 0) {
    const ln_client failed = clnt;
    clnt = nullptr;
    detail::throw_failure(ret, "ln::client: connecting to the ln_manager", ln_get_error_message(failed));
  }
  char* granted = nullptr;
  if (ln_client_get_name(clnt, &granted) == 0 && granted != nullptr) name = granted;
}

inline client::~client() {
  // First, so that no handler runs into a half-destroyed client.
  for (auto& watch : service_watches_) ln_set_service_availability_handler(clnt, watch.first.c_str(), nullptr, nullptr);
  for (auto& watch : publisher_watches_)
    ln_set_publisher_availability_handler(clnt, watch.first.c_str(), nullptr, nullptr);
  for (auto& connection : event_connections_) delete connection.second;
  for (auto& named_logger : loggers_) delete named_logger.second;
  for (multi_waiter* waiter : multi_waiters_) delete waiter;
  for (outport* port : outports_) delete port;
  for (inport* port : inports_) delete port;
  std::list<service*> services;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    services.swap(services_);  // ~service() then finds nothing to unlink
  }
  for (service* svc : services) delete svc;
  if (owns_client_ && clnt != nullptr) ln_deinit(&clnt);
}

inline void client::throw_error(int ret, const std::string& message) {
  detail::throw_failure(ret, message, ln_get_error_message(clnt));
}

inline void client::throw_error(int ret, const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string message = detail::vformat(format, args);
  va_end(args);
  throw_error(ret, message);
}

inline void client::throw_error(const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string message = detail::vformat(format, args);
  va_end(args);
  throw exception(message);
}

inline void client::throw_retval_error(int retval, const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string message = detail::vformat(format, args);
  va_end(args);
  throw exception(message + ": " + strerror(retval), LNE_CHECK_ERROR_CODE, retval);
}

inline void client::throw_error_no_client(int ret, const char* format, ...) {
  va_list args;
  va_start(args, format);
  const std::string message = detail::vformat(format, args);
  va_end(args);
  detail::throw_failure(ret, message, nullptr);
}

inline std::vector<std::string> client::get_remaining_args() {
  unsigned int n_args = 0;
  char* block = nullptr;
  const int ret = ln_get_remaining_args(clnt, &n_args, &block);
  if (ret != 0) throw_error(ret, "ln::client::get_remaining_args");
  std::vector<std::string> args;
  for (unsigned int i = 0; i < n_args && block != nullptr; ++i) {
    args.emplace_back(block);
    block += args.back().size() + 1;
  }
  return args;
}

inline double client::ping(double timeout) {
  double rtt = 0;
  const int ret = ln_ping(clnt, timeout, &rtt);
  if (ret != 0) throw_error(ret, "ln::client::ping");
  return rtt;
}

inline std::string client::describe_message_definition(std::string message_definition_name) {
  char* text = nullptr;
  const int ret = ln_describe_message_definition(clnt, message_definition_name.c_str(), &text);
  if (ret != 0) throw_error(ret, "ln::client::describe_message_definition('" + message_definition_name + "')");
  std::string description;
  detail::take_c_string(text, description);
  return description;
}

inline void client::get_message_definition(std::string message_definition_name, std::string& message_definition,
                                           unsigned int& message_size, std::string& hash,
                                           std::string& flat_message_definition) {
  char* md = nullptr;
  char* md_hash = nullptr;
  char* flat = nullptr;
  const int ret =
      ln_get_message_definition_v21(clnt, message_definition_name.c_str(), &md, &message_size, &md_hash, &flat);
  if (ret != 0) throw_error(ret, "ln::client::get_message_definition('" + message_definition_name + "')");
  detail::take_c_string(md, message_definition);
  detail::take_c_string(md_hash, hash);
  detail::take_c_string(flat, flat_message_definition);
}

inline void client::get_message_definition(std::string message_definition_name, std::string& message_definition,
                                           unsigned int& message_size, std::string& hash) {
  std::string flat_message_definition;
  get_message_definition(std::move(message_definition_name), message_definition, message_size, hash,
                         flat_message_definition);
}

inline void client::get_message_definition(std::string message_definition_name, std::string& message_definition,
                                           unsigned int& message_size) {
  std::string hash;
  get_message_definition(std::move(message_definition_name), message_definition, message_size, hash);
}

inline void client::get_message_definition_for_topic(std::string topic_name, std::string& message_definition_name,
                                                     std::string& message_definition, unsigned int& message_size,
                                                     std::string& hash) {
  char* md_name = nullptr;
  char* md = nullptr;
  char* md_hash = nullptr;
  const int ret =
      ln_get_message_definition_for_topic_v17(clnt, topic_name.c_str(), &md_name, &md, &message_size, &md_hash);
  if (ret != 0) throw_error(ret, "ln::client::get_message_definition_for_topic('" + topic_name + "')");
  detail::take_c_string(md_name, message_definition_name);
  detail::take_c_string(md, message_definition);
  detail::take_c_string(md_hash, hash);
}

inline void client::get_message_definition_for_topic(std::string topic_name, std::string& message_definition_name,
                                                     std::string& message_definition, unsigned int& message_size) {
  std::string hash;
  get_message_definition_for_topic(std::move(topic_name), message_definition_name, message_definition, message_size,
                                   hash);
}

inline std::string client::put_message_definition(std::string message_definition_name, std::string message_definition) {
  char* stored_as = nullptr;
  const int ret =
      ln_put_message_definition(clnt, message_definition_name.c_str(), message_definition.c_str(), &stored_as);
  if (ret != 0) throw_error(ret, "ln::client::put_message_definition('" + message_definition_name + "')");
  std::string stored_name;
  detail::take_c_string(stored_as, stored_name);
  return stored_name;
}

inline void client::get_service_signature_for_service(std::string service_name, std::string& service_interface,
                                                      std::string& service_definition, std::string& service_signature) {
  char* iface = nullptr;
  char* definition = nullptr;
  char* signature = nullptr;
  const int ret = ln_get_service_signature_for_service(clnt, service_name.c_str(), &iface, &definition, &signature);
  if (ret != 0) throw_error(ret, "ln::client::get_service_signature_for_service('" + service_name + "')");
  detail::take_c_string(iface, service_interface);
  detail::take_c_string(definition, service_definition);
  detail::take_c_string(signature, service_signature);
}

inline void client::get_service_signature(std::string service_interface, std::string& service_definition,
                                          std::string& service_signature) {
  char* definition = nullptr;
  char* signature = nullptr;
  const int ret = ln_get_service_signature(clnt, service_interface.c_str(), &definition, &signature);
  if (ret != 0) throw_error(ret, "ln::client::get_service_signature('" + service_interface + "')");
  detail::take_c_string(definition, service_definition);
  detail::take_c_string(signature, service_signature);
}

inline void client::locate_member_in_message_definition(std::string message_definition_name, std::string member,
                                                        unsigned int& member_offset, unsigned int& member_byte_len) {
  const int ret = ln_locate_member_in_message_definition(clnt, message_definition_name.c_str(), member.c_str(),
                                                         &member_offset, &member_byte_len);
  if (ret != 0)
    throw_error(ret,
                "ln::client::locate_member_in_message_definition('" + message_definition_name + "', '" + member + "')");
}

inline outport* client::publish(std::string topic_name, std::string message_def_name, unsigned int buffers) {
  outport* port = new outport(this, topic_name, message_def_name, buffers);
  std::lock_guard<std::mutex> lock(mutex_);
  outports_.push_back(port);
  return port;
}

inline void client::unpublish(outport* port) {
  if (port == nullptr) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    outports_.remove(port);
  }
  delete port;
}

inline inport* client::subscribe(std::string topic_name, std::string message_def_name, double rate,
                                 unsigned int buffers, bool need_reliable_transport) {
  inport* port = new inport(this, topic_name, message_def_name, rate, buffers, need_reliable_transport);
  std::lock_guard<std::mutex> lock(mutex_);
  inports_.push_back(port);
  return port;
}

inline void client::unsubscribe(inport* port) {
  if (port == nullptr) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    inports_.remove(port);
  }
  delete port;
}

inline multi_waiter* client::get_multi_waiter() {
  multi_waiter* waiter = new multi_waiter(this);
  std::lock_guard<std::mutex> lock(mutex_);
  multi_waiters_.push_back(waiter);
  return waiter;
}

inline void client::wait_and_handle_service_group_requests(const char* group_name, double timeout) {
  const int ret = ln_wait_and_handle_service_group_requests(clnt, group_name, timeout);
  if (ret < 0) throw_error(ret, "ln::client::wait_and_handle_service_group_requests");
}

inline void client::handle_service_group_in_thread_pool(const char* group_name, std::string pool_name) {
  const int ret = ln_handle_service_group_in_thread_pool(clnt, group_name, pool_name.c_str());
  if (ret < 0) throw_error(ret, "ln::client::handle_service_group_in_thread_pool('" + pool_name + "')");
}

inline void client::remove_service_group_from_thread_pool(const char* group_name) {
  const int ret = ln_remove_service_group_from_thread_pool(clnt, group_name);
  if (ret < 0) throw_error(ret, "ln::client::remove_service_group_from_thread_pool");
}

inline void client::unblock_service_group(const char* group_name) {
  const int ret = ln_unblock_service_group(clnt, group_name);
  if (ret < 0) throw_error(ret, "ln::client::unblock_service_group");
}

inline void client::set_max_threads(std::string pool_name, unsigned int n_threads) {
  const int ret = ln_set_max_threads(clnt, pool_name.c_str(), n_threads);
  if (ret < 0) throw_error(ret, "ln::client::set_max_threads('" + pool_name + "')");
}

inline void client::thread_pool_setschedparam(std::string pool_name, int policy, int priority,
                                              unsigned int affinity_mask) {
  const int ret = ln_thread_pool_setschedparam(clnt, pool_name.c_str(), policy, priority, affinity_mask);
  if (ret < 0) throw_error(ret, "ln::client::thread_pool_setschedparam('" + pool_name + "')");
}

inline service* client::get_service(std::string service_name, std::string service_interface, std::string signature) {
  service* svc = new service(*this, service_name, service_interface, signature, false);
  std::lock_guard<std::mutex> lock(mutex_);
  services_.push_back(svc);
  return svc;
}

inline service* client::get_service_provider(std::string service_name, std::string service_interface,
                                             std::string signature) {
  service* svc = new service(*this, service_name, service_interface, signature, true);
  std::lock_guard<std::mutex> lock(mutex_);
  services_.push_back(svc);
  return svc;
}

inline void client::release_service(service* svc) { delete svc; }

inline void client::forget(service* svc) {
  std::lock_guard<std::mutex> lock(mutex_);
  services_.remove(svc);
}

inline void client::needs_provider(std::string service_or_topic_name, double timeout) {
  const int ret = ln_needs_provider(clnt, service_or_topic_name.c_str(), timeout);
  if (ret != 0) throw_error(ret, "ln::client::needs_provider('" + service_or_topic_name + "')");
}

inline logger* client::get_logger(std::string logger_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto found = loggers_.find(logger_name);
  if (found != loggers_.end()) return found->second;
  ln_logger handle = nullptr;
  const int ret = ln_client_get_logger(clnt, &handle, logger_name.c_str());
  if (ret != 0) throw_error(ret, "ln::client::get_logger('" + logger_name + "')");
  logger* created = new logger(this, logger_name, handle);
  loggers_[logger_name] = created;
  return created;
}

inline std::string client::find_services_with_interface(std::string interface_name) {
  char* found = nullptr;
  const int ret = ln_client_find_services_with_interface(clnt, interface_name.c_str(), &found);
  if (ret != 0) throw_error(ret, "ln::client::find_services_with_interface('" + interface_name + "')");
  std::string services;
  detail::take_c_string(found, services);
  return services;
}

inline event_connection* client::connect_to_event(std::string event_name, std::string event_connect_signature,
                                                  void* connect_data, event_connection::handler_t handler,
                                                  void* user_data) {
  event_connection* conn =
      new event_connection(this, event_name, event_connect_signature, connect_data, 0, handler, user_data, false);
  std::lock_guard<std::mutex> lock(mutex_);
  event_connections_[conn->id] = conn;
  return conn;
}

inline event_connection* client::connect_to_event_flat(std::string event_name, std::string event_connect_signature,
                                                       void* connect_data_flat, uint32_t connect_data_flat_len,
                                                       event_connection::handler_t handler, void* user_data) {
  event_connection* conn = new event_connection(this, event_name, event_connect_signature, connect_data_flat,
                                                connect_data_flat_len, handler, user_data, true);
  std::lock_guard<std::mutex> lock(mutex_);
  event_connections_[conn->id] = conn;
  return conn;
}

inline void client::disconnect_from_event(event_connection* conn) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto found = conn != nullptr ? event_connections_.find(conn->id) : event_connections_.end();
    if (found == event_connections_.end() || found->second != conn)
      throw exception("ln::client::disconnect_from_event: not a connection of this client", LNE_INVALID_PARAMETER);
    event_connections_.erase(found);
  }
  delete conn;
}

inline void client::set_thread_safe(bool enable) {
  const int ret = ln_client_set_thread_safe(clnt, enable ? 1 : 0);
  if (ret < 0) throw_error(ret, "ln::client::set_thread_safe");
}

inline void client::register_as_service_logger(std::string logger_service_name,
                                               std::string service_name_patterns_to_log) {
  const int ret =
      ln_register_as_service_logger(clnt, logger_service_name.c_str(), service_name_patterns_to_log.c_str());
  if (ret < 0) throw_error(ret, "ln::client::register_as_service_logger('" + logger_service_name + "')");
}

inline void client::set_float_parameter(std::string parameter_name, float value) {
  const int ret = ln_client_set_float_parameter(clnt, parameter_name.c_str(), value);
  if (ret != 0) throw_error(ret, "ln::client::set_float_parameter('" + parameter_name + "')");
}

inline bool client::wait_for_service(const std::string& service_name, double timeout) {
  const int ret = ln_wait_for_service(clnt, service_name.c_str(), timeout);
  if (ret < 0) throw_error(ret, "ln::client::wait_for_service('" + service_name + "')");
  return ret == 1;
}

inline void client::set_service_availability_handler(const std::string& service_name, availability_handler_t handler) {
  set_availability_handler(true, service_name, std::move(handler));
}

inline void client::set_publisher_availability_handler(const std::string& topic_name, availability_handler_t handler) {
  set_availability_handler(false, topic_name, std::move(handler));
}

inline std::vector<topic_info> client::list_topics() {
  return detail::list_rows<topic_info>(clnt, ln_list_topics, "ln::client::list_topics()", [](const ln_topic_info& row) {
    topic_info info;
    info.name = row.name;
    info.message_definition = row.message_definition;
    info.hash = row.hash;
    info.message_size = row.message_size;
    info.publisher = row.publisher;
    info.subscribers = row.subscribers;
    info.packets = row.packets;
    info.rate = row.rate;
    return info;
  });
}

inline std::vector<client_info> client::list_clients() {
  return detail::list_rows<client_info>(clnt, ln_list_clients, "ln::client::list_clients()",
                                        [](const ln_client_info& row) {
                                          client_info info;
                                          info.name = row.name;
                                          info.id = row.id;
                                          info.pid = row.pid;
                                          info.host = row.host;
                                          info.host_id = row.host_id;
                                          info.published = detail::string_list(row.published);
                                          info.subscribed = detail::string_list(row.subscribed);
                                          info.services = detail::string_list(row.services);
                                          return info;
                                        });
}

inline std::vector<service_info> client::list_services() {
  return detail::list_rows<service_info>(clnt, ln_list_services, "ln::client::list_services()",
                                         [](const ln_service_info& row) {
                                           service_info info;
                                           info.name = row.name;
                                           info.interface = row.interface;
                                           info.signature = row.signature;
                                           info.provider = row.provider;
                                           info.group = row.group;
                                           return info;
                                         });
}

inline manager_status client::get_manager_status() {
  ln_manager_status* status = nullptr;
  const int ret = ln_get_manager_status(clnt, &status);
  if (ret < 0) throw_error(ret, "ln::client::get_manager_status()");
  const std::unique_ptr<ln_manager_status, detail::free_list> owned(status);
  manager_status info;
  info.version = status->version;
  info.pid = status->pid;
  info.address = status->address;
  info.uptime = status->uptime;
  info.clients = status->clients;
  info.topics = status->topics;
  info.services = status->services;
  info.message_definition_dirs = detail::string_list(status->message_definition_dirs);
  return info;
}

inline void client::set_availability_handler(bool for_service, const std::string& watched_name,
                                             availability_handler_t handler) {
  std::unique_ptr<availability_slot> slot;
  if (handler) slot.reset(new availability_slot{this, std::move(handler)});
  const ln_availability_handler trampoline = slot ? &client::dispatch_availability : nullptr;
  const int ret = for_service
                      ? ln_set_service_availability_handler(clnt, watched_name.c_str(), trampoline, slot.get())
                      : ln_set_publisher_availability_handler(clnt, watched_name.c_str(), trampoline, slot.get());
  if (ret != 0)
    throw_error(ret, std::string("ln::client::set_") + (for_service ? "service" : "publisher") +
                         "_availability_handler('" + watched_name + "')");
  std::lock_guard<std::mutex> lock(mutex_);
  availability_slots& watches = for_service ? service_watches_ : publisher_watches_;
  std::unique_ptr<availability_slot>& current = watches[watched_name];
  if (current) retired_watches_.push_back(std::move(current));
  current = std::move(slot);
  if (!current) watches.erase(watched_name);
}

inline void client::dispatch_availability(ln_client c_client, const char* watched_name, int available, void* slot) {
  const availability_slot* watch = static_cast<const availability_slot*>(slot);
  detail::run_guarded(c_client, "availability handler",
                      [&] { watch->handler(watched_name != nullptr ? watched_name : "", available != 0); });
}

// ---------------------------------------------------------------- ports

inline outport::outport(client* owner, const std::string& topic, const std::string& md_name, unsigned int buffers)
    : port_base(owner), port(nullptr) {
  const int ret = ln_publish_with_buffers(owner->clnt, topic.c_str(), md_name.c_str(), buffers, &port);
  if (ret != 0) owner->throw_error(ret, "ln::client::publish('" + topic + "')");
  topic_name = topic;
  topic_md = md_name;
  const int size = ln_get_message_size(port);
  message_size = size > 0 ? static_cast<unsigned int>(size) : 0;
  const char* hash = ln_get_msg_def_hash(port);
  msg_def_hash = hash != nullptr ? hash : "";
}

inline outport::~outport() { ln_unpublish(&port); }

inline void outport::write(void* data) {
  const int ret = ln_write(port, data, message_size, nullptr);
  if (ret != 0) clnt->throw_error(ret, "ln::outport('" + topic_name + "')::write");
}

inline void outport::write(void* data, double timestamp) {
  const int ret = ln_write(port, data, message_size, &timestamp);
  if (ret != 0) clnt->throw_error(ret, "ln::outport('" + topic_name + "')::write");
}

inline void* outport::get_next_buffer(unsigned int* buffer_len) {
  void* buffer = nullptr;
  const int ret = ln_outport_get_next_buffer(port, &buffer, buffer_len);
  if (ret != 0) clnt->throw_error(ret, "ln::outport('" + topic_name + "')::get_next_buffer");
  return buffer;
}

inline unsigned int outport::has_subscriber() {
  const int ret = ln_has_subscriber(port);
  return ret > 0 ? static_cast<unsigned int>(ret) : 0;
}

inline inport::inport(client* owner, const std::string& topic, const std::string& md_name, double rate,
                      unsigned int buffers, bool need_reliable_transport)
    : port_base(owner), port(nullptr), timestamp(0) {
  const int ret = ln_subscribe_with_buffers(owner->clnt, topic.c_str(), md_name.c_str(), &port, rate,
                                            need_reliable_transport ? 1 : 0, buffers);
  if (ret != 0) owner->throw_error(ret, "ln::client::subscribe('" + topic + "')");
  topic_name = topic;
  topic_md = md_name;
  const int size = ln_get_message_size(port);
  message_size = size > 0 ? static_cast<unsigned int>(size) : 0;
  const char* hash = ln_get_msg_def_hash(port);
  msg_def_hash = hash != nullptr ? hash : "";
}

inline inport::~inport() { ln_unsubscribe(&port); }

inline bool inport::read(void* data, bool blocking) {
  const int ret = ln_read(port, data, message_size, &timestamp, blocking ? 1 : 0);
  if (ret < 0) clnt->throw_error(ret, "ln::inport('" + topic_name + "')::read");
  return ret == 1;
}

inline bool inport::read(void* data, double timeout) {
  const int ret = ln_read_timeout(port, data, message_size, &timestamp, timeout);
  if (ret < 0) clnt->throw_error(ret, "ln::inport('" + topic_name + "')::read");
  return ret == 1;
}

inline bool inport::read(void* data, double timeout, sample_info* info) {
  sample_info received{};
  const int ret = ln_read_with_info(port, data, message_size, &received, timeout);
  if (ret < 0) clnt->throw_error(ret, "ln::inport('" + topic_name + "')::read");
  if (ret != 1) return false;
  timestamp = received.timestamp;
  if (info != nullptr) *info = received;
  return true;
}

inline borrowed_sample inport::borrow(double timeout) {
  const void* packet = nullptr;
  unsigned int size = 0;
  sample_info received{};
  const int ret = ln_read_borrow(port, &packet, &size, &received, timeout);
  if (ret < 0) clnt->throw_error(ret, "ln::inport('" + topic_name + "')::borrow");
  if (ret != 1) return borrowed_sample();
  timestamp = received.timestamp;
  return borrowed_sample(this, packet, size, received);
}

inline bool inport::has_publisher() { return ln_has_publisher(port) > 0; }

inline void inport::unblock() {
  const int ret = ln_unblock(port);
  if (ret != 0) clnt->throw_error(ret, "ln::inport('" + topic_name + "')::unblock");
}

inline borrowed_sample::borrowed_sample(borrowed_sample&& other) noexcept
    : port_(other.port_), data_(other.data_), size_(other.size_), info_(other.info_) {
  other.port_ = nullptr;
  other.data_ = nullptr;
  other.size_ = 0;
}

inline borrowed_sample& borrowed_sample::operator=(borrowed_sample&& other) noexcept {
  if (this != &other) {
    release();
    port_ = other.port_;
    data_ = other.data_;
    size_ = other.size_;
    info_ = other.info_;
    other.port_ = nullptr;
    other.data_ = nullptr;
    other.size_ = 0;
  }
  return *this;
}

inline void borrowed_sample::release() noexcept {
  // The only failure is "nothing lent", which cannot happen while data_ is set.
  if (data_ != nullptr) ln_read_release(port_->port);
  port_ = nullptr;
  data_ = nullptr;
  size_ = 0;
}

// ---------------------------------------------------------------- multi_waiter

inline multi_waiter::multi_waiter(client* owner) : clnt(owner), waiter(nullptr) {
  const int ret = ln_multi_waiter_init(owner->clnt, &waiter);
  if (ret < 0) owner->throw_error(ret, "ln::client::get_multi_waiter");
}

inline multi_waiter::~multi_waiter() { ln_multi_waiter_deinit(&waiter); }

inline void multi_waiter::add_port(inport* port) {
  const int ret = ln_multi_waiter_add_port(waiter, port->port);
  if (ret < 0) clnt->throw_error(ret, "ln::multi_waiter::add_port('" + port->topic_name + "')");
}

inline void multi_waiter::remove_port(inport* port) {
  const int ret = ln_multi_waiter_remove_port(waiter, port->port);
  if (ret < 0) clnt->throw_error(ret, "ln::multi_waiter::remove_port('" + port->topic_name + "')");
}

inline bool multi_waiter::wait(double timeout) {
  const int ret = ln_multi_waiter_wait(waiter, timeout);
  if (ret < 0) clnt->throw_error(ret, "ln::multi_waiter::wait");
  return ret > 0;
}

inline bool multi_waiter::can_read(inport* port) { return ln_multi_waiter_can_read(waiter, port->port) > 0; }

inline int multi_waiter::start_pipe_notifier_thread(ln_pipe_fd_t* fd) {
  const int ret = ln_multi_waiter_start_pipe_notifier_thread(waiter, fd);
  if (ret < 0) clnt->throw_error(ret, "ln::multi_waiter::start_pipe_notifier_thread");
  return ret;
}

inline int multi_waiter::ack_pipe_notification() {
  const int ret = ln_multi_waiter_ack_pipe_notification(waiter);
  if (ret < 0) clnt->throw_error(ret, "ln::multi_waiter::ack_pipe_notification");
  return ret;
}

// ---------------------------------------------------------------- service_request

inline void service_request::fail(int ret, const std::string& context) const {
  svc->fail(ret, "ln::service_request('" + svc->name_ + "')::" + context);
}

inline void service_request::set_data(void* data, const char* signature) {
  const int ret = ln_service_request_set_data(req_, data, signature);
  if (ret != 0)
    fail(ret, std::string("set_data(signature '") + (signature != nullptr ? signature : "") + "', service signature '" +
                  svc->signature_ + "')");
}

inline void service_request::get_request_data(char** buffer, uint64_t* buffer_len) {
  const int ret = ln_service_request_get_request_data(req_, buffer, buffer_len);
  if (ret != 0) fail(ret, "get_request_data");
}

inline int service_request::respond() {
  const int ret = ln_service_request_respond(req_);
  if (ret != 0) fail(ret, "respond");
  return ret;
}

inline int service_request::respondv(struct iovec* iov, unsigned int iov_len) {
  const int ret = ln_service_request_respondv(req_, iov, iov_len);
  if (ret != 0) fail(ret, "respondv");
  return ret;
}

inline int service_request::respond_data(void* data) {
  const int ret = ln_service_request_respond_data(req_, data);
  if (ret != 0) fail(ret, "respond_data");
  return ret;
}

inline void service_request::respond_error(int error, const std::string& message) {
  const int ret = ln_service_request_respond_error(req_, error, message.c_str());
  if (ret != 0) fail(ret, "respond_error");
}

inline bool service_request::is_aborted() {
  const int ret = ln_service_request_is_aborted(req_);
  if (ret < 0) fail(ret, "is_aborted");
  return ret > 0;
}

inline bool service_request::check_finished(int ret, int retval, const char* context) {
  if (ret < 0) fail(ret, context);
  if (ret == 0) return false;
  if (retval != 0)
    detail::throw_failure(retval, "ln::service_request('" + svc->name_ + "')::" + context,
                          ln_service_request_get_error_message(req_));
  return true;
}

inline bool service_request::finished() {
  if (!is_async_) fail(-LNE_SVC_REQ_NOT_RUNNING, "finished: not an asynchronous call");
  int retval = 0;
  const int ret = ln_service_request_finished(req_, &retval);
  return check_finished(ret, retval, "finished");
}

inline bool service_request::wait(double timeout) {
  if (!is_async_) fail(-LNE_SVC_REQ_NOT_RUNNING, "wait: not an asynchronous call");
  int retval = 0;
  const int ret = ln_service_request_wait(req_, timeout, &retval);
  return check_finished(ret, retval, "wait");
}

inline void service_request::abort() {
  if (!is_async_) fail(-LNE_SVC_REQ_NOT_RUNNING, "abort: not an asynchronous call");
  const int ret = ln_service_request_abort(req_);
  if (ret != 0) fail(ret, "abort");
}

inline int service_request::get_finished_notification_fd() {
  int fd = -1;
  const int ret = ln_service_request_get_finished_notification_fd(req_, &fd);
  if (ret != 0) fail(ret, "get_finished_notification_fd");
  return fd;
}

// ---------------------------------------------------------------- service_future

inline service_future::service_future(service_future&& other) noexcept : svc_(other.svc_), req_(other.req_) {
  other.svc_ = nullptr;
  other.req_ = nullptr;
}

inline service_future& service_future::operator=(service_future&& other) noexcept {
  if (this != &other) {
    if (valid()) ln_service_request_abort(req_);
    svc_ = other.svc_;
    req_ = other.req_;
    other.svc_ = nullptr;
    other.req_ = nullptr;
  }
  return *this;
}

inline service_future::~service_future() {
  // Aborting a finished call is harmless; a running one must not write into
  // data that may be gone once the future is.
  if (valid()) ln_service_request_abort(req_);
}

inline bool service_future::wait_for(double timeout) {
  if (!valid()) throw exception("ln::service_future::wait_for: no call", LNE_SVC_REQ_NOT_RUNNING);
  int retval = 0;
  const int ret = ln_service_request_wait(req_, timeout, &retval);
  if (ret < 0) svc_->fail(ret, "ln::service('" + svc_->name_ + "')::call_future: wait");
  return ret == 1;
}

inline void service_future::get() {
  if (!valid()) throw exception("ln::service_future::get: no call", LNE_SVC_REQ_NOT_RUNNING);
  int retval = 0;
  const int ret = ln_service_request_wait(req_, -1, &retval);
  service* const owner = svc_;
  const ln_service_request finished_call = req_;
  svc_ = nullptr;
  req_ = nullptr;
  const std::string context = "ln::service('" + owner->name_ + "')::call_future";
  if (ret < 0) owner->fail(ret, context);
  if (retval != 0) detail::throw_failure(retval, context, ln_service_request_get_error_message(finished_call));
}

inline void service_future::abort() {
  if (!valid()) return;
  const int ret = ln_service_request_abort(req_);
  service* const owner = svc_;
  svc_ = nullptr;
  req_ = nullptr;
  if (ret != 0) owner->fail(ret, "ln::service('" + owner->name_ + "')::call_future: abort");
}

// ---------------------------------------------------------------- service

inline service::service(client& owner, const std::string& service_name, const std::string& service_interface,
                        const std::string& signature, bool is_provider)
    : clnt(&owner),
      svc(nullptr),
      name_(service_name),
      interface_(service_interface),
      signature_(signature),
      is_provider_(is_provider) {
  const int ret = ln_service_init(owner.clnt, &svc, service_name.c_str(), service_interface.c_str(), signature.c_str());
  if (ret != 0)
    owner.throw_error(ret, std::string("ln::client::") + (is_provider ? "get_service_provider" : "get_service") + "('" +
                               service_name + "')");
}

inline service::~service() {
  clnt->forget(this);
  ln_service_deinit(&svc);  // also aborts a running asynchronous call
}

inline void service::fail(int ret, const std::string& context) const { clnt->throw_error(ret, context); }

inline void service::require_provider(const char* operation) const {
  if (!is_provider_)
    fail(-LNE_SVC_IS_CLIENT, "ln::service('" + name_ + "')::" + operation +
                                 ": handle is for calling; use ln::client::get_service_provider()");
}

inline void service::set_handler(handler_t handler, void* user_data) {
  require_provider("set_handler");
  handler_ = handler;
  handler_data_ = user_data;
}

inline void service::do_register(const char* group_name) {
  require_provider("do_register");
  if (handler_ == nullptr) fail(-LNE_SVC_NO_HANDLER, "ln::service('" + name_ + "')::do_register: set_handler() first");
  int ret = ln_service_provider_set_handler(svc, &service::dispatch_request, this);
  if (ret == 0) ret = ln_service_provider_register_in_group(clnt->clnt, svc, group_name);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::do_register");
}

inline int service::get_fd() {
  const int ret = ln_service_provider_get_fd(svc);
  if (ret < 0) fail(ret, "ln::service('" + name_ + "')::get_fd");
  return ret;
}

inline void service::set_client_fd_handler(fd_handler_t handler, void* user_data) {
  require_provider("set_client_fd_handler");
  fd_handler_ = handler;
  fd_handler_data_ = user_data;
  const int ret = ln_service_provider_set_client_fd_handler(svc, &service::dispatch_fd_event, this);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::set_client_fd_handler");
}

inline int service::dispatch_request(ln_client, ln_service_request request, void* self) {
  service* const provider = static_cast<service*>(self);
  service_request req(provider, request, false);
  std::string failure;
  try {
    return provider->handler_(*provider->clnt, req, provider->handler_data_);
  } catch (const std::exception& e) {
    failure = e.what();
  } catch (...) {
    failure = "unknown exception";
  }
  // Tell the caller why; if that fails too (e.g. the handler had already
  // responded), at least the code reaches it.
  const std::string message = "handler of service '" + provider->name_ + "' threw: " + failure;
  return ln_service_request_respond_error(request, -LNE_SVC_HANDLER_EXC, message.c_str()) == 0 ? 0
                                                                                               : -LNE_SVC_HANDLER_EXC;
}

inline void service::dispatch_fd_event(ln_client c_client, ln_svc_client_event_t event, int fd, void* self) {
  service* const provider = static_cast<service*>(self);
  if (provider->fd_handler_ == nullptr) return;
  detail::run_guarded(c_client, "service client fd handler",
                      [&] { provider->fd_handler_(*provider->clnt, event, fd, provider->fd_handler_data_); });
}

inline void service::call(void* data, double timeout) {
  const int ret = ln_service_call_with_timeout(svc, data, timeout);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::call");
}

inline void service::callv(struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens, char** response_buffer,
                           uint32_t* response_len, uint8_t* need_swap, double timeout) {
  const int ret = ln_service_callv_with_timeout(svc, iov, iov_len, iov_element_lens, response_buffer, response_len,
                                                need_swap, timeout);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::callv");
}

inline void service::abort() {
  const int ret = ln_service_call_abort(svc);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::abort");
}

inline service_request* service::track_async(ln_service_request request) {
  if (async_request_)
    async_request_->req_ = request;
  else
    async_request_.reset(new service_request(this, request, true));
  return async_request_.get();
}

inline service_request* service::call_async(void* data) {
  ln_service_request request = nullptr;
  const int ret = ln_service_call_async(svc, data, &request);
  if (ret < 0) fail(ret, "ln::service('" + name_ + "')::call_async");
  return track_async(request);
}

inline service_request* service::callv_async(struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens) {
  ln_service_request request = nullptr;
  const int ret = ln_service_callv_async(svc, iov, iov_len, iov_element_lens, &request);
  if (ret < 0) fail(ret, "ln::service('" + name_ + "')::callv_async");
  return track_async(request);
}

inline void service::callv_async_get_response(char** response_buffer, uint32_t* response_len) {
  const int ret = ln_service_callv_async_get_response(svc, response_buffer, response_len);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::callv_async_get_response");
}

inline void service::callv_async_get_response_data(void* data) {
  const int ret = ln_service_callv_async_get_response_data(svc, data);
  if (ret != 0) fail(ret, "ln::service('" + name_ + "')::callv_async_get_response_data");
}

inline service_future service::call_future(void* data) {
  ln_service_request request = nullptr;
  const int ret = ln_service_call_async(svc, data, &request);
  if (ret < 0) fail(ret, "ln::service('" + name_ + "')::call_future");
  return service_future(this, request);
}

// ---------------------------------------------------------------- events

inline event_call::event_call(event_connection* arrived_on, ln_event_call& handle)
    : connection(arrived_on), call(handle) {}

inline void event_call::set_data(void* host_ptr, const char* call_signature) {
  const int ret = ln_event_call_set_data(call, call_signature, host_ptr);
  if (ret != 0) connection->clnt->throw_error(ret, "ln::event_call('" + connection->event_name + "')::set_data");
}

inline void* event_call::get_buffer(uint32_t* len) {
  void* buffer = nullptr;
  const int ret = ln_event_call_get_buffer(call, &buffer, len);
  if (ret != 0) connection->clnt->throw_error(ret, "ln::event_call('" + connection->event_name + "')::get_buffer");
  return buffer;
}

inline event_connection::event_connection(client* owner, const std::string& name, const std::string& connect_signature,
                                          void* connect_data, uint32_t connect_data_len, handler_t handler,
                                          void* user_data, bool is_flat)
    : clnt(owner), event_name(name), conn(nullptr), id(0), handler_(handler), user_data_(user_data) {
  const int ret = is_flat ? ln_event_connect_flat(owner->clnt, &conn, name.c_str(), connect_signature.c_str(),
                                                  connect_data, connect_data_len, &event_connection::dispatch, this)
                          : ln_event_connect(owner->clnt, &conn, name.c_str(), connect_signature.c_str(), connect_data,
                                             &event_connection::dispatch, this);
  if (ret != 0) owner->throw_error(ret, "ln::client::connect_to_event('" + name + "')");
  id = ln_event_connection_get_id(conn);
}

inline event_connection::~event_connection() { ln_event_connection_deinit(&conn); }

inline void event_connection::dispatch(ln_client c_client, ln_event_call call, void* self) {
  event_connection* const connection = static_cast<event_connection*>(self);
  detail::run_guarded(c_client, "event handler", [&] {
    event_call delivered(connection, call);
    connection->handler_(delivered, connection->user_data_);
  });
}

// ---------------------------------------------------------------- string_buffer

inline string_buffer::string_buffer(char** target_ptr, const std::stringstream& src) { assign(target_ptr, src.str()); }

inline string_buffer::string_buffer(char** target_ptr, const std::string& src) { assign(target_ptr, src); }

inline void string_buffer::assign(char** target_ptr, const std::string& src) {
  length_ = static_cast<uint32_t>(src.size());
  storage_.reset(new char[src.size() + 1]);
  memcpy(storage_.get(), src.c_str(), src.size() + 1);
  // Fields of generated structs are packed, hence possibly misaligned:
  // store through memcpy. The `_len` field sits right before the pointer.
  char* const characters = storage_.get();
  memcpy(target_ptr, &characters, sizeof characters);
  memcpy(reinterpret_cast<char*>(target_ptr) - sizeof length_, &length_, sizeof length_);
}

inline string_buffer::operator std::string() const { return std::string(storage_.get(), length_); }

inline const char* string_buffer::c_str() const { return storage_.get(); }

// ---------------------------------------------------------------- logger

inline logger::logger(client* owner, const std::string& logger_name, ln_logger handle)
    : clnt(owner), _logger(handle), name(logger_name), data(nullptr) {}

inline logger::~logger() { delete data; }

inline void logger::add_topic(std::string topic_name, uint64_t log_size, unsigned int divisor) {
  const int ret = ln_logger_add_topic64(_logger, topic_name.c_str(), log_size, divisor);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::add_topic('" + topic_name + "')");
}

inline void logger::clear_topics() {
  const int ret = ln_logger_clear_topics(_logger);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::clear_topics");
}

inline void logger::enable() {
  const int ret = ln_logger_enable(_logger);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::enable");
}

inline void logger::disable() {
  const int ret = ln_logger_disable(_logger);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::disable");
}

inline logger_data* logger::download() {
  ln_logger_data contents = nullptr;
  const int ret = ln_logger_download(_logger, &contents);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::download");
  if (data == nullptr)
    data = new logger_data(this, contents, false);
  else
    data->set_data(contents, false);
  return data;
}

inline logger_data* logger::direct_download() {
  ln_logger_data contents = nullptr;
  const int ret = ln_logger_direct_download(_logger, &contents);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::direct_download");
  if (data == nullptr)
    data = new logger_data(this, contents, false);
  else
    data->set_data(contents, false);
  return data;
}

inline void logger::manager_save(std::string filename, std::string format) {
  const int ret = ln_logger_manager_save(_logger, filename.c_str(), format.c_str());
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::manager_save('" + filename + "')");
}

inline void logger::set_only_ts(bool only_ts) {
  const int ret = ln_logger_set_only_ts(_logger, only_ts ? 1 : 0);
  if (ret != 0) clnt->throw_error(ret, "ln::logger('" + name + "')::set_only_ts");
}

inline logger_data::topic_cursor::topic_cursor(logger_topic* recorded)
    : name(recorded->name != nullptr ? recorded->name : ""), topic(recorded) {}

inline logger_sample* logger_data::topic_cursor::get_sample(unsigned int i) {
  return reinterpret_cast<logger_sample*>(reinterpret_cast<uint8_t*>(topic->samples) +
                                          static_cast<size_t>(topic->sample_size) * i);
}

inline logger_data::logger_data(logger* owner, ln_logger_data contents, bool own_data)
    : _logger(owner), data(nullptr), own_data_(false) {
  set_data(contents, own_data);
}

inline logger_data::~logger_data() {
  clear_topics();
  if (own_data_ && data != nullptr) ln_logger_data_deinit(&data);
}

inline void logger_data::clear_topics() {
  for (topic_cursor* cursor : topics) delete cursor;
  topics.clear();
}

inline void logger_data::set_data(ln_logger_data contents, bool own_data) {
  clear_topics();
  data = contents;
  own_data_ = own_data;
  unsigned int n_topics = 0;
  if (ln_logger_data_get_info(data, &n_topics) != 0) return;
  for (unsigned int i = 0; i < n_topics; ++i) {
    logger_topic* recorded = nullptr;
    if (ln_logger_data_get_topic(data, i, &recorded) == 0 && recorded != nullptr)
      topics.push_back(new topic_cursor(recorded));
  }
}

// Logger data calls have no client: their detail is ln_get_error_message(NULL).
inline void logger_data::save(std::string filename) {
  const int ret = ln_logger_data_save(data, filename.c_str());
  if (ret != 0) detail::throw_failure(ret, "ln::logger_data::save('" + filename + "')", ln_get_error_message(nullptr));
}

inline logger_data* logger_data::load(std::string filename) {
  ln_logger_data contents = nullptr;
  const int ret = ln_logger_data_load(&contents, filename.c_str());
  if (ret != 0) detail::throw_failure(ret, "ln::logger_data::load('" + filename + "')", ln_get_error_message(nullptr));
  return new logger_data(nullptr, contents, true);
}

// ---------------------------------------------------------------- DSA helpers

namespace detail {
[[noreturn]] inline void throw_dsa_failure(const char* function, int ret) {
  throw std::runtime_error(std::string(function) + " returned " + std::to_string(ret) + ": " + ln_format_error(ret));
}

inline bool verify_dsa_signature(int ret, const char* function) {
  if (ret == 0) return true;
  // ln_dsa_dss1_verify_*() answer -LNE_INVALID_DSA_SIGNATURE (LN 2.9's
  // wrapper expects -LNE_INVALID_SIGNATURE and so throws for a wrong one).
  if (ret == -LNE_INVALID_DSA_SIGNATURE || ret == -LNE_INVALID_SIGNATURE) return false;
  throw_dsa_failure(function, ret);
}

inline const uint8_t* bytes_of(const std::string& text) { return reinterpret_cast<const uint8_t*>(text.data()); }
}  // namespace detail

inline std::string dsa_dss1_sign_message(const std::string& pem_private_key_filename, const std::string& message) {
  uint8_t* signature = nullptr;
  unsigned int signature_len = 0;
  const int ret = ln_dsa_dss1_sign_message(pem_private_key_filename.c_str(), detail::bytes_of(message),
                                           static_cast<unsigned int>(message.size()), &signature, &signature_len);
  if (ret < 0) detail::throw_dsa_failure("ln_dsa_dss1_sign_message", ret);
  std::string result(reinterpret_cast<const char*>(signature), signature_len);
  free(signature);
  return result;
}

inline bool dsa_dss1_verify_message_signature(const std::string& openssh_public_key_filename,
                                              const std::string& message, const std::string& signature) {
  return detail::verify_dsa_signature(
      ln_dsa_dss1_verify_message_signature(openssh_public_key_filename.c_str(), detail::bytes_of(message),
                                           static_cast<unsigned int>(message.size()), detail::bytes_of(signature),
                                           static_cast<unsigned int>(signature.size())),
      "ln_dsa_dss1_verify_message_signature");
}

inline bool dsa_dss1_verify_message_signature_memkey(const std::string& openssh_public_key_contents,
                                                     const std::string& message, const std::string& signature) {
  return detail::verify_dsa_signature(
      ln_dsa_dss1_verify_message_signature_memkey(
          openssh_public_key_contents.c_str(), detail::bytes_of(message), static_cast<unsigned int>(message.size()),
          detail::bytes_of(signature), static_cast<unsigned int>(signature.size())),
      "ln_dsa_dss1_verify_message_signature_memkey");
}

inline void dsa_dss1_generate_key_pair(const std::string& pem_private_key_filename,
                                       const std::string& openssh_public_key_filename) {
  const int ret = ln_dsa_dss1_generate_key_pair(pem_private_key_filename.c_str(), openssh_public_key_filename.c_str());
  if (ret < 0) detail::throw_dsa_failure("ln_dsa_dss1_generate_key_pair", ret);
}

}  // namespace ln

#undef LN_PRINTF_FORMAT

#endif  // LN_CPPWRAPPER_IMPL_H
