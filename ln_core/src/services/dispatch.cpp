// Providers, their callers' connections and requests: reading requests in
// turns, running handlers, sending (or queueing) responses. Service groups
// and thread pools, which decide who waits, are in thread_pools.cpp.
#include "services/dispatch.hpp"

#include <cxxabi.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <exception>

#include "services/dispatch_internal.hpp"

namespace ln::services {

namespace {
thread_local const Provider* handling_provider = nullptr;
}  // namespace

// --------------------------------------------------------------- Request

void* to_handle(Request* request) { return static_cast<RequestHandle*>(request); }

Request* provider_request(void* handle) {
  auto* h = static_cast<RequestHandle*>(handle);
  return h != nullptr && h->side() == RequestHandle::Side::Provider ? static_cast<Request*>(h) : nullptr;
}

Request::Request(Dispatcher& dispatcher, std::shared_ptr<Provider> provider,
                 std::shared_ptr<ProviderConnection> connection, const frames::RequestHead& head,
                 frames::Payload payload, const Limits& limits, std::shared_ptr<CallLog> log)
    : RequestHandle(Side::Provider),
      dispatcher_(dispatcher),
      provider_(std::move(provider)),
      connection_(std::move(connection)),
      request_id_(head.request_id),
      caller_id_(head.client_id),
      payload_(std::move(payload)),
      limits_(limits),
      log_(log && log->enabled() ? std::move(log) : nullptr),
      arrived_(log_ ? wall_clock_seconds() : 0) {}

std::string_view Request::request_data() const {
  return {payload_.data() + frames::header_size, payload_.size() - frames::header_size};
}

Status Request::set_data(void* data, const char* signature) {
  const ServiceSignature& registered = *provider_->signature;
  if (!same_signature(registered.text(), signature))
    return Status::failure(LNE_SVC_REQ_SET_DATA_WRONG, "set_data(): signature '" +
                                                           std::string(signature ? signature : "(null)") +
                                                           "' differs from the service's '" + registered.text() + "'");
  if (data == nullptr) return Status::failure(LNE_INVALID_PARAMETER, "set_data(): no data");
  Status s = unflatten(registered.request(), payload_.data() + frames::header_size,
                       payload_.size() - frames::header_size, data, limits_, arena_);
  if (s.ok()) data_ = data;
  return s;
}

Status Request::respond() {
  const ServiceSignature& signature = *provider_->signature;
  if (data_ == nullptr && !signature.response().empty())
    return Status::failure(LNE_INVALID_PARAMETER, "respond(): call set_data() first (it names the response struct)");
  const void* host = data_ ? static_cast<const char*>(data_) + signature.response_offset() : nullptr;
  return answer(0, {}, host, {});
}

Status Request::respond_data(const void* data) {
  if (data == nullptr) return Status::failure(LNE_INVALID_PARAMETER, "respond_data(): no data");
  return answer(0, {}, static_cast<const char*>(data) + provider_->signature->response_offset(), {});
}

Status Request::respond_flat(std::string_view flat_response) { return answer(0, {}, nullptr, flat_response); }

Status Request::respond_error(int error, std::string_view message) {
  if (error == 0 || error == -LNE_SVC_RESP_LATER)
    return Status::failure(LNE_INVALID_PARAMETER, "respond_error(): " + std::to_string(error) + " is no error code");
  return answer(error, message, nullptr, {});
}

bool Request::is_aborted() const { return connection_->closed || io::peer_closed(connection_->fd); }

Status Request::answer(int result, std::string_view text, const void* host, std::string_view flat) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (answered_)
      return Status::failure(LNE_SVC_HANDLER_MULTI_RESP,
                             "service '" + provider_->name + "': the request was already answered");
    answered_ = true;
    sending_ = true;
  }
  const Status s = send_frame(result, text, host, flat);
  bool done = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sending_ = false;
    done = !handler_running_;
  }
  if (done) delete this;
  return s;
}

Status Request::send_frame(int result, std::string_view text, const void* host, std::string_view flat) {
  const MessageLayout& layout = provider_->signature->response();
  std::size_t body_size = 0;
  Status invalid_response;
  if (result == 0) {
    invalid_response = host != nullptr ? flat_size(layout, host, limits_, body_size)
                                       : check_flat(layout, flat.data(), flat.size(), limits_);
    if (invalid_response.ok() && host == nullptr) body_size = flat.size();
  }
  if (!invalid_response.ok()) {
    // The caller must not wait for a response that will never come.
    const std::string reason =
        "provider of '" + provider_->name + "' failed to send its response: " + invalid_response.detail();
    Status s =
        dispatcher_.send_response(connection_, request_id_, invalid_response.code(), reason, {}, nullptr, nullptr, 0);
    return s.ok() ? invalid_response : s;
  }
  if (!log_)
    return dispatcher_.send_response(connection_, request_id_, result, text, flat,
                                     result == 0 && host ? &layout : nullptr, host, body_size);
  // Logged: the flat response is made once, sent and reported.
  std::string flattened;
  if (result == 0 && host != nullptr) {
    flattened.resize(body_size);
    write_flat(layout, host, flattened.data());
    flat = flattened;
  }
  CallLog::Item item;
  item.service = provider_->name;
  item.response = true;
  item.caller_id = caller_id_;
  item.request_id = request_id_;
  item.result = result;
  item.flat = result == 0 ? flat : std::string_view();
  item.request_time = arrived_;
  item.completion_time = wall_clock_seconds();
  item.fd = connection_->fd;
  const Status sent =
      dispatcher_.send_response(connection_, request_id_, result, text, flat, nullptr, nullptr, flat.size());
  item.transfer_time = wall_clock_seconds() - item.completion_time;
  if (sent.ok()) log_->record(item);
  return sent;
}

void Request::handler_returned(int ret) {
  std::unique_lock<std::mutex> lock(mutex_);
  handler_running_ = false;
  if (answered_) {
    const bool done = !sending_;
    lock.unlock();
    if (done) delete this;
    return;
  }
  if (ret == -LNE_SVC_RESP_LATER) return;  // lives on until answered
  lock.unlock();
  if (ret == 0)
    answer(-LNE_SVC_HANDLER_NO_RESP, "handler of service '" + provider_->name + "' returned without responding",
           nullptr, {});
  else
    answer(ret, {}, nullptr, {});
}

// ------------------------------------------------------------ Dispatcher

// Writes one response frame to `connection`. A caller that has gone (it
// aborted or timed out) simply does not get it; one that does not read gets
// the rest queued (see ProviderConnection) or, beyond its budget, loses the
// connection.
Status Dispatcher::send_response(const std::shared_ptr<ProviderConnection>& connection, std::uint32_t request_id,
                                 int result, std::string_view text, std::string_view body_flat,
                                 const MessageLayout* layout, const void* host, std::size_t body_size) {
  const std::size_t overhead = frames::response_overhead(text);
  const std::size_t total = overhead + body_size;
  char small[512];
  std::unique_ptr<char[]> large;
  char* frame = small;
  if (total > sizeof small) {
    large.reset(new (std::nothrow) char[total]);
    if (!large) return Status::failure(LNE_NO_MEM, "no memory for a response of " + std::to_string(total) + " bytes");
    frame = large.get();
  }
  frames::write_response_head(frame, {request_id, result}, text, body_size);
  if (layout != nullptr)
    write_flat(*layout, host, frame + overhead);
  else if (body_size > 0)
    std::memcpy(frame + overhead, body_flat.data(), body_size);
  int err = 0;
  switch (connection->send(frame, total, std::move(large), limits_, err)) {
    case ProviderConnection::Sent::out:
      return {};
    case ProviderConnection::Sent::queued: {
      bool unwatched = false;
      {
        // A thread serving the connection re-arms it when it is done with it.
        std::lock_guard<std::mutex> lock(mutex_);
        if (!connection->closed && !connection->claimed) unwatched = !arm_locked(*connection).ok();
      }
      if (unwatched) close_connection(connection);  // never flushed: the caller cannot get its answer
      return {};
    }
    case ProviderConnection::Sent::too_much:
      close_connection(connection);  // the caller does not read its answers: it loses its connection
      return {};
    case ProviderConnection::Sent::failed:
      if (connection->closed) return {};
      return errno_failure("sending the service response", err);
  }
  return {};
}

Dispatcher::Dispatcher(void* client, Limits limits, WaitPolicy wait) : client_(client), limits_(limits), wait_(wait) {}

Dispatcher::~Dispatcher() {
  std::vector<ThreadPool*> pools;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [name, pool] : pools_) {
      pool->stopping = true;
      pool->events.wake();
      pools.push_back(pool.get());
    }
  }
  for (ThreadPool* pool : pools)
    for (PoolThread& t : pool->threads)
      if (t.thread.joinable()) t.thread.join();

  std::vector<ServiceGroup*> groups;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (default_group_) groups.push_back(default_group_.get());
    for (auto& [name, group] : groups_) groups.push_back(group.get());
    for (ServiceGroup* group : groups) {
      group->unblock_pending = true;
      group->events.wake();
    }
  }
  std::vector<std::shared_ptr<ProviderConnection>> connections;
  {
    // Whoever is still in wait_and_handle() leaves now; wait for it.
    std::unique_lock<std::mutex> lock(mutex_);
    for (ServiceGroup* group : groups) group->turn.wait(lock, [&] { return !group->busy; });
    for (auto& [key, connection] : connections_) connections.push_back(connection);
  }
  for (auto& connection : connections) close_connection(connection);
}

// ------------------------------------------------------------- providers

Status Dispatcher::add_provider(std::uint32_t service_id, std::string name,
                                std::shared_ptr<const ServiceSignature> signature, Handler handler, void* user_data,
                                const char* group_name) {
  if (handler == nullptr) return Status::failure(LNE_SVC_NO_HANDLER, "service '" + name + "' has no handler");
  if (!signature) return Status::failure(LNE_INVALID_PARAMETER, "service '" + name + "' has no signature");
  std::lock_guard<std::mutex> lock(mutex_);
  if (providers_.count(service_id) != 0)
    return Status::failure(LNE_SVC_ALREADY_REGISTERED, "service id " + std::to_string(service_id) + " is taken");
  ServiceGroup* group = nullptr;
  Status s = group_locked(group_name, group);
  if (!s.ok()) return s;
  auto provider = std::make_shared<Provider>();
  provider->service_id = service_id;
  provider->name = std::move(name);
  provider->signature = std::move(signature);
  provider->handler = handler;
  provider->user_data = user_data;
  provider->group = group;
  providers_.emplace(service_id, std::move(provider));
  return {};
}

Status Dispatcher::remove_provider(std::uint32_t service_id) {
  std::shared_ptr<Provider> provider;
  std::vector<std::shared_ptr<ProviderConnection>> connections;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = providers_.find(service_id);
    if (it == providers_.end())
      return Status::failure(LNE_SVC_NOT_REGISTERED, "no provider with id " + std::to_string(service_id));
    provider = it->second;
    provider->removed = true;
    providers_.erase(it);
    for (auto& [key, connection] : connections_)
      if (connection->provider == provider) connections.push_back(connection);
  }
  for (auto& connection : connections) close_connection(connection);
  std::unique_lock<std::mutex> lock(mutex_);
  const int own = handling_provider == provider.get() ? 1 : 0;
  handlers_done_.wait(lock, [&] { return provider->running <= own; });
  return {};
}

bool Dispatcher::has_provider(std::uint32_t service_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return providers_.count(service_id) != 0;
}

Status Dispatcher::set_connection_observer(std::uint32_t service_id, ConnectionObserver observer, void* user_data) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = providers_.find(service_id);
  if (it == providers_.end())
    return Status::failure(LNE_SVC_NOT_REGISTERED, "no provider with id " + std::to_string(service_id));
  it->second->observer = observer;
  it->second->observer_data = user_data;
  return {};
}

int Dispatcher::provider_fd(std::uint32_t service_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = providers_.find(service_id);
  return it == providers_.end() ? -LNE_SVC_NOT_REGISTERED : it->second->group->events.epoll_fd;
}

// ----------------------------------------------------------- connections

Status Dispatcher::adopt_connection(int fd, std::uint32_t service_id) {
  std::shared_ptr<Provider> provider;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = providers_.find(service_id);
    if (it != providers_.end()) provider = it->second;
  }
  if (!provider) {
    ::close(fd);
    return Status::failure(LNE_SVC_NOT_REGISTERED, "no provider with id " + std::to_string(service_id));
  }
  const int on = 1;  // fails harmlessly on Unix sockets
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  auto connection = std::make_shared<ProviderConnection>(fd, provider, frames::max_payload_for(limits_.max_data_size));

  std::lock_guard<std::mutex> lock(mutex_);
  if (provider->removed)
    return Status::failure(LNE_SVC_NOT_REGISTERED, "service '" + provider->name + "' was just unregistered");
  connection->key = next_connection_key_++;
  Status s = arm_locked(*connection);
  if (!s.ok()) return s;
  connections_.emplace(connection->key, connection);
  queue_event_locked(provider, LN_NEW_SVC_CLIENT, fd);
  return {};
}

// Registers (or re-arms) a connection in the event set that serves its
// group now: the group's own, or its pool's.
Status Dispatcher::arm_locked(ProviderConnection& connection) {
  ServiceGroup& group = *connection.provider->group;
  const bool shared = group.pool != nullptr;
  EventSet& set = shared ? group.pool->events : group.events;
  const int home = set.epoll_fd;
  const bool queued = connection.has_queued;
  const std::uint32_t events = set_events(shared, queued);
  if (queued)
    set.arm_timer(connection.last_progress_ns + static_cast<std::int64_t>(limits_.response_timeout_ms) * 1000000);
  if (connection.registered_in == home && !shared && connection.armed_events == events) return {};  // still armed
  epoll_event ev{};
  ev.events = events;
  ev.data.u64 = connection.key;
  connection.armed_events = events;
  if (connection.registered_in == home) {
    if (::epoll_ctl(home, EPOLL_CTL_MOD, connection.fd, &ev) == 0) return {};
    return errno_failure("epoll_ctl", errno);
  }
  if (connection.registered_in >= 0) ::epoll_ctl(connection.registered_in, EPOLL_CTL_DEL, connection.fd, nullptr);
  connection.registered_in = -1;
  if (::epoll_ctl(home, EPOLL_CTL_ADD, connection.fd, &ev) != 0) return errno_failure("epoll_ctl", errno);
  connection.registered_in = home;
  return {};
}

void Dispatcher::expire_queued_responses(EventSet& set) {
  set.consume_timer();
  const std::int64_t now = now_ns();
  const std::int64_t timeout = static_cast<std::int64_t>(limits_.response_timeout_ms) * 1000000;
  std::vector<std::shared_ptr<ProviderConnection>> stalled;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    set.timer_armed = false;
    for (auto& [key, connection] : connections_) {
      if (connection->registered_in != set.epoll_fd || !connection->has_queued) continue;
      const std::int64_t due = connection->last_progress_ns + timeout;
      if (due <= now)
        stalled.push_back(connection);
      else
        set.arm_timer(due);
    }
  }
  // Its caller has not taken a byte of its answers for response_timeout_ms.
  for (auto& connection : stalled) close_connection(connection);
}

void Dispatcher::move_group_connections_locked(const ServiceGroup& group, int to_epoll) {
  for (auto& [key, connection] : connections_) {
    // A claimed connection moves when its thread re-arms it.
    if (connection->provider->group != &group || connection->claimed || connection->registered_in == to_epoll) continue;
    arm_locked(*connection);
  }
}

void Dispatcher::queue_event_locked(const std::shared_ptr<Provider>& provider, int event, int fd) {
  if (provider->observer == nullptr) return;
  ServiceGroup& group = *provider->group;
  group.observer_events.push_back({provider, event, fd});
  (group.pool ? group.pool->events : group.events).wake();
}

void Dispatcher::close_connection(const std::shared_ptr<ProviderConnection>& connection) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (connection->closed) return;
    connection->closed = true;
    connections_.erase(connection->key);
    if (connection->registered_in >= 0) ::epoll_ctl(connection->registered_in, EPOLL_CTL_DEL, connection->fd, nullptr);
    connection->registered_in = -1;
    queue_event_locked(connection->provider, LN_REMOVE_SVC_CLIENT, connection->fd);
  }
  // Wakes a blocked response write; the descriptor itself is closed with
  // the last reference.
  ::shutdown(connection->fd, SHUT_RDWR);
}

std::shared_ptr<ProviderConnection> Dispatcher::claim(std::uint64_t key) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = connections_.find(key);
  if (it == connections_.end() || it->second->claimed) return nullptr;
  it->second->claimed = true;
  return it->second;
}

void Dispatcher::release(const std::shared_ptr<ProviderConnection>& connection) {
  bool failed = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    connection->claimed = false;
    if (!connection->closed) failed = !arm_locked(*connection).ok();
  }
  if (failed) close_connection(connection);
}

int Dispatcher::serve(std::uint64_t key) {
  const std::shared_ptr<ProviderConnection> connection = claim(key);
  if (!connection) return 0;
  const int handled = serve_claimed(connection);
  release(connection);
  return handled;
}

int Dispatcher::serve_claimed(const std::shared_ptr<ProviderConnection>& connection) {
  if (connection->has_queued) {
    bool empty = false;
    const io::Result flushed = connection->flush(empty);
    if (flushed.outcome != io::Outcome::Done) {
      close_connection(connection);  // the caller left
      return 0;
    }
    if (!empty) return 0;  // release() waits for room again
  }
  Status malformed;
  // Requests left from the last turn come first; more are read after them.
  // A caller that left meanwhile takes its unstarted requests with it.
  const bool backlog = connection->assembler.has_ready();
  const io::Result r = !backlog ? io::receive_available(connection->fd, connection->assembler, malformed)
                       : io::peer_closed(connection->fd) ? io::Result{io::Outcome::Closed, 0}
                                                         : io::Result{};
  if (r.outcome != io::Outcome::Done) {
    // The caller left (or broke the stream): its unstarted requests go too.
    close_connection(connection);
    return 0;
  }
  // A caller that does not take its answers gets no more of them: its
  // further requests wait (in the assembler, then in its socket) until it
  // reads or its connection times out.
  int handled = 0;
  frames::Payload payload;
  while (!connection->closed && !connection->has_queued && handled < requests_per_turn &&
         connection->assembler.next(payload)) {
    handle_payload(connection, std::move(payload));
    ++handled;
  }
  if (!connection->closed && !connection->has_queued && connection->assembler.has_ready()) {
    std::lock_guard<std::mutex> lock(mutex_);
    ServiceGroup& group = *connection->provider->group;
    EventSet& set = group.pool ? group.pool->events : group.events;
    set.backlog.push_back(connection->key);
    set.wake();
  }
  return handled;
}

int Dispatcher::serve_backlog(EventSet& set) {
  std::deque<std::uint64_t> keys;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    keys.swap(set.backlog);
  }
  int handled = 0;
  for (std::uint64_t key : keys) handled += serve(key);
  return handled;
}

void Dispatcher::handle_payload(const std::shared_ptr<ProviderConnection>& connection, frames::Payload payload) {
  frames::RequestHead head;
  if (!frames::parse_request(payload, head).ok()) {
    close_connection(connection);
    return;
  }
  Provider& provider = *connection->provider;
  if (provider.removed || head.service_id != provider.service_id) {
    send_response(connection, head.request_id, -LNE_SVC_NOT_REGISTERED,
                  "service '" + provider.name + "' is not provided here any more", {}, nullptr, nullptr, 0);
    return;
  }
  const Status valid = check_flat(provider.signature->request(), payload.data() + frames::header_size,
                                  payload.size() - frames::header_size, limits_);
  if (!valid.ok()) {
    send_response(connection, head.request_id, -LNE_SVC_RECV_REQ,
                  "malformed request for service '" + provider.name + "': " + valid.detail(), {}, nullptr, nullptr, 0);
    return;
  }
  run_handler(new Request(*this, connection->provider, connection, head, std::move(payload), limits_, log_));
}

void Dispatcher::run_handler(Request* request) {
  const std::shared_ptr<Provider> provider = request->provider_;  // the request may be gone afterwards
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++provider->running;
  }
  const Provider* outer = handling_provider;
  handling_provider = provider.get();
  int ret = 0;
  std::string exception_text;
  bool threw = false;
  try {
    ret = provider->handler(client_, to_handle(request), provider->user_data);
  } catch (abi::__forced_unwind&) {
    throw;  // thread cancellation must go on
  } catch (const std::exception& e) {
    threw = true;
    exception_text = e.what();
  } catch (...) {
    threw = true;
    exception_text = "unknown exception";
  }
  if (threw) {
    request->respond_error(-LNE_SVC_HANDLER_EXC,
                           "handler of service '" + provider->name + "' threw: " + exception_text);
    ret = 0;
  }
  handling_provider = outer;
  request->handler_returned(ret);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    --provider->running;
  }
  handlers_done_.notify_all();
}

void Dispatcher::deliver_events(const ServiceGroup* only_group, const ThreadPool* only_pool) {
  std::vector<PendingEvent> events;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto take = [&](ServiceGroup& group) {
      if (only_group ? &group != only_group : group.pool != only_pool) return;
      for (PendingEvent& e : group.observer_events) events.push_back(std::move(e));
      group.observer_events.clear();
    };
    if (default_group_) take(*default_group_);
    for (auto& [name, group] : groups_) take(*group);
  }
  for (const PendingEvent& e : events) {
    ConnectionObserver observer = nullptr;
    void* data = nullptr;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      observer = e.provider->observer;
      data = e.provider->observer_data;
    }
    if (observer) observer(client_, e.event, e.fd, data);
  }
}

}  // namespace ln::services
