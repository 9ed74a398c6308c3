#include "services/call_state.hpp"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <sstream>

#define NO_CPP_WRAPPER
#include "ln/ln.h"
#include "services/socket_io.hpp"

namespace ln::services {

struct CallerConnection {
  CallerConnection(int socket, std::uint32_t id, std::size_t max_payload)
      : fd(socket), service_id(id), local(is_unix_socket(socket)), assembler(max_payload) {}
  ~CallerConnection() { ::close(fd); }

  // Tells the provider at once that its request is abandoned, and makes
  // every later use of this connection fail.
  void give_up() {
    broken = true;
    ::shutdown(fd, SHUT_RDWR);
  }

  static bool is_unix_socket(int fd) {
    int domain = 0;
    socklen_t size = sizeof domain;
    return ::getsockopt(fd, SOL_SOCKET, SO_DOMAIN, &domain, &size) == 0 && domain == AF_UNIX;
  }

  const int fd;
  const std::uint32_t service_id;
  // A Unix socket: a request sent after the provider closed it fails at
  // once (EPIPE) instead of vanishing, as it can over TCP.
  const bool local;
  frames::FrameAssembler assembler;  // used by the one call in flight
  std::atomic<bool> broken{false};
};

namespace {

// Request ids are unique per process, not only per connection: with the
// caller's client id they name a call in service logs (as LN 2.9's do).
std::uint32_t new_request_id() {
  static std::atomic<std::uint32_t> last{0};
  std::uint32_t id = last.fetch_add(1, std::memory_order_relaxed) + 1;
  if (id == 0) id = last.fetch_add(1, std::memory_order_relaxed) + 1;  // 0 is never an id
  return id;
}

std::string describe(const io::Result& r, const char* while_doing) {
  switch (r.outcome) {
    case io::Outcome::Closed:
      return std::string("the provider closed the connection (it stopped or failed) ") + while_doing;
    case io::Outcome::Failed:
      return std::string("connection to the provider failed ") + while_doing + ": " + std::strerror(r.sys_errno);
    default:
      return std::string("unexpected data from the provider ") + while_doing;
  }
}

// What the caller learns of a failure the provider reported.
std::string provider_failure(int result, std::string_view text) {
  if (!text.empty()) return std::string(text);
  return "the provider failed the call with error " + std::to_string(result);
}

// 0.25 -> "0.25", 5 -> "5".
std::string seconds_text(double seconds) {
  std::ostringstream text;
  text << seconds;
  return text.str();
}

const char* const kAborted = "the call was aborted";

// The response body, validated for `data` (or as flat bytes if data is null).
Status take_response(const ServiceSignature& signature, frames::Payload& response, std::size_t body_offset, void* data,
                     const Limits& limits, Arena& arena) {
  char* body = response.data() + body_offset;
  const std::size_t size = response.size() - body_offset;
  Status s = data ? unflatten(signature.response(), body, size, static_cast<char*>(data) + signature.response_offset(),
                              limits, arena)
                  : check_flat(signature.response(), body, size, limits);
  if (s.ok()) return s;
  return Status::failure(LNE_SVC_RECV_RESP, "invalid response from the provider: " + s.detail());
}

// Parses a response frame that must answer request `request_id`.
Status parse_response_to(std::uint32_t request_id, const frames::Payload& response, frames::ResponseHead& head,
                         std::string_view& text, std::size_t& body_offset) {
  Status s = frames::parse_response(response, head, text, body_offset);
  if (s.ok() && head.request_id != request_id)
    s = Status::failure(LNE_SVC_RECV_RESP, "response to request " + std::to_string(head.request_id) + ", expected " +
                                               std::to_string(request_id));
  return s;
}

}  // namespace

// ------------------------------------------------------------- AsyncCall

void* to_handle(AsyncCall* call) { return static_cast<RequestHandle*>(call); }

AsyncCall* caller_request(void* handle) {
  auto* h = static_cast<RequestHandle*>(handle);
  return h != nullptr && h->side() == RequestHandle::Side::Caller ? static_cast<AsyncCall*>(h) : nullptr;
}

AsyncCall::AsyncCall(std::shared_ptr<const ServiceSignature> signature, const Limits& limits, std::string context)
    : RequestHandle(Side::Caller),
      signature_(std::move(signature)),
      limits_(limits),
      context_(std::move(context)),
      notify_fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}

AsyncCall::~AsyncCall() {
  if (notify_fd_ >= 0) ::close(notify_fd_);
}

bool AsyncCall::running() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_ == State::Running;
}

void AsyncCall::start(void* data, std::shared_ptr<CallerConnection> connection, std::uint32_t request_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::uint64_t drained = 0;
  [[maybe_unused]] const ssize_t n = ::read(notify_fd_, &drained, sizeof drained);
  state_ = State::Running;
  data_ = data;
  delivered_ = false;
  result_ = 0;
  error_.clear();
  connection_ = std::move(connection);
  request_id_ = request_id;
  sent_ = 0;
  response_ = frames::Payload();
  body_offset_ = 0;
  arena_.clear();
  reactor_ = nullptr;
  reactor_key_ = 0;
}

void AsyncCall::finish_locked(int result, std::string text) {
  if (reactor_) reactor_->forget(reactor_key_, connection_->fd);
  reactor_ = nullptr;
  reactor_key_ = 0;
  state_ = State::Finished;
  result_ = result;
  error_ = result != 0 ? context_ + text : std::string();
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(notify_fd_, &one, sizeof one);
  done_.notify_all();
}

void AsyncCall::on_ready(std::uint64_t key, std::uint32_t events) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ != State::Running || key != reactor_key_) return;
  CallerConnection& connection = *connection_;
  if ((events & EPOLLOUT) && send_pending()) {
    const io::Result r = io::send_some(connection.fd, frame_.data(), frame_.size(), sent_);
    if (r.outcome != io::Outcome::Done) {
      connection.give_up();
      finish_locked(-LNE_SVC_RECV_RESP, describe(r, "while the request was sent"));
      return;
    }
    if (!send_pending()) {
      epoll_event ev{};
      ev.events = EPOLLIN | EPOLLRDHUP;
      ev.data.u64 = key;
      ::epoll_ctl(reactor_->epoll_fd_, EPOLL_CTL_MOD, connection.fd, &ev);
    }
  }
  if (!(events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP | EPOLLERR))) return;
  Status malformed;
  const io::Result r = io::receive_available(connection.fd, connection.assembler, malformed);
  if (connection.assembler.next(response_)) {
    frames::ResponseHead head;
    std::string_view text;
    Status s = parse_response_to(request_id_, response_, head, text, body_offset_);
    if (s.ok() && head.result == 0) s = take_response(*signature_, response_, body_offset_, nullptr, limits_, arena_);
    if (!s.ok()) {
      connection.give_up();
      finish_locked(-LNE_SVC_RECV_RESP, s.detail());
    } else {
      finish_locked(head.result, head.result != 0 ? provider_failure(head.result, text) : std::string());
    }
    return;
  }
  if (r.outcome != io::Outcome::Done) {
    connection.give_up();
    finish_locked(-LNE_SVC_RECV_RESP, r.outcome == io::Outcome::Malformed
                                          ? "invalid data from the provider: " + malformed.detail()
                                          : describe(r, "before it responded"));
  }
}

int AsyncCall::deliver_locked(int* retval) {
  if (!delivered_) {
    delivered_ = true;
    if (result_ == 0 && data_ != nullptr) {
      // The response was checked on arrival; this can only run short of memory.
      const Status s = take_response(*signature_, response_, body_offset_, data_, limits_, arena_);
      if (!s.ok()) {
        result_ = s.code();
        error_ = context_ + s.detail();
      }
    }
  }
  if (retval) *retval = result_;
  return 1;
}

int AsyncCall::finished(int* retval) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ == State::Idle) return -LNE_SVC_REQ_NOT_RUNNING;
  if (state_ == State::Running) return 0;
  return deliver_locked(retval);
}

int AsyncCall::wait(double timeout, int* retval) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (state_ == State::Idle) return -LNE_SVC_REQ_NOT_RUNNING;
  const auto ended = [this] { return state_ != State::Running; };
  if (timeout < 0)
    done_.wait(lock, ended);
  else if (timeout > 0)
    done_.wait_for(lock, std::chrono::duration<double>(timeout), ended);
  if (state_ == State::Running) return 0;
  return deliver_locked(retval);
}

int AsyncCall::abort() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ == State::Idle) return -LNE_SVC_REQ_NOT_RUNNING;
  if (state_ == State::Running) {
    connection_->give_up();
    finish_locked(-LNE_SVC_REQ_ABORTED, kAborted);
  } else if (!delivered_) {
    // Finished, but the program has not looked: the response is dropped
    // unseen, so the data is never written after abort().
    delivered_ = true;
    result_ = -LNE_SVC_REQ_ABORTED;
    error_ = context_ + kAborted;
    response_ = frames::Payload();
  }
  return 0;
}

const char* AsyncCall::error_message() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ != State::Finished || result_ == 0 || error_.empty()) return nullptr;
  return error_.c_str();
}

std::string_view AsyncCall::response() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ != State::Finished || result_ != 0 || response_.empty()) return {};
  return {response_.data() + body_offset_, response_.size() - body_offset_};
}

int AsyncCall::response_into(void* data) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ == State::Idle) return -LNE_SVC_REQ_NOT_RUNNING;
  if (state_ == State::Running) return -LNE_SVC_REQ_RUNNING;
  if (result_ != 0) return result_;
  if (data == nullptr || response_.empty()) return -LNE_INVALID_PARAMETER;
  return take_response(*signature_, response_, body_offset_, data, limits_, arena_).code();
}

// ---------------------------------------------------------- AsyncReactor

AsyncReactor::~AsyncReactor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    if (wake_fd_ >= 0) {
      const std::uint64_t one = 1;
      [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof one);
    }
  }
  if (thread_.joinable()) thread_.join();
  if (epoll_fd_ >= 0) ::close(epoll_fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

Status AsyncReactor::start_locked() {
  if (thread_.joinable()) return {};
  if (epoll_fd_ < 0) epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (wake_fd_ < 0) wake_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (epoll_fd_ < 0 || wake_fd_ < 0)
    return Status::failure(LNE_CHECK_ERRNO, std::string("asynchronous calls: ") + std::strerror(errno), errno);
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = 0;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &ev) != 0 && errno != EEXIST)
    return Status::failure(LNE_CHECK_ERRNO, std::string("asynchronous calls: ") + std::strerror(errno), errno);
  try {
    thread_ = std::thread(&AsyncReactor::run, this);
  } catch (const std::system_error& e) {
    return Status::failure(LNE_CHECK_ERRNO, std::string("asynchronous calls: ") + e.what(), e.code().value());
  }
  return {};
}

Status AsyncReactor::watch(const std::shared_ptr<AsyncCall>& call) {
  std::lock_guard<std::mutex> call_lock(call->mutex_);
  if (call->state_ != AsyncCall::State::Running) return {};  // failed while being sent
  std::lock_guard<std::mutex> lock(mutex_);
  Status s = start_locked();
  if (!s.ok()) return s;
  const std::uint64_t key = next_key_++;
  epoll_event ev{};
  ev.events = EPOLLIN | EPOLLRDHUP | (call->send_pending() ? EPOLLOUT : 0u);
  ev.data.u64 = key;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, call->connection_->fd, &ev) != 0)
    return Status::failure(LNE_CHECK_ERRNO, std::string("asynchronous calls: epoll_ctl: ") + std::strerror(errno),
                           errno);
  calls_.emplace(key, call);
  call->reactor_ = this;
  call->reactor_key_ = key;
  return {};
}

void AsyncReactor::forget(std::uint64_t key, int fd) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (calls_.erase(key) != 0) ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
}

void AsyncReactor::run() {
  epoll_event events[16];
  for (;;) {
    const int n = ::epoll_wait(epoll_fd_, events, 16, -1);
    if (n < 0 && errno != EINTR) return;
    for (int i = 0; i < n; ++i) {
      const std::uint64_t key = events[i].data.u64;
      std::shared_ptr<AsyncCall> call;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (key == 0) {
          if (stopping_) return;
          continue;
        }
        const auto it = calls_.find(key);
        if (it != calls_.end()) call = it->second;
      }
      if (call) call->on_ready(key, events[i].events);
    }
  }
}

// --------------------------------------------------------- ServiceCaller

ServiceCaller::ServiceCaller(std::shared_ptr<const ServiceSignature> signature, Connector connector,
                             std::shared_ptr<AsyncReactor> reactor, Limits limits, WaitPolicy wait,
                             const std::string& service_name)
    : signature_(std::move(signature)),
      connector_(std::move(connector)),
      reactor_(std::move(reactor)),
      limits_(limits),
      wait_(wait),
      context_(service_name.empty() ? std::string() : "service '" + service_name + "': "),
      name_(service_name) {}

void ServiceCaller::set_call_log(std::shared_ptr<CallLog> log, std::string interface) {
  log_ = std::move(log);
  interface_ = std::move(interface);
}

frames::RequestHead ServiceCaller::head_for(const CallerConnection& connection, std::uint32_t request_id) const {
  return {connection.service_id, request_id, log_ ? log_->client_id() : 0};
}

void ServiceCaller::log_sent(const frames::FrameBuffer& frame, const CallerConnection& connection,
                             std::uint32_t request_id, double started, double sent) const {
  CallLog::Item item;
  item.service = name_;
  item.interface = interface_;
  item.caller_id = log_->client_id();
  item.request_id = request_id;
  item.flat = {frame.data() + frames::request_overhead, frame.size() - frames::request_overhead};
  item.completion_time = started;
  item.transfer_time = sent - started;
  item.fd = connection.fd;
  log_->record(item);
}

ServiceCaller::~ServiceCaller() {
  if (async_) async_->abort();
}

int ServiceCaller::fail(int code, std::string detail) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  error_ = context_ + detail;
  return code;
}

std::string ServiceCaller::last_error() const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return error_;
}

std::string_view ServiceCaller::last_response() const {
  if (response_.empty()) return {};
  return {response_.data() + body_offset_, response_.size() - body_offset_};
}

bool ServiceCaller::needs_data() const { return !signature_->request().empty() || !signature_->response().empty(); }

int ServiceCaller::call(void* data, double timeout) {
  if (data == nullptr && needs_data()) return fail(-LNE_INVALID_PARAMETER, "no service data given");
  return run_call(data, {}, timeout);
}

int ServiceCaller::call_flat(std::string_view flat_request, double timeout) {
  return run_call(nullptr, flat_request, timeout);
}

int ServiceCaller::abort() {
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (!sync_running_) return -LNE_SVC_REQ_NOT_RUNNING;
  abort_requested_ = true;
  // Wakes the blocked send or receive; the call then sees abort_requested_.
  if (connection_) connection_->give_up();
  return 0;
}

int ServiceCaller::build_request(const void* data, std::string_view flat_request, frames::FrameBuffer& frame) {
  const MessageLayout& layout = signature_->request();
  std::size_t body = 0;
  Status s = data ? flat_size(layout, data, limits_, body)
                  : check_flat(layout, flat_request.data(), flat_request.size(), limits_);
  if (!data) body = flat_request.size();
  if (s.ok() && body > limits_.max_data_size)
    s = Status::failure(LNE_PACKET_TOO_LARGE,
                        "request larger than the limit of " + std::to_string(limits_.max_data_size) + " bytes");
  if (!s.ok()) return fail(s.code(), "invalid request: " + s.detail());
  if (!frame.resize(frames::request_overhead + body))
    return fail(-LNE_NO_MEM, "no memory for a request of " + std::to_string(body) + " bytes");
  if (data)
    write_flat(layout, data, frame.data() + frames::request_overhead);
  else if (body > 0)
    std::memcpy(frame.data() + frames::request_overhead, flat_request.data(), body);
  return 0;
}

int ServiceCaller::ensure_connection(std::shared_ptr<CallerConnection>& out, bool resend_possible, bool& fresh) {
  std::shared_ptr<CallerConnection> connection;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    connection = connection_;
  }
  // A provider that went away since the last call (restarted, say) shows
  // as a closed idle connection: connect again instead of failing. One
  // poll() per call finds out - unless the caller can resend a request
  // refused by a closed local connection (see run_call()).
  const bool check_idle = connection && !(resend_possible && connection->local);
  if (connection && (connection->broken || (check_idle && io::idle_connection_spoiled(connection->fd)))) {
    drop_connection(connection);
    connection.reset();
  }
  fresh = !connection;
  if (!connection) {
    ProviderLink link;
    Status s = connector_ ? connector_(link) : Status::failure(LNE_NO_PROVIDER_FOUND, "no way to reach the provider");
    if (s.ok() && link.fd < 0) s = Status::failure(LNE_NO_PROVIDER_FOUND, "no connection to the provider");
    if (!s.ok()) return fail(s.code(), s.detail());
    const int on = 1;  // fails harmlessly on Unix sockets
    ::setsockopt(link.fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    connection =
        std::make_shared<CallerConnection>(link.fd, link.service_id, frames::max_payload_for(limits_.max_data_size));
  }
  std::lock_guard<std::mutex> lock(state_mutex_);
  connection_ = connection;
  if (sync_running_ && abort_requested_) {
    // abort() came before there was a connection to shut down.
    connection->give_up();
    connection_.reset();
    error_ = context_ + kAborted;
    return -LNE_SVC_REQ_ABORTED;
  }
  out = std::move(connection);
  return 0;
}

void ServiceCaller::drop_connection(const std::shared_ptr<CallerConnection>& connection) {
  connection->give_up();
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (connection_ == connection) connection_.reset();
}

int ServiceCaller::run_call(void* data, std::string_view flat_request, double timeout) {
  std::lock_guard<std::mutex> turn(call_mutex_);
  if (async_ && async_->running())
    return fail(-LNE_SVC_REQ_RUNNING, "an asynchronous call is still running on this handle");
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    sync_running_ = true;
    abort_requested_ = false;
  }
  struct EndOfCall {
    ServiceCaller& caller;
    ~EndOfCall() {
      std::lock_guard<std::mutex> lock(caller.state_mutex_);
      caller.sync_running_ = false;
    }
  } end_of_call{*this};

  // LN: the previous response's dynamic fields are valid until this call.
  response_ = frames::Payload();
  arena_.clear();
  const io::Deadline deadline = io::Deadline::after_seconds(timeout);

  int rc = build_request(data, flat_request, frame_);
  if (rc != 0) return rc;
  std::shared_ptr<CallerConnection> connection;
  std::uint32_t request_id = 0;
  io::Result r;
  bool logging = false;
  double started = 0;
  for (bool first_attempt = true;; first_attempt = false) {
    bool fresh = false;
    rc = ensure_connection(connection, first_attempt, fresh);
    if (rc != 0) return rc;
    logging = log_ && log_->enabled();  // a new connection's lookup may have just named the loggers
    request_id = new_request_id();
    frames::write_request_head(frame_.data(), head_for(*connection, request_id),
                               frame_.size() - frames::request_overhead);
    if (logging) started = wall_clock_seconds();
    r = io::send_all(connection->fd, frame_.data(), frame_.size(), deadline);
    // A local connection the provider closed while it was idle refuses the
    // request (EPIPE): no provider has seen it (a frame is only handled
    // once complete), so it goes out once more, on a new connection. (One
    // we shut down ourselves, for abort(), is `broken`.)
    if (r.outcome == io::Outcome::Closed && !fresh && first_attempt && connection->local && !connection->broken) {
      drop_connection(connection);
      continue;
    }
    break;
  }
  if (logging && r.outcome == io::Outcome::Done)
    log_sent(frame_, *connection, request_id, started, wall_clock_seconds());
  Status malformed;
  if (r.outcome == io::Outcome::Done)
    r = io::receive_frame(connection->fd, connection->assembler, deadline, response_, malformed, wait_.spin_us);
  if (r.outcome != io::Outcome::Done) {
    drop_connection(connection);
    response_ = frames::Payload();
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      if (abort_requested_) {
        error_ = context_ + kAborted;
        return -LNE_SVC_REQ_ABORTED;
      }
    }
    if (r.outcome == io::Outcome::Timeout)
      return fail(-LNE_SVC_TIMEOUT, "no response within " + seconds_text(timeout) + " s");
    if (r.outcome == io::Outcome::Malformed)
      return fail(-LNE_SVC_RECV_RESP, "invalid data from the provider: " + malformed.detail());
    return fail(-LNE_SVC_RECV_RESP, describe(r, "before it responded"));
  }

  frames::ResponseHead head;
  std::string_view text;
  Status s = parse_response_to(request_id, response_, head, text, body_offset_);
  if (!s.ok()) {
    drop_connection(connection);
    response_ = frames::Payload();
    return fail(-LNE_SVC_RECV_RESP, s.detail());
  }
  if (head.result != 0) {
    const int result = head.result;
    std::string why = provider_failure(result, text);
    response_ = frames::Payload();
    return fail(result, std::move(why));
  }
  s = take_response(*signature_, response_, body_offset_, data, limits_, arena_);
  if (!s.ok()) {
    response_ = frames::Payload();
    return fail(s.code(), s.detail());
  }
  return 0;
}

int ServiceCaller::call_async(void* data, AsyncCall*& call) {
  if (data == nullptr && needs_data()) return fail(-LNE_INVALID_PARAMETER, "no service data given");
  return start_async(data, {}, call);
}

int ServiceCaller::call_flat_async(std::string_view flat_request, AsyncCall*& call) {
  return start_async(nullptr, flat_request, call);
}

int ServiceCaller::start_async(void* data, std::string_view flat_request, AsyncCall*& call) {
  std::unique_lock<std::mutex> turn(call_mutex_, std::try_to_lock);
  if (!turn.owns_lock()) return fail(-LNE_SVC_REQ_RUNNING, "a blocking call is running on this handle");
  if (async_ && async_->running())
    return fail(-LNE_SVC_REQ_RUNNING, "an asynchronous call is still running on this handle");
  if (!reactor_) return fail(-LNE_NOT_YET_IMPLEMENTED, "asynchronous calls need a reactor");
  if (!async_) {
    async_ = std::make_shared<AsyncCall>(signature_, limits_, context_);
    if (async_->notify_fd_ < 0) {
      const int err = errno;
      async_.reset();
      return fail(-LNE_CHECK_ERRNO, std::string("eventfd: ") + std::strerror(err));
    }
  }
  // The call is not running, so neither the reactor nor the program touch it.
  int rc = build_request(data, flat_request, async_->frame_);
  if (rc != 0) return rc;
  std::shared_ptr<CallerConnection> connection;
  bool fresh = false;
  rc = ensure_connection(connection, false, fresh);
  if (rc != 0) return rc;
  const std::uint32_t request_id = new_request_id();
  frames::write_request_head(async_->frame_.data(), head_for(*connection, request_id),
                             async_->frame_.size() - frames::request_overhead);
  // Logged when started: the reactor may still be sending the tail of a big one.
  if (log_ && log_->enabled()) {
    const double now = wall_clock_seconds();
    log_sent(async_->frame_, *connection, request_id, now, now);
  }
  async_->start(data, connection, request_id);
  {
    // Small requests go out at once; the reactor sends the rest of big ones.
    std::lock_guard<std::mutex> lock(async_->mutex_);
    const io::Result r = io::send_some(connection->fd, async_->frame_.data(), async_->frame_.size(), async_->sent_);
    if (r.outcome != io::Outcome::Done) {
      connection->give_up();
      async_->finish_locked(-LNE_SVC_RECV_RESP, describe(r, "while the request was sent"));
    }
  }
  Status s = reactor_->watch(async_);
  if (!s.ok()) {
    async_->abort();
    return fail(s.code(), s.detail());
  }
  call = async_.get();
  return 0;
}

}  // namespace ln::services
