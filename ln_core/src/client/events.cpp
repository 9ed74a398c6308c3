#include "client/events.hpp"

#include <chrono>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "protocol/methods.hpp"
#include "services/dispatch.hpp"

namespace ln::clientlib {
namespace {

namespace method = protocol::method;
using protocol::Message;
using services::Status;

constexpr std::uint64_t kCallTag = 0x4c4e45564e43414cull;  // stale handles fail the check
constexpr std::uint64_t kConnectionTag = 0x4c4e45564e434f4eull;

// The generated request struct of ln/event/call (its response is empty).
#pragma pack(push, 1)
struct EventCallRequest {
  std::uint32_t data_len;
  std::uint8_t* data;
  std::uint32_t signature_len;
  char* signature;
};
#pragma pack(pop)

void put_u32(std::string& out, std::size_t value) {
  for (int shift = 0; shift < 32; shift += 8) out += static_cast<char>((value >> shift) & 0xff);
}

// The flat ln/event/call request: the event's data and its signature.
std::string call_request(std::string_view data, std::string_view signature) {
  std::string flat;
  flat.reserve(8 + data.size() + signature.size());
  put_u32(flat, data.size());
  flat += data;
  put_u32(flat, signature.size());
  flat += signature;
  return flat;
}

}  // namespace

// ---------------------------------------------------------------- handles

EventCall* EventCall::from_handle(void* handle) noexcept {
  auto* call = static_cast<EventCall*>(handle);
  return call != nullptr && call->tag_ == kCallTag ? call : nullptr;
}

Status EventCall::set_data(const char* call_signature, void* call_data) {
  if (call_signature == nullptr || call_data == nullptr)
    return Status::failure(LNE_INVALID_PARAMETER, "call_signature and call_data must not be NULL");
  if (signature_ != call_signature)
    return Status::failure(LNE_SVC_REQ_SET_DATA_WRONG, "the event came with signature '" + std::string(signature_) +
                                                           "', not '" + call_signature + "'");
  const std::size_t colon = signature_.find(": ");
  services::MessageLayout layout;
  Status compiled = colon == std::string_view::npos
                        ? Status::failure(LNE_INVALID_SIGNATURE, "no '<definition>: ' prefix")
                        : services::MessageLayout::compile(signature_.substr(colon + 2), layout);
  if (!compiled.ok())
    return Status::failure(LNE_INVALID_SIGNATURE,
                           "the event's signature '" + std::string(signature_) + "' is invalid: " + compiled.detail());
  Status filled =
      services::unflatten(layout, const_cast<char*>(data_.data()), data_.size(), call_data, services::Limits{}, arena_);
  if (!filled.ok()) return Status::failure(LNE_SVC_RECV_REQ, "malformed event data: " + filled.detail());
  return {};
}

EventConnection* EventConnection::from_handle(void* handle) noexcept {
  auto* connection = static_cast<EventConnection*>(handle);
  return connection != nullptr && connection->tag_ == kConnectionTag ? connection : nullptr;
}

// -------------------------------------------------------------------- hub

std::shared_ptr<EventHub> EventHub::of(Client& client) {
  bool made = false;
  auto glue = ServicesGlue::of(client);  // not inside part_state(): it holds the lock services_state() takes
  auto state = client.part_state("events", [&] {
    made = true;
    return std::static_pointer_cast<void>(std::make_shared<EventHub>(client, std::move(glue)));
  });
  auto hub = std::static_pointer_cast<EventHub>(state);
  if (made) hub->install_hooks();
  return hub;
}

EventHub::EventHub(Client& client, std::shared_ptr<ServicesGlue> glue) : client_(client), glue_(std::move(glue)) {}

void EventHub::install_hooks() {
  std::weak_ptr<EventHub> weak = weak_from_this();
  client_.add_notification_handler(std::string(method::event), [weak](const Message& message) {
    if (auto hub = weak.lock()) hub->on_event(message);
  });
  client_.add_reconnect_handler([weak] {
    if (auto hub = weak.lock()) hub->announce_again();
  });
  deliverer_ = std::thread([this] { deliver_main(); });
}

EventHub::~EventHub() {
  std::unique_lock<std::mutex> lock(mutex_);
  stopping_ = true;
  changed_.notify_all();
  // A delivery blocked in its call (nobody handles the default group) ends
  // with the abort; one just about to call is caught by the next round.
  while (delivering_ != 0) {
    if (EventConnection* connection = find_locked(delivering_)) connection->caller_->abort();
    changed_.wait_for(lock, std::chrono::milliseconds(10));
  }
  lock.unlock();
  if (deliverer_.joinable()) deliverer_.join();
  // Connections the program never disconnected: their handles stay valid
  // (and refused, as their hub is gone); their services go.
  for (auto& entry : connections_) {
    glue_->release_provider(entry.second->provider_id_);
    (void)entry.second.release();
  }
}

EventConnection* EventHub::find_locked(unsigned int id) const {
  const auto it = connections_.find(id);
  return it != connections_.end() ? it->second.get() : nullptr;
}

EventConnection* EventHub::connect(const std::string& event_name, const std::string& connect_signature,
                                   std::string connect_flat, EventHandler handler, void* user_data) {
  const std::size_t colon = connect_signature.find(": ");
  if (colon == std::string::npos || colon == 0)
    throw Failure(LNE_INVALID_SIGNATURE, "connect signature '" + connect_signature +
                                             "' does not read '<definition>: <signature>' (pass the generated "
                                             "*_CONNECT_SIGNATURE)");
  std::shared_ptr<const services::ServiceSignature> signature;
  const Status compiled = services::ServiceSignature::compile_shared(kEventCallSignature, signature);
  if (!compiled.ok()) throw Failure(LNE_INTERNAL_ERROR, compiled.detail());

  auto owned = std::unique_ptr<EventConnection>(new EventConnection);
  EventConnection* connection = owned.get();
  connection->tag_ = kConnectionTag;
  connection->event_name_ = event_name;
  connection->handler_service_ = event_name + "." + client_.name();
  connection->from_manager_ = event_name.rfind("ln.", 0) == 0;
  connection->connect_signature_ = connect_signature;
  connection->connect_flat_ = std::move(connect_flat);
  connection->handler_ = handler;
  connection->user_data_ = user_data;
  connection->hub_ = weak_from_this();
  connection->caller_ = std::make_unique<services::ServiceCaller>(
      signature, glue_->connector(connection->handler_service_, std::string(kEventCallInterface), signature->text()),
      glue_->reactor(), glue_->limits(), glue_->wait_policy(), connection->handler_service_);
  try {
    connection->provider_id_ = glue_->register_provider(connection->handler_service_, std::string(kEventCallInterface),
                                                        signature, &EventHub::handle_call, connection, nullptr);
  } catch (const Failure& failure) {
    if (failure.code() != LNE_SVC_ALREADY_REGISTERED) throw;
    throw Failure(LNE_REQUEST_FAILED, "cannot connect to event '" + event_name + "': its handler service '" +
                                          connection->handler_service_ +
                                          "' exists already (is this client connected to it already?)");
  }
  unsigned int id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    id = connection->id_ = next_id_++;
    connections_[id] = std::move(owned);
  }
  if (!connection->from_manager_) return connection;
  Message request = client_.new_request(method::connect_event);
  request.set("name", event_name)
      .set("signature", connect_signature)
      .set("connect_data", connection->connect_flat_)
      .set("handler", connection->handler_service_);
  try {
    // In the loop thread, before the initial sync's events arrive.
    client_.request(std::move(request), Client::kRequestTimeout, [this, id](const Message& answer) {
      if (answer.is_error()) return;
      std::lock_guard<std::mutex> lock(mutex_);
      if (EventConnection* found = find_locked(id)) {
        found->manager_id_ = answer.get_int_or("event_connection_id", -1);
        by_manager_id_[found->manager_id_] = id;
      }
    });
  } catch (...) {
    disconnect(connection);
    throw;
  }
  return connection;
}

void EventHub::disconnect(EventConnection* connection) {
  std::unique_ptr<EventConnection> owned;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto it = connections_.find(connection->id_);
    if (it == connections_.end() || it->second.get() != connection) return;
    while (delivering_ == connection->id_) {
      connection->caller_->abort();
      changed_.wait_for(lock, std::chrono::milliseconds(10));
    }
    owned = std::move(it->second);
    connections_.erase(it);
    by_manager_id_.erase(connection->manager_id_);
    for (auto pending = queue_.begin(); pending != queue_.end();)
      pending = pending->connection == connection->id_ ? queue_.erase(pending) : std::next(pending);
  }
  if (connection->manager_id_ > 0 && client_.registered()) {
    try {
      Message request = client_.new_request(method::disconnect_event);
      request.set("event_connection_id", connection->manager_id_);
      client_.request(std::move(request));
    } catch (...) {
      // The manager forgets it anyway when we leave or it restarts.
    }
  }
  glue_->release_provider(connection->provider_id_);  // waits for a running handler
}

int EventHub::handle_call(void* client, void* request_handle, void* user_data) {
  auto* connection = static_cast<EventConnection*>(user_data);
  services::Request* request = services::provider_request(request_handle);
  EventCallRequest received{};
  const Status filled = request->set_data(&received, kEventCallSignature.data());
  if (!filled.ok()) return filled.code();
  EventCall call(static_cast<Client*>(client), {reinterpret_cast<const char*>(received.data), received.data_len},
                 {received.signature, received.signature_len});
  call.tag_ = kCallTag;
  connection->handler_(client, &call, connection->user_data_);
  const Status answered = request->respond();
  return answered.ok() ? 0 : answered.code();
}

void EventHub::on_event(const Message& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = by_manager_id_.find(message.get_int_or("event_connection_id", -1));
  if (it == by_manager_id_.end()) return;  // disconnected meanwhile
  if (queue_.size() >= kMaxQueuedEvents) {
    queue_.pop_front();
    if (++dropped_ % 1000 == 1 && client_.debugging())
      client_.debug("events: %llu events dropped so far: nobody handles the default service group",
                    static_cast<unsigned long long>(dropped_));
  }
  queue_.push_back({it->second, message.get_string_or("data", ""), message.get_string_or("signature", "")});
  changed_.notify_all();
}

void EventHub::announce_again() {
  std::vector<Message> requests;
  std::vector<unsigned int> ids;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    by_manager_id_.clear();
    for (auto& [id, connection] : connections_) {
      if (!connection->from_manager_) continue;
      connection->manager_id_ = -1;
      Message request = client_.new_request(method::connect_event);
      request.set("name", connection->event_name_)
          .set("signature", connection->connect_signature_)
          .set("connect_data", connection->connect_flat_)
          .set("handler", connection->handler_service_);
      requests.push_back(std::move(request));
      ids.push_back(id);
    }
  }
  std::weak_ptr<EventHub> weak = weak_from_this();
  for (std::size_t i = 0; i < requests.size(); ++i) {
    client_.manager().send_request(std::move(requests[i]), [weak, id = ids[i]](Reply& reply) {
      auto hub = weak.lock();
      if (!hub || reply.error != 0) return;
      std::lock_guard<std::mutex> lock(hub->mutex_);
      if (EventConnection* connection = hub->find_locked(id)) {
        connection->manager_id_ = reply.message.get_int_or("event_connection_id", -1);
        hub->by_manager_id_[connection->manager_id_] = id;
      }
    });
  }
}

void EventHub::deliver_main() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    Pending event = std::move(queue_.front());
    queue_.pop_front();
    EventConnection* connection = find_locked(event.connection);
    if (connection == nullptr) continue;
    delivering_ = connection->id_;
    services::ServiceCaller* caller = connection->caller_.get();
    lock.unlock();
    // Blocks until the handler ran: events reach a connection one at a time.
    const int ret = caller->call_flat(call_request(event.data, event.signature), 0);
    if (ret != 0 && client_.debugging())
      client_.debug("events: delivering to '%s' failed: %s", connection->handler_service_.c_str(),
                    caller->last_error().c_str());
    lock.lock();
    delivering_ = 0;
    changed_.notify_all();
  }
}

}  // namespace ln::clientlib
