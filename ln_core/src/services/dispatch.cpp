#include "services/dispatch.hpp"

#include <cxxabi.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sched.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <deque>
#include <exception>
#include <list>

#define NO_CPP_WRAPPER
#include "ln/ln.h"
#include "services/socket_io.hpp"

namespace ln::services {

// ------------------------------------------------------------- internals

struct Provider {
  std::uint32_t service_id = 0;
  std::string name;
  std::shared_ptr<const ServiceSignature> signature;
  Handler handler = nullptr;
  void* user_data = nullptr;
  ServiceGroup* group = nullptr;
  std::atomic<bool> removed{false};
  // Guarded by the dispatcher's mutex:
  ConnectionObserver observer = nullptr;
  void* observer_data = nullptr;
  int running = 0;  // handlers in progress
};

namespace {

// How long a response write waits for a caller to make room before the rest
// is queued: a caller that reads takes it within this (large responses go
// out in one go), one that does not holds up its serving thread no longer.
constexpr auto response_wait = std::chrono::milliseconds(1);

std::int64_t now_ns() { return io::Clock::now().time_since_epoch().count(); }

}  // namespace

// Responses go out in order. What a caller does not take at once is queued
// (its requests then wait in its socket, see serve_claimed), flushed when
// the socket is writable again, and the connection is closed when the queue
// makes no progress for Limits::response_timeout_ms or would grow beyond
// Limits::max_unread_responses: a caller that does not read holds up
// nobody but itself.
struct ProviderConnection {
  ProviderConnection(int socket, std::shared_ptr<Provider> served, std::size_t max_payload)
      : fd(socket), provider(std::move(served)), assembler(max_payload) {}
  // Closed only when nothing refers to it any more, so a deferred response
  // can never write into a descriptor number that was reused meanwhile.
  ~ProviderConnection() { ::close(fd); }

  enum class Sent { out, queued, too_much, failed };

  // `owned`: the frame's memory, kept instead of copied if the rest is queued.
  Sent send(const char* data, std::size_t size, std::unique_ptr<char[]> owned, const Limits& limits, int& sys_errno) {
    std::lock_guard<std::mutex> lock(write_mutex);
    std::size_t sent = 0;
    if (queue.empty()) {
      const io::Result r = io::send_within(fd, data, size, io::Deadline::at(io::Clock::now() + response_wait), sent);
      sys_errno = r.sys_errno;
      // A caller that has gone (aborted, timed out) simply does not get it.
      if (r.outcome == io::Outcome::Done || r.outcome == io::Outcome::Closed) return Sent::out;
      if (r.outcome != io::Outcome::Timeout) return Sent::failed;
      last_progress_ns.store(now_ns());
    } else if (queued_bytes + size > limits.max_unread_responses) {
      return Sent::too_much;
    }
    Chunk chunk;
    if (owned) {
      chunk.owned = std::move(owned);
      chunk.data = data + sent;
    } else {
      chunk.copy.assign(data + sent, size - sent);
      chunk.data = chunk.copy.data();
    }
    chunk.size = size - sent;
    queued_bytes += chunk.size;
    queue.push_back(std::move(chunk));
    has_queued.store(true);
    return Sent::queued;
  }

  // Writes what the socket takes now; `empty` tells whether the queue is.
  io::Result flush(bool& empty) {
    std::lock_guard<std::mutex> lock(write_mutex);
    io::Result r;
    while (!queue.empty()) {
      Chunk& front = queue.front();
      const std::size_t before = front_sent;
      r = io::send_some(fd, front.data, front.size, front_sent);
      if (front_sent != before) last_progress_ns.store(now_ns());
      queued_bytes -= front_sent - before;
      if (r.outcome != io::Outcome::Done || front_sent < front.size) break;
      queue.pop_front();
      front_sent = 0;
    }
    empty = queue.empty();
    has_queued.store(!empty);
    return r;
  }

  const int fd;
  const std::shared_ptr<Provider> provider;
  frames::FrameAssembler assembler;  // used only by the thread that claimed the connection
  std::mutex write_mutex;
  std::atomic<bool> closed{false};
  std::atomic<bool> has_queued{false};
  std::atomic<std::int64_t> last_progress_ns{0};  // of the queue: when it last shrank or began
  // Guarded by write_mutex:
  struct Chunk {
    std::unique_ptr<char[]> owned;
    std::string copy;
    const char* data = nullptr;
    std::size_t size = 0;
  };
  std::deque<Chunk> queue;
  std::size_t front_sent = 0;
  std::size_t queued_bytes = 0;
  // Guarded by the dispatcher's mutex:
  std::uint64_t key = 0;
  int registered_in = -1;  // the epoll set it is registered with
  std::uint32_t armed_events = 0;
  bool claimed = false;  // a thread is reading it
};

namespace {

// In a pool's set, where several threads wait, a connection fires once and
// waits to be re-armed by the thread that served it: never two threads on
// one connection. A group's own set has one waiter at a time, so there a
// connection stays armed (level-triggered) and costs no re-arm per request.
// A connection whose caller has not taken all responses yet waits for room
// (EPOLLOUT) instead of requests (EPOLLIN): its requests wait in its socket.
std::uint32_t set_events(bool shared, bool output_queued) {
  return (output_queued ? EPOLLOUT : EPOLLIN) | EPOLLRDHUP | (shared ? EPOLLONESHOT : 0u);
}
// The key of an event set's timer (connection keys count up from 1, 0 is
// the wake-up descriptor).
constexpr std::uint64_t timer_key = ~std::uint64_t{0};
// Requests of one connection handled in a row; the rest wait for the
// connection's next turn, after the other connections': a caller that
// floods the provider delays the others by this many requests only. One
// (plain round robin) halved the median round trip of a normal caller next
// to a flooding one against four, with no measurable loss in throughput
// (bench/run ln_isolation, ln_services).
constexpr int requests_per_turn = 1;

thread_local const Provider* handling_provider = nullptr;

Status errno_failure(const std::string& what, int err) {
  return Status::failure(LNE_CHECK_ERRNO, what + ": " + std::strerror(err), err);
}

// epoll_wait() that first polls, yielding, for up to `spin_us` (WaitPolicy);
// `yield_first` when nothing can have come yet.
int wait_for_events(int epoll_fd, epoll_event* events, int max_events, const io::Deadline& deadline, unsigned spin_us,
                    bool yield_first = false) {
  if (spin_us > 0) {
    if (yield_first) ::sched_yield();
    const io::Clock::time_point until = io::Clock::now() + std::chrono::microseconds(spin_us);
    do {
      const int n = ::epoll_wait(epoll_fd, events, max_events, 0);
      if (n != 0) return n;
      ::sched_yield();
    } while (io::Clock::now() < until && !deadline.expired());
  }
  return ::epoll_wait(epoll_fd, events, max_events, deadline.remaining_ms());
}

}  // namespace

// An epoll set plus the eventfd that wakes its waiters (key 0) and a timer
// (timer_key) for the deadlines of its connections' queued responses.
struct EventSet {
  EventSet() = default;
  EventSet(const EventSet&) = delete;
  EventSet& operator=(const EventSet&) = delete;
  ~EventSet() {
    if (epoll_fd >= 0) ::close(epoll_fd);
    if (wake_fd >= 0) ::close(wake_fd);
    if (timer_fd >= 0) ::close(timer_fd);
  }

  Status open() {
    epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
    if (epoll_fd < 0) return errno_failure("epoll_create1", errno);
    wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (wake_fd < 0) return errno_failure("eventfd", errno);
    timer_fd = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
    if (timer_fd < 0) return errno_failure("timerfd_create", errno);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = 0;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, wake_fd, &ev) != 0) return errno_failure("epoll_ctl", errno);
    ev.data.u64 = timer_key;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, timer_fd, &ev) != 0) return errno_failure("epoll_ctl", errno);
    return {};
  }
  // Fires at `when_ns` (steady clock) unless it fires earlier already (dispatcher's mutex held).
  void arm_timer(std::int64_t when_ns) {
    if (timer_armed && timer_at_ns <= when_ns) return;
    itimerspec spec{};
    spec.it_value.tv_sec = static_cast<time_t>(when_ns / 1000000000);
    spec.it_value.tv_nsec = static_cast<long>(when_ns % 1000000000);
    if (spec.it_value.tv_sec == 0 && spec.it_value.tv_nsec == 0) spec.it_value.tv_nsec = 1;  // 0 would disarm
    ::timerfd_settime(timer_fd, TFD_TIMER_ABSTIME, &spec, nullptr);
    timer_armed = true;
    timer_at_ns = when_ns;
  }
  void consume_timer() {
    std::uint64_t expirations = 0;
    [[maybe_unused]] const ssize_t n = ::read(timer_fd, &expirations, sizeof expirations);
  }
  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(wake_fd, &one, sizeof one);
  }
  void consume() const {
    std::uint64_t value = 0;
    [[maybe_unused]] const ssize_t n = ::read(wake_fd, &value, sizeof value);
  }

  int epoll_fd = -1;
  int wake_fd = -1;
  int timer_fd = -1;
  bool timer_armed = false;  // guarded by the dispatcher's mutex
  std::int64_t timer_at_ns = 0;
  // Connections whose turn ended with requests left (received already, so
  // epoll will not report them), in turn order; guarded by the mutex.
  std::deque<std::uint64_t> backlog;
};

struct PendingEvent {
  std::shared_ptr<Provider> provider;
  int event = 0;
  int fd = -1;
};

struct ServiceGroup {
  std::string name;
  EventSet events;                  // its connections while it is handled directly
  ThreadPool* pool = nullptr;       // set while a pool serves it
  bool busy = false;                // a thread is in wait_and_handle(); others take turns
  bool answered_last_turn = false;  // the last wait_and_handle() served requests
  std::condition_variable turn;
  bool unblock_pending = false;
  std::vector<PendingEvent> observer_events;
};

struct PoolThread {
  std::thread thread;
  bool finished = false;
};

struct ThreadPool {
  std::string name;
  EventSet events;
  std::list<PoolThread> threads;  // a list: threads keep the address of their entry
  unsigned active = 0;            // threads not asked to retire
  unsigned retire_requests = 0;
  bool stopping = false;
  int policy = -1;
  int priority = -1;
  unsigned affinity_mask = 0;
};

namespace {

Status apply_schedparam(const ThreadPool& pool, pthread_t thread) {
  if (pool.policy != -1 || pool.priority != -1) {
    int policy = 0;
    sched_param param{};
    int err = ::pthread_getschedparam(thread, &policy, &param);
    if (err != 0) return errno_failure("pthread_getschedparam", err);
    const int new_policy = pool.policy != -1 ? pool.policy : policy;
    if (pool.priority != -1)
      param.sched_priority = pool.priority;
    else if (new_policy != policy)
      param.sched_priority = ::sched_get_priority_min(new_policy);
    err = ::pthread_setschedparam(thread, new_policy, &param);
    if (err != 0) return errno_failure("thread pool '" + pool.name + "': pthread_setschedparam", err);
  }
  if (pool.affinity_mask != 0) {
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    for (unsigned cpu = 0; cpu < 8 * sizeof pool.affinity_mask; ++cpu)
      if (pool.affinity_mask & (1u << cpu)) CPU_SET(cpu, &cpus);
    const int err = ::pthread_setaffinity_np(thread, sizeof cpus, &cpus);
    if (err != 0) return errno_failure("thread pool '" + pool.name + "': pthread_setaffinity_np", err);
  }
  return {};
}

// A thread's scheduling as it was, to undo a change that failed half-way.
struct ThreadScheduling {
  int policy = SCHED_OTHER;
  sched_param param{};
  bool has_policy = false;
  cpu_set_t cpus;
  bool has_cpus = false;
};

ThreadScheduling scheduling_of(pthread_t thread) {
  ThreadScheduling s;
  s.has_policy = ::pthread_getschedparam(thread, &s.policy, &s.param) == 0;
  CPU_ZERO(&s.cpus);
  s.has_cpus = ::pthread_getaffinity_np(thread, sizeof s.cpus, &s.cpus) == 0;
  return s;
}

void restore_scheduling(pthread_t thread, const ThreadScheduling& s) {
  if (s.has_policy) ::pthread_setschedparam(thread, s.policy, &s.param);
  if (s.has_cpus) ::pthread_setaffinity_np(thread, sizeof s.cpus, &s.cpus);
}

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

Status Dispatcher::group_locked(const char* name, ServiceGroup*& out) {
  if (ServiceGroup* found = find_group_locked(name)) {
    out = found;
    return {};
  }
  auto group = std::make_unique<ServiceGroup>();
  group->name = name ? name : "";
  Status s = group->events.open();
  if (!s.ok()) return s;
  out = group.get();
  if (name == nullptr)
    default_group_ = std::move(group);
  else
    groups_.emplace(name, std::move(group));
  return {};
}

ServiceGroup* Dispatcher::find_group_locked(const char* name) {
  if (name == nullptr) return default_group_.get();
  const auto it = groups_.find(std::string_view(name));
  return it == groups_.end() ? nullptr : it->second.get();
}

Status Dispatcher::pool_locked(const char* name, ThreadPool*& out) {
  if (name == nullptr) return Status::failure(LNE_INVALID_PARAMETER, "thread pool without a name");
  const auto it = pools_.find(std::string_view(name));
  if (it != pools_.end()) {
    out = it->second.get();
    return {};
  }
  auto pool = std::make_unique<ThreadPool>();
  pool->name = name;
  Status s = pool->events.open();
  if (s.ok()) s = start_threads_locked(*pool, 1);
  if (!s.ok()) return s;
  out = pool.get();
  pools_.emplace(name, std::move(pool));
  return {};
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

// ------------------------------------------------------ groups and pools

Status Dispatcher::wait_and_handle(const char* group_name, double timeout, int* handled) {
  if (handled) *handled = 0;
  const io::Deadline deadline =
      timeout < 0
          ? io::Deadline()
          : io::Deadline::at(io::Clock::now() +
                             std::chrono::duration_cast<io::Clock::duration>(std::chrono::duration<double>(timeout)));
  ServiceGroup* group = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Status s = group_locked(group_name, group);
    if (!s.ok()) return s;
  }
  bool yield_first = false;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto free = [&] { return !group->busy; };
    if (!deadline.finite())
      group->turn.wait(lock, free);
    else if (!group->turn.wait_until(lock, deadline.when(), free))
      return {};  // another thread kept the group for the whole timeout
    group->busy = true;
    // Right after answering, the next request needs the caller's turn first:
    // if the caller shares our CPU, let it have it before looking.
    yield_first = group->answered_last_turn;
  }
  int count = 0;
  struct EndOfTurn {
    Dispatcher& dispatcher;
    ServiceGroup& group;
    const int& count;
    ~EndOfTurn() {
      std::lock_guard<std::mutex> lock(dispatcher.mutex_);
      group.busy = false;
      group.answered_last_turn = count > 0;
      group.turn.notify_one();
    }
  } end_of_turn{*this, *group, count};

  epoll_event events[8];
  for (;;) {
    deliver_events(group, nullptr);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (group->pool && count == 0)
        return Status::failure(
            LNE_SVC_GRP_HANDLED_IN_POOL,
            "service group '" + group->name + "' is handled by thread pool '" + group->pool->name + "'");
      if (group->unblock_pending) {
        group->unblock_pending = false;
        break;
      }
    }
    if (count > 0) break;
    // Connections with requests left from their last turn do not wait for
    // epoll; the others' new requests are looked at first, without waiting.
    bool backlogged;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      backlogged = !group->events.backlog.empty();
    }
    const int n =
        wait_for_events(group->events.epoll_fd, events, 8, backlogged ? io::Deadline::at(io::Clock::now()) : deadline,
                        backlogged ? 0 : wait_.spin_us, yield_first);
    yield_first = false;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno_failure("epoll_wait", errno);
    for (int i = 0; i < n; ++i) {
      if (events[i].data.u64 == 0)
        group->events.consume();
      else if (events[i].data.u64 == timer_key)
        expire_queued_responses(group->events);
      else
        count += serve(events[i].data.u64);
    }
    if (backlogged) count += serve_backlog(group->events);
    if (n == 0 && !backlogged) break;
  }
  if (handled) *handled = count;
  return {};
}

Status Dispatcher::handle_in_pool(const char* group_name, const char* pool_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = nullptr;
  Status s = group_locked(group_name, group);
  ThreadPool* pool = nullptr;
  if (s.ok()) s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  if (group->pool == pool) return {};
  group->pool = pool;
  move_group_connections_locked(*group, pool->events.epoll_fd);
  group->events.wake();  // a thread in wait_and_handle() returns
  if (!group->observer_events.empty()) pool->events.wake();
  return {};
}

Status Dispatcher::remove_from_pool(const char* group_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = find_group_locked(group_name);
  if (group == nullptr)
    return Status::failure(LNE_SVC_GRP_UNKNOWN,
                           std::string("unknown service group '") + (group_name ? group_name : "") + "'");
  if (group->pool == nullptr) return {};
  group->pool = nullptr;
  move_group_connections_locked(*group, group->events.epoll_fd);
  group->events.wake();
  return {};
}

Status Dispatcher::unblock(const char* group_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = nullptr;
  Status s = group_locked(group_name, group);
  if (!s.ok()) return s;
  group->unblock_pending = true;
  group->events.wake();
  return {};
}

Status Dispatcher::set_max_threads(const char* pool_name, unsigned n_threads) {
  std::lock_guard<std::mutex> lock(mutex_);
  ThreadPool* pool = nullptr;
  Status s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  reap_finished_locked(*pool);
  const unsigned wanted = n_threads < 1 ? 1 : n_threads;
  if (wanted > pool->active) return start_threads_locked(*pool, wanted - pool->active);
  if (wanted < pool->active) {
    pool->retire_requests += pool->active - wanted;
    pool->active = wanted;
    pool->events.wake();
  }
  return {};
}

Status Dispatcher::set_pool_schedparam(const char* pool_name, int policy, int priority, unsigned affinity_mask) {
  std::lock_guard<std::mutex> lock(mutex_);
  ThreadPool* pool = nullptr;
  Status s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  const int old_policy = pool->policy, old_priority = pool->priority;
  const unsigned old_mask = pool->affinity_mask;
  pool->policy = policy;
  pool->priority = priority;
  pool->affinity_mask = affinity_mask;
  // All or nothing: after a failure (EPERM, EINVAL, ...) every thread and the
  // pool's settings for later threads are as they were.
  std::vector<std::pair<pthread_t, ThreadScheduling>> changed;
  for (PoolThread& t : pool->threads) {
    if (t.finished) continue;
    const pthread_t thread = t.thread.native_handle();
    changed.emplace_back(thread, scheduling_of(thread));
    s = apply_schedparam(*pool, thread);
    if (!s.ok()) {
      for (const auto& [changed_thread, before] : changed) restore_scheduling(changed_thread, before);
      pool->policy = old_policy;
      pool->priority = old_priority;
      pool->affinity_mask = old_mask;
      return s;
    }
  }
  return {};
}

Status Dispatcher::start_threads_locked(ThreadPool& pool, unsigned count) {
  for (unsigned i = 0; i < count; ++i) {
    pool.threads.emplace_back();
    PoolThread& entry = pool.threads.back();
    try {
      entry.thread = std::thread(&Dispatcher::pool_thread_main, this, &pool, &entry);
    } catch (const std::system_error& e) {
      pool.threads.pop_back();
      return errno_failure("thread pool '" + pool.name + "': starting a thread", e.code().value());
    }
    ++pool.active;
    // Best effort for threads started later; set_pool_schedparam() reports.
    apply_schedparam(pool, entry.thread.native_handle());
  }
  return {};
}

void Dispatcher::reap_finished_locked(ThreadPool& pool) {
  for (auto it = pool.threads.begin(); it != pool.threads.end();) {
    if (it->finished) {
      it->thread.join();  // it has left its loop; joining is immediate
      it = pool.threads.erase(it);
    } else {
      ++it;
    }
  }
}

void Dispatcher::pool_thread_main(ThreadPool* pool, PoolThread* self) {
  epoll_event event{};
  for (;;) {
    // One event at a time, so idle threads can take the other connections.
    const int n = wait_for_events(pool->events.epoll_fd, &event, 1, io::Deadline(), wait_.spin_us);
    if (n < 0 && errno != EINTR) break;
    if (n <= 0) continue;
    const std::uint64_t key = event.data.u64;
    bool leave = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      // The wake-up stays readable until every thread that must leave saw
      // it. A thread that must leave serves nothing more, so a shrunk pool
      // keeps its new limit at once.
      if (pool->stopping) {
        leave = true;
      } else if (pool->retire_requests > 0) {
        leave = true;
        if (--pool->retire_requests == 0) pool->events.consume();
      } else if (key == 0) {
        pool->events.consume();
      }
    }
    if (leave) {
      if (key != 0) rearm(key);  // its event goes to a thread that stays
      break;
    }
    if (key == 0) {
      deliver_events(nullptr, pool);
      serve_backlog(pool->events);
    } else if (key == timer_key) {
      expire_queued_responses(pool->events);
    } else {
      serve(key);
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  self->finished = true;
}

void Dispatcher::rearm(std::uint64_t key) {
  std::shared_ptr<ProviderConnection> connection;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = connections_.find(key);
    // A claimed connection is re-armed by the thread that claimed it.
    if (it == connections_.end() || it->second->claimed) return;
    if (arm_locked(*it->second).ok()) return;
    connection = it->second;
  }
  close_connection(connection);
}

}  // namespace ln::services
