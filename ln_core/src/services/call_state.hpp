// The caller side of services: one ServiceCaller per calling handle
// (ln_service), the asynchronous call in flight (ln_service_request on the
// caller side) and the reactor thread that progresses asynchronous calls.
//
// A blocking call flattens the request, writes it to the handle's own
// connection and reads the response in the calling thread itself - no
// thread hand-off - so its cost is one socket round trip plus the
// marshalling. It polls briefly before it sleeps (WaitPolicy), which saves
// the cross-core wake-up whenever the provider answers quickly. Asynchronous calls are written and read by the client's
// AsyncReactor thread; the response is unpacked into the caller's struct
// only when the program looks at the result (finished()/wait()), in its own
// thread, so a call aborted before that never writes into its data.
//
// Giving up on a call (timeout, abort) closes the connection: the provider
// sees its request aborted, and no late response can reach a later call.
// The next call connects again through the Connector. A provider that dies
// mid-call closes the connection too: the call fails at once with
// -LNE_SVC_RECV_RESP, never hangs.
//
// Every failure comes with a text that says why (last_error(),
// AsyncCall::error_message()): the provider's own explanation, or ours.
// A caller made for a named service starts each with "service 'NAME': ".
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>

#include "services/call_frames.hpp"
#include "services/call_log.hpp"
#include "services/marshal.hpp"
#include "services/request_handle.hpp"
#include "services/signature.hpp"
#include "services/status.hpp"

namespace ln::services {

/// A connected socket to a service's provider, past the `call` handshake,
/// and the id the provider knows the service by.
struct ProviderLink {
  int fd = -1;
  std::uint32_t service_id = 0;
};

/// Opens a ProviderLink; supplied by the client core (lookup_service at
/// the manager, connect to peer_socket or peer_address, `call` handshake).
/// Called from the calling thread whenever the handle has no usable
/// connection: on its first call, after a timeout or abort, after the
/// provider went away. The socket becomes the caller's.
using Connector = std::function<Status(ProviderLink& link)>;

struct CallerConnection;
class AsyncReactor;

/// An asynchronous call (what ln_service_request is on the caller side, as
/// to_handle(AsyncCall*)). Belongs to its ServiceCaller and is reused by
/// its next asynchronous call.
class AsyncCall : public RequestHandle {
 public:
  /// `context` starts every error message (e.g. "service 'x': ").
  AsyncCall(std::shared_ptr<const ServiceSignature> signature, const Limits& limits, std::string context = {});
  ~AsyncCall();
  AsyncCall(const AsyncCall&) = delete;
  AsyncCall& operator=(const AsyncCall&) = delete;

  /// ln_service_request_finished(): 0 still running, 1 finished (retval:
  /// 0, < 0 LN error, > 0 the provider's error; on success the response is
  /// now in the call's data), < 0 error (no call started).
  int finished(int* retval);
  /// ln_service_request_wait(): as finished(), waiting up to `timeout`
  /// seconds (< 0 without limit, 0 not at all).
  int wait(double timeout, int* retval);
  /// ln_service_request_abort(): the call ends with -LNE_SVC_REQ_ABORTED
  /// and the library does not write to its data any more.
  int abort();
  /// Readable once the call finished (until the next call starts).
  int notification_fd() const { return notify_fd_; }
  /// The provider's explanation of a failure, or ours; nullptr while
  /// running, after success or when there is none.
  const char* error_message() const;
  /// The flat response of a successful call (callv_async_get_response).
  std::string_view response() const;
  /// Unpacks the response into `data`, a complete service struct
  /// (callv_async_get_response_data); as finished()'s retval.
  int response_into(void* data);

  bool running() const;

 private:
  friend class ServiceCaller;
  friend class AsyncReactor;
  enum class State { Idle, Running, Finished };

  void start(void* data, std::shared_ptr<CallerConnection> connection, std::uint32_t request_id);
  // Reactor side: progress on readiness `events` of registration `key`.
  void on_ready(std::uint64_t key, std::uint32_t events);
  void finish_locked(int result, std::string text);
  int deliver_locked(int* retval);
  bool send_pending() const { return sent_ < frame_.size(); }

  const std::shared_ptr<const ServiceSignature> signature_;
  const Limits limits_;
  const std::string context_;
  int notify_fd_ = -1;

  mutable std::mutex mutex_;
  std::condition_variable done_;
  State state_ = State::Idle;
  void* data_ = nullptr;
  bool delivered_ = false;
  int result_ = 0;
  std::string error_;
  std::shared_ptr<CallerConnection> connection_;
  std::uint32_t request_id_ = 0;
  frames::FrameBuffer frame_;
  std::size_t sent_ = 0;
  frames::Payload response_;
  std::size_t body_offset_ = 0;
  Arena arena_;
  AsyncReactor* reactor_ = nullptr;
  std::uint64_t reactor_key_ = 0;
};

/// The thread that sends and receives for asynchronous calls; one per
/// client, started on first use.
class AsyncReactor {
 public:
  AsyncReactor() = default;
  ~AsyncReactor();
  AsyncReactor(const AsyncReactor&) = delete;
  AsyncReactor& operator=(const AsyncReactor&) = delete;

  /// Sends and receives for `call` until it finishes.
  Status watch(const std::shared_ptr<AsyncCall>& call);

 private:
  friend class AsyncCall;
  // Stops watching (called by the finishing call, holding its own mutex).
  void forget(std::uint64_t key, int fd);
  Status start_locked();
  void run();

  std::mutex mutex_;
  int epoll_fd_ = -1;
  int wake_fd_ = -1;
  bool stopping_ = false;
  std::thread thread_;
  std::unordered_map<std::uint64_t, std::shared_ptr<AsyncCall>> calls_;
  std::uint64_t next_key_ = 1;  // 0 is the wake-up descriptor
};

/// The calling side of one service handle.
class ServiceCaller {
 public:
  /// Blocking calls wait for the response as `wait` says; error texts name
  /// `service_name` if one is given.
  ServiceCaller(std::shared_ptr<const ServiceSignature> signature, Connector connector,
                std::shared_ptr<AsyncReactor> reactor, Limits limits = {}, WaitPolicy wait = {},
                const std::string& service_name = {});
  /// Aborts a running asynchronous call.
  ~ServiceCaller();
  ServiceCaller(const ServiceCaller&) = delete;
  ServiceCaller& operator=(const ServiceCaller&) = delete;

  /// ln_service_call_with_timeout(): request from data->req, response into
  /// data->resp (dynamic fields point into memory of this object, valid
  /// until its next call). `timeout` <= 0 waits without limit.
  /// @return 0, < 0 an LN error (-LNE_SVC_TIMEOUT, -LNE_SVC_REQ_ABORTED,
  ///         -LNE_SVC_REQ_RUNNING, -LNE_SVC_RECV_RESP, ...), > 0 the
  ///         provider's error. last_error() explains failures.
  int call(void* data, double timeout);
  /// ln_service_callv(): the request already flat (checked against the
  /// signature); the flat response is last_response() afterwards.
  int call_flat(std::string_view flat_request, double timeout);
  /// The flat response of the last successful call (until the next call).
  std::string_view last_response() const;
  /// ln_service_call_abort(): makes a blocking call running in another
  /// thread return -LNE_SVC_REQ_ABORTED; -LNE_SVC_REQ_NOT_RUNNING if none.
  int abort();
  /// ln_service_call_async(): starts a call; `data` must stay valid until
  /// it finished or was aborted. At most one call per handle at a time.
  int call_async(void* data, AsyncCall*& call);
  /// ln_service_callv_async().
  int call_flat_async(std::string_view flat_request, AsyncCall*& call);
  /// The detail of the last failed blocking call or call start.
  std::string last_error() const;
  /// Service logging: every request sent is reported to `log` (as a call
  /// of `interface`); its client id goes into the request frames. Set
  /// before the first call.
  void set_call_log(std::shared_ptr<CallLog> log, std::string interface);

 private:
  bool needs_data() const;
  int run_call(void* data, std::string_view flat_request, double timeout);
  int start_async(void* data, std::string_view flat_request, AsyncCall*& call);
  // Flattens the request into `frame` after the frame head; the head is
  // written once the connection (service id) is known.
  int build_request(const void* data, std::string_view flat_request, frames::FrameBuffer& frame);
  // The handle's connection, made if needed (`fresh` then). With
  // `resend_possible` an idle local connection is not checked first.
  int ensure_connection(std::shared_ptr<CallerConnection>& out, bool resend_possible, bool& fresh);
  void drop_connection(const std::shared_ptr<CallerConnection>& connection);
  int fail(int code, std::string detail);
  // The request frame's head; reports the request once it is sent.
  frames::RequestHead head_for(const CallerConnection& connection, std::uint32_t request_id) const;
  void log_sent(const frames::FrameBuffer& frame, const CallerConnection& connection, std::uint32_t request_id,
                double started, double sent) const;

  const std::shared_ptr<const ServiceSignature> signature_;
  const Connector connector_;
  const std::shared_ptr<AsyncReactor> reactor_;
  const Limits limits_;
  const WaitPolicy wait_;
  const std::string context_;  // starts every error text
  const std::string name_;
  std::shared_ptr<CallLog> log_;
  std::string interface_;

  std::mutex call_mutex_;  // one call (blocking, or the start of an asynchronous one) at a time
  mutable std::mutex state_mutex_;
  std::shared_ptr<CallerConnection> connection_;
  bool sync_running_ = false;
  bool abort_requested_ = false;
  std::string error_;
  std::shared_ptr<AsyncCall> async_;

  // Owned by the running blocking call; the response stays for the program.
  frames::FrameBuffer frame_;
  frames::Payload response_;
  std::size_t body_offset_ = 0;
  Arena arena_;
};

}  // namespace ln::services
