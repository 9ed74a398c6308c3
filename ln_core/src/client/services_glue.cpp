#include "client/services_glue.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <set>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "protocol/methods.hpp"
#include "protocol/wire.hpp"

namespace ln::clientlib {

namespace method = protocol::method;
using protocol::Message;
using services::Status;
using Clock = std::chrono::steady_clock;

namespace {

constexpr std::chrono::milliseconds kHandshakeTimeout{5000};

services::Limits limits_from_environment() {
  services::Limits limits;
  if (const char* text = std::getenv("LN_SERVICE_MAX_DATA_SIZE")) {
    char* end = nullptr;
    const unsigned long long value = std::strtoull(text, &end, 10);
    if (end != text && value > 0) limits.max_data_size = static_cast<std::size_t>(value);
  }
  if (const char* text = std::getenv("LN_SERVICE_RESPONSE_TIMEOUT_MS")) {
    char* end = nullptr;
    const unsigned long value = std::strtoul(text, &end, 10);
    if (end != text && value > 0) limits.response_timeout_ms = static_cast<unsigned>(std::min(value, 3600000UL));
  }
  if (const char* text = std::getenv("LN_SERVICE_MAX_UNREAD_RESPONSES")) {
    char* end = nullptr;
    const unsigned long long value = std::strtoull(text, &end, 10);
    if (end != text && value > 0) limits.max_unread_responses = static_cast<std::size_t>(value);
  }
  return limits;
}

services::WaitPolicy wait_from_environment() {
  services::WaitPolicy wait;
  if (const char* text = std::getenv("LN_SERVICE_SPIN_US")) {
    char* end = nullptr;
    const unsigned long value = std::strtoul(text, &end, 10);
    if (end != text) wait.spin_us = static_cast<unsigned>(std::min(value, 1000000UL));
  }
  return wait;
}

bool set_blocking(int fd) {
  const int flags = ::fcntl(fd, F_GETFL);
  return flags >= 0 && ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) == 0;
}

// Reads exactly one message (the handshake's answer) from `fd`.
Status read_answer(int fd, Message& out) {
  protocol::FrameReader reader;
  const auto deadline = Clock::now() + kHandshakeTimeout;
  for (;;) {
    if (auto message = reader.next()) {
      if (reader.buffered() != 0)
        return Status::failure(LNE_GOT_INVALID_RESPONSE, "the provider sent data before the first request");
      out = std::move(*message);
      return {};
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return Status::failure(LNE_SVC_TIMEOUT, "the provider did not answer the call handshake");
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(left.count()) + 1);
    if (ready < 0 && errno != EINTR) return Status::failure(LNE_CHECK_ERRNO, std::strerror(errno), errno);
    if (ready <= 0) continue;
    // Read only the frame's size prefix and body: the provider sends
    // nothing more before our first request anyway.
    char buffer[4096];
    const ssize_t got = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
    if (got == 0) return Status::failure(LNE_SVC_RECV_RESP, "the provider closed the connection during the handshake");
    if (got < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return Status::failure(LNE_CHECK_ERRNO, std::string("handshake: ") + std::strerror(errno), errno);
    }
    reader.append(buffer, static_cast<std::size_t>(got));
  }
}

}  // namespace

Status ServicesGlue::connect_to_provider(const Message& found, UniqueFd& socket) {
  const std::string provider = found.get_string_or("provider", "");
  const std::string socket_name = found.get_string_or("peer_socket", "");
  const std::string address = found.get_string_or("peer_address", "");
  std::string unix_error;
  if (found.get_string_or("host_id", "") == client_.host_id() && !socket_name.empty()) {
    try {
      socket = connect_abstract_unix(socket_name);
      return {};
    } catch (const Failure& failure) {
      unix_error = failure.what();
    }
  }
  if (address.empty())
    return Status::failure(LNE_NO_PROVIDER_FOUND,
                           "cannot reach its provider '" + provider + "': " +
                               (unix_error.empty() ? "it runs on another host and offers no TCP address" : unix_error));
  try {
    socket = connect_peer_tcp(address, kHandshakeTimeout);
    return {};
  } catch (const Failure& failure) {
    return Status::failure(LNE_NO_PROVIDER_FOUND,
                           "cannot reach its provider '" + provider + "' at " + address + ": " + failure.what());
  }
}

std::shared_ptr<ServicesGlue> ServicesGlue::of(Client& client) {
  bool made = false;
  auto state = client.services_state([&] {
    made = true;
    return std::static_pointer_cast<void>(std::make_shared<ServicesGlue>(client));
  });
  auto glue = std::static_pointer_cast<ServicesGlue>(state);
  if (made) glue->install_hooks();
  return glue;
}

ServicesGlue::ServicesGlue(Client& client)
    : client_(client),
      limits_(limits_from_environment()),
      wait_(wait_from_environment()),
      dispatcher_(static_cast<void*>(&client), limits_, wait_),
      reactor_(std::make_shared<services::AsyncReactor>()),
      logging_(std::make_shared<ServiceLogging>(client, *this)) {
  dispatcher_.set_call_log(logging_);
}

ServicesGlue::~ServicesGlue() {
  logging_->stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  events_changed_.notify_all();
  if (notifier_.joinable()) notifier_.join();
}

void ServicesGlue::install_hooks() {
  std::weak_ptr<ServicesGlue> weak = weak_from_this();
  // The peer server and the handlers run in the loop thread; posting keeps
  // add_method() there too.
  auto add_call = [this, weak] {
    client_.peer_server().add_method("call", [weak](PeerRequest& request) {
      if (auto glue = weak.lock())
        glue->on_call(request);
      else
        request.fail(LNE_SVC_NOT_REGISTERED, "this client provides no services");
    });
  };
  if (client_.loop().in_loop_thread())
    add_call();
  else
    client_.loop().post(add_call);
  const std::pair<std::string_view, bool> availability[] = {
      {method::service_available, true},
      {method::service_gone, false},
      {method::topic_publisher_available, true},
      {method::topic_publisher_gone, false},
  };
  for (const auto& [notification, up] : availability) {
    const bool topic =
        notification == method::topic_publisher_available || notification == method::topic_publisher_gone;
    client_.add_notification_handler(std::string(notification), [weak, topic, up = up](const Message& message) {
      if (auto glue = weak.lock()) glue->on_availability_notification(topic, message.get_string_or("name", ""), up);
    });
  }
  client_.add_reconnect_handler([weak] {
    if (auto glue = weak.lock()) {
      glue->reregister_all();
      glue->refresh_watches();
    }
  });
  notifier_ = std::thread([this] { notifier_main(); });
  logging_->start();  // its reconnect handler runs after ours: loggers after their services
}

bool ServicesGlue::provides(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& entry : registrations_)
    if (entry.second.name == name) return true;
  return false;
}

// ------------------------------------------------------------------ calling

services::Connector ServicesGlue::connector(std::string name, std::string interface, std::string signature) {
  return [this, name = std::move(name), interface = std::move(interface),
          signature = std::move(signature)](services::ProviderLink& link) -> Status {
    Message found;
    try {
      Message lookup = client_.new_request(method::lookup_service);
      lookup.set("name", name).set("interface", interface).set("signature", signature);
      found = client_.request(std::move(lookup));
    } catch (const Failure& failure) {
      return Status::failure(failure.code(), failure.what());
    } catch (const std::exception& error) {
      return Status::failure(LNE_GOT_INVALID_RESPONSE, error.what());
    }
    UniqueFd socket;
    Status reached = connect_to_provider(found, socket);
    if (!reached.ok()) return reached;
    Message handshake = Message::request(1, method::call);
    handshake.set("service_id", found.get_int_or("service_id", 0));
    if (const int error = send_all(socket.get(), protocol::encode(handshake), -1, kHandshakeTimeout); error != 0)
      return Status::failure(LNE_NO_PROVIDER_FOUND, std::string("handshake: ") + std::strerror(error));
    Message answer;
    Status read = read_answer(socket.get(), answer);
    if (!read.ok()) return read;
    if (answer.is_error())
      return Status::failure(answer.error_code() > 0 ? answer.error_code() : LNE_REQUEST_FAILED, answer.error_text());
    if (found.has("log_services")) logging_->set_loggers(name, "", found.get_list("log_services"));
    const std::int64_t local_id = answer.get_int_or("service_id", -1);
    if (local_id <= 0 || local_id > 0xffffffffLL || !set_blocking(socket.get()))
      return Status::failure(LNE_GOT_INVALID_RESPONSE, "invalid handshake answer");
    link.fd = socket.release();
    link.service_id = static_cast<std::uint32_t>(local_id);
    return {};
  };
}

// ---------------------------------------------------------------- providing

std::uint32_t ServicesGlue::register_provider(const std::string& name, const std::string& interface,
                                              std::shared_ptr<const services::ServiceSignature> signature,
                                              services::Handler handler, void* user_data, const char* group) {
  std::uint32_t local_id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    local_id = next_local_id_++;
  }
  const std::string signature_text = signature->text();
  Status added = dispatcher_.add_provider(local_id, name, std::move(signature), handler, user_data, group);
  if (!added.ok()) throw Failure(-added.code(), added.detail());
  Registration registration{name, interface, group != nullptr ? group : "", group != nullptr, signature_text, -1};
  Message request = client_.new_request(method::register_service);
  request.set("name", name).set("interface", interface).set("signature", signature_text);
  if (registration.has_group) request.set("group", registration.group);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    registrations_[local_id] = registration;
  }
  try {
    // The translation is in place (loop thread) before any caller can look
    // the new id up.
    client_.request(std::move(request), Client::kRequestTimeout,
                    [this, local_id, name, interface](const Message& answer) {
                      if (answer.has("log_services"))
                        logging_->set_loggers(name, interface, answer.get_list("log_services"));
                      std::lock_guard<std::mutex> lock(mutex_);
                      const std::int64_t manager_id = answer.get_int_or("service_id", -1);
                      auto it = registrations_.find(local_id);
                      if (it == registrations_.end()) return;
                      it->second.manager_id = manager_id;
                      local_by_manager_id_[manager_id] = local_id;
                    });
  } catch (...) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      registrations_.erase(local_id);
    }
    dispatcher_.remove_provider(local_id);
    throw;
  }
  return local_id;
}

Status ServicesGlue::release_provider(std::uint32_t local_id) {
  std::int64_t manager_id = -1;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = registrations_.find(local_id);
    if (it != registrations_.end()) {
      manager_id = it->second.manager_id;
      registrations_.erase(it);
    }
    if (manager_id > 0) local_by_manager_id_.erase(manager_id);
  }
  if (manager_id > 0 && client_.registered()) {
    try {
      Message request = client_.new_request(method::unregister_service);
      request.set("service_id", manager_id);
      client_.request(std::move(request));
    } catch (...) {
      // The manager forgets it anyway when we leave; nothing to do here.
    }
  }
  return dispatcher_.remove_provider(local_id);
}

void ServicesGlue::on_call(PeerRequest& request) {
  // On this host the rule of shared-memory segments: same user unless
  // LN_PEER_ALLOW_UIDS says otherwise. Over TCP there is no uid to check
  // (the peer server listens on the address used towards the manager).
  if (!request.connection->over_tcp() && !request.connection->local_user_allowed()) {
    request.fail(LNE_REQUEST_FAILED,
                 "services are only offered to processes of the same user on this host "
                 "(or of users LN_PEER_ALLOW_UIDS lists)");
    return;
  }
  const std::int64_t manager_id = request.message.get_int_or("service_id", -1);
  std::uint32_t local_id = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = local_by_manager_id_.find(manager_id); it != local_by_manager_id_.end()) local_id = it->second;
  }
  if (local_id == 0 || !dispatcher_.has_provider(local_id)) {
    request.fail(LNE_SVC_NOT_REGISTERED, "service id " + std::to_string(manager_id) + " is not provided here");
    return;
  }
  Message ok = Message::response_to(request.message);
  ok.set("service_id", static_cast<std::int64_t>(local_id));
  if (!request.connection->send(ok)) return;
  UniqueFd socket = client_.peer_server().take_over(request.connection);
  if (!socket.valid() || !set_blocking(socket.get())) return;
  dispatcher_.adopt_connection(socket.release(), local_id);  // closes it itself on failure
}

void ServicesGlue::reregister_all() {
  // Loop thread, after a (restarted) manager accepted us again: the old
  // manager ids mean nothing any more.
  std::map<std::uint32_t, Registration> registrations;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    local_by_manager_id_.clear();
    registrations = registrations_;
  }
  std::weak_ptr<ServicesGlue> weak = weak_from_this();
  for (const auto& [local_id, registration] : registrations) {
    Message request = client_.new_request(method::register_service);
    request.set("name", registration.name)
        .set("interface", registration.interface)
        .set("signature", registration.signature);
    if (registration.has_group) request.set("group", registration.group);
    client_.manager().send_request(std::move(request), [weak, id = local_id](Reply& reply) {
      auto glue = weak.lock();
      if (!glue || reply.error != 0) return;  // another provider took the name meanwhile: stays unregistered
      std::lock_guard<std::mutex> lock(glue->mutex_);
      auto it = glue->registrations_.find(id);
      if (it == glue->registrations_.end()) return;
      if (reply.message.has("log_services"))
        glue->logging_->set_loggers(it->second.name, it->second.interface, reply.message.get_list("log_services"));
      it->second.manager_id = reply.message.get_int_or("service_id", -1);
      glue->local_by_manager_id_[it->second.manager_id] = id;
    });
  }
}

// ------------------------------------------------------- waiting, watching

bool ServicesGlue::service_registered(const std::string& name) {
  Message lookup = client_.new_request(method::lookup_service);
  lookup.set("name", name).set("interface", "").set("signature", "");
  try {
    client_.request(std::move(lookup));
    return true;
  } catch (const Failure& failure) {
    if (failure.code() == LNE_NO_PROVIDER_FOUND) return false;
    throw;
  }
}

int ServicesGlue::wait_for_service(const std::string& name, double timeout) {
  const bool limited = timeout >= 0;
  const auto deadline = Clock::now() + std::chrono::microseconds(static_cast<long long>(std::min(timeout, 1e9) * 1e6));
  for (;;) {
    std::uint64_t seen;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      seen = service_changes_;
    }
    if (service_registered(name)) return 1;
    if (limited && Clock::now() >= deadline) return 0;
    // Woken by service_available; the periodic check covers a lost
    // notification (e.g. across a manager restart).
    auto until = Clock::now() + std::chrono::milliseconds(200);
    if (limited) until = std::min(until, deadline);
    std::unique_lock<std::mutex> lock(mutex_);
    service_changed_.wait_until(lock, until, [&] { return service_changes_ != seen; });
  }
}

bool ServicesGlue::topic_has_publisher(const std::string& name) {
  const Message topics = client_.request(client_.new_request(method::list_topics));
  const auto& names = topics.get_list("names");
  const auto& publishers = topics.get_list("publishers");
  for (std::size_t i = 0; i < names.size() && i < publishers.size(); ++i)
    if (names[i] == name) return !publishers[i].empty();
  return false;
}

void ServicesGlue::on_availability_notification(bool topic, const std::string& name, bool available) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!topic) ++service_changes_;
    auto it = watches_.find(WatchKey{topic, name});
    if (it != watches_.end()) {
      it->second.changed = true;
      events_.push_back(Event{topic, name, available ? 1 : 0, 0});
    }
  }
  service_changed_.notify_all();
  events_changed_.notify_all();
}

void ServicesGlue::refresh_watches() {
  std::vector<WatchKey> keys;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& entry : watches_) keys.push_back(entry.first);
  }
  if (keys.empty()) return;
  std::weak_ptr<ServicesGlue> weak = weak_from_this();
  // One list of each kind tells the state of every watched name.
  for (const bool topic : {false, true}) {
    if (std::none_of(keys.begin(), keys.end(), [topic](const WatchKey& key) { return key.first == topic; })) continue;
    Message request = client_.new_request(topic ? method::list_topics : method::list_services);
    client_.manager().send_request(std::move(request), [weak, topic](Reply& reply) {
      auto glue = weak.lock();
      if (!glue || reply.error != 0) return;  // lost again: the next reconnect looks again
      std::set<std::string> present;
      try {
        const auto& names = reply.message.get_list("names");
        const auto& owners = reply.message.get_list(topic ? "publishers" : "providers");
        for (std::size_t i = 0; i < names.size() && i < owners.size(); ++i)
          if (!owners[i].empty()) present.insert(names[i]);
      } catch (const protocol::ProtocolError&) {
        return;
      }
      {
        std::lock_guard<std::mutex> lock(glue->mutex_);
        for (const auto& [key, watch] : glue->watches_) {
          if (key.first != topic) continue;
          glue->events_.push_back(Event{topic, key.second, present.count(key.second) ? 1 : 0, watch.generation});
        }
      }
      glue->events_changed_.notify_all();
    });
  }
}

void ServicesGlue::set_availability_handler(bool topic, const std::string& name, AvailabilityHandler handler,
                                            void* user_data) {
  const WatchKey key{topic, name};
  std::uint64_t generation = 0;
  {
    // Waits for a running invocation in another thread (one in this thread,
    // i.e. a handler replacing itself, simply completes later).
    std::lock_guard<std::recursive_mutex> delivering(delivering_);
    std::lock_guard<std::mutex> lock(mutex_);
    if (handler == nullptr) {
      watches_.erase(key);
      return;
    }
    Watch& watch = watches_[key];
    watch = Watch{};
    watch.handler = handler;
    watch.user_data = user_data;
    watch.generation = generation = next_generation_++;
  }
  const int available = (topic ? topic_has_publisher(name) : service_registered(name)) ? 1 : 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = watches_.find(key);
    if (it == watches_.end() || it->second.generation != generation) return;
    // A notification that came meanwhile is queued and tells a newer state.
    if (!it->second.changed) events_.push_back(Event{topic, name, available, generation});
  }
  events_changed_.notify_all();
}

void ServicesGlue::deliver(const Event& event) {
  std::lock_guard<std::recursive_mutex> delivering(delivering_);
  AvailabilityHandler handler;
  void* user_data;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = watches_.find(WatchKey{event.topic, event.name});
    if (it == watches_.end()) return;
    Watch& watch = it->second;
    if (event.generation != 0 && event.generation != watch.generation) return;
    if (watch.delivered == event.available) return;
    watch.delivered = event.available;
    handler = watch.handler;
    user_data = watch.user_data;
  }
  handler(static_cast<void*>(&client_), event.name.c_str(), event.available, user_data);
}

void ServicesGlue::notifier_main() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (events_.empty()) {
      events_changed_.wait(lock, [this] { return stopping_ || !events_.empty(); });
      continue;
    }
    Event event = std::move(events_.front());
    events_.pop_front();
    lock.unlock();
    deliver(event);
    lock.lock();
  }
}

}  // namespace ln::clientlib
