// The provider side of services: registered providers, the connections
// callers opened to them, service groups, thread pools and the requests
// being handled.
//
// Threads. The client core's peer server accepts a caller's connection and
// answers its `call` handshake; then it hands the socket over with
// adopt_connection() and never touches it again. From then on the socket is
// read by the thread that handles the provider's group - a thread inside
// wait_and_handle() or a pool thread - and requests run in that same thread.
// So a call costs no thread hand-off on the provider side: a hand-off (an I/O
// thread queueing requests for a handler thread) adds 1.5-5 µs per call on
// one core and would defeat the spin that makes split-core calls ~10x
// faster (service_rtt_bench --modes hop). Requests that wait for their
// group simply stay in their connection's socket: that is the group's
// queue, bounded by the kernel's socket buffers (a flood blocks the
// callers' sends instead of growing this process). Each group (and each
// pool) has an epoll set of its connections; in a pool's set a connection
// is armed one-shot, so of several pool threads exactly one reads it and
// serves its requests, in order, while other threads serve other
// connections. Every caller handle has a connection of its own, so "up to n
// concurrent requests" in a pool of n threads means up to n callers at a
// time. Serving threads wait as WaitPolicy says (spin briefly, then sleep).
//
// Callers that do not read. A response the caller's socket does not take
// within a millisecond is queued in its connection (in order with later
// ones) and written when the socket has room; meanwhile that connection's
// further requests are not handled (they wait in its socket). A queue that
// makes no progress for Limits::response_timeout_ms, or would grow beyond
// Limits::max_unread_responses, closes that connection. So a caller that
// does not read its answers holds up its own requests only, never the
// provider's thread or the other callers.
//
// Handler protocol (LN 2.9): the handler gets a Request (ln_service_request),
// copies the request out with set_data(), and answers with respond() (or
// respond_error()). Its return value then decides: answered -> done;
// -LNE_SVC_RESP_LATER unanswered -> the request lives on until someone
// answers it, from any thread; 0 unanswered -> the caller gets
// -LNE_SVC_HANDLER_NO_RESP; any other value unanswered -> the caller gets
// that value. Answering twice is -LNE_SVC_HANDLER_MULTI_RESP. A handler
// that throws (C++ registered through the C API) fails the call with
// -LNE_SVC_HANDLER_EXC and the exception's text.
//
// Aborts. A caller that gives up on a call closes its connection. Requests
// of a closed connection that did not start yet are dropped; running and
// deferred ones report is_aborted() and their response is discarded
// (respond() still succeeds). A connection that sends anything but
// well-framed requests is closed; the provider goes on serving the others.
// A request whose flat data does not match the signature is answered with
// -LNE_SVC_RECV_REQ without running the handler.
#pragma once

#include <pthread.h>

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include "services/call_frames.hpp"
#include "services/call_log.hpp"
#include "services/marshal.hpp"
#include "services/request_handle.hpp"
#include "services/signature.hpp"
#include "services/status.hpp"

namespace ln::services {

/// ln_service_handler: (ln_client, ln_service_request, user_data); the
/// request is to_handle(Request*) (request_handle.hpp).
using Handler = int (*)(void* client, void* request, void* user_data);
/// ln_service_fd_handler: (ln_client, ln_svc_client_event_t, fd, user_data).
using ConnectionObserver = void (*)(void* client, int event, int fd, void* user_data);

// Internals of dispatch.cpp.
struct Provider;
struct ProviderConnection;
struct EventSet;
struct ServiceGroup;
struct ThreadPool;
struct PoolThread;
class Dispatcher;

/// A request on the provider side; what ln_service_request points to while
/// it is handled. It ends when the handler returns, or - deferred with
/// -LNE_SVC_RESP_LATER - when it has been answered; the pointer is invalid
/// after that (so a second answer to a deferred request that was already
/// answered is a use after free, as in LN).
class Request : public RequestHandle {
 public:
  Request(const Request&) = delete;
  Request& operator=(const Request&) = delete;

  /// ln_service_request_set_data(): checks `signature` against the
  /// provider's (LNE_SVC_REQ_SET_DATA_WRONG) and fills data->req; dynamic
  /// fields point into memory of this request. Remembers `data` for
  /// respond().
  Status set_data(void* data, const char* signature);
  /// The flat request as received (ln_service_request_get_request_data).
  std::string_view request_data() const;
  /// Sends data->resp of the struct given to set_data(). Returns once the
  /// response is written to the connection, so dynamic response fields only
  /// need to live until then.
  Status respond();
  /// Sends the response part of `data`, a complete service struct.
  Status respond_data(const void* data);
  /// Sends an already flat response (ln_service_request_respondv); it is
  /// checked against the signature.
  Status respond_flat(std::string_view flat_response);
  /// Fails the call with `error` (> 0 the application's, < 0 an LN code;
  /// not 0 or -LNE_SVC_RESP_LATER) and an explanation for the caller.
  Status respond_error(int error, std::string_view message);
  /// Whether the caller gave up (aborted, timed out, disconnected).
  bool is_aborted() const;

 private:
  friend class Dispatcher;
  Request(Dispatcher& dispatcher, std::shared_ptr<Provider> provider, std::shared_ptr<ProviderConnection> connection,
          const frames::RequestHead& head, frames::Payload payload, const Limits& limits, std::shared_ptr<CallLog> log);
  ~Request() = default;
  // Sends the one answer: `result` 0 with the flat form of `host` (or of
  // `flat` if host is null), else an error with `text`.
  Status answer(int result, std::string_view text, const void* host, std::string_view flat);
  Status send_frame(int result, std::string_view text, const void* host, std::string_view flat);
  void handler_returned(int ret);

  Dispatcher& dispatcher_;
  const std::shared_ptr<Provider> provider_;
  const std::shared_ptr<ProviderConnection> connection_;
  const std::uint32_t request_id_;
  const std::uint32_t caller_id_;
  frames::Payload payload_;
  const Limits limits_;
  const std::shared_ptr<CallLog> log_;  // set while service logging is on
  double arrived_ = 0;                  // wall clock, when logging
  Arena arena_;
  void* data_ = nullptr;

  std::mutex mutex_;
  bool handler_running_ = true;
  bool answered_ = false;
  bool sending_ = false;
};

/// All providers of one client and the machinery that runs their handlers.
class Dispatcher {
 public:
  /// `client` is passed to handlers and observers as their ln_client.
  /// Serving threads wait for requests as `wait` says.
  explicit Dispatcher(void* client, Limits limits = {}, WaitPolicy wait = {});
  /// Stops the pools, closes every connection. No thread may be inside
  /// wait_and_handle() any more (ln_deinit's single-thread rule); one that
  /// still is gets unblocked and waited for.
  ~Dispatcher();
  Dispatcher(const Dispatcher&) = delete;
  Dispatcher& operator=(const Dispatcher&) = delete;

  // ---------------------------------------------------------------- providers

  /// Service logging: providers report every response they send to `log`.
  /// Set before the first provider is added.
  void set_call_log(std::shared_ptr<CallLog> log) { log_ = std::move(log); }

  /// Makes `service_id` (the manager's id for the registered service)
  /// callable; `group_name` nullptr is the default group.
  Status add_provider(std::uint32_t service_id, std::string name, std::shared_ptr<const ServiceSignature> signature,
                      Handler handler, void* user_data, const char* group_name);
  /// Closes the provider's connections and waits until none of its
  /// handlers runs any more (except the calling thread's own), so its
  /// user_data may be freed afterwards.
  Status remove_provider(std::uint32_t service_id);
  bool has_provider(std::uint32_t service_id) const;
  /// ln_service_provider_set_client_fd_handler(): `observer` learns of
  /// callers connecting (LN_NEW_SVC_CLIENT) and leaving
  /// (LN_REMOVE_SVC_CLIENT), in the thread that handles the group.
  Status set_connection_observer(std::uint32_t service_id, ConnectionObserver observer, void* user_data);
  /// ln_service_provider_get_fd(): readable while the provider's group
  /// (handled by wait_and_handle) has work. < 0 if unknown.
  int provider_fd(std::uint32_t service_id) const;

  // -------------------------------------------------------------- connections

  /// Takes over a caller's socket after the peer server answered its
  /// `call` handshake for `service_id` ok (check has_provider() before
  /// answering). The caller sends nothing before that ok, so the peer
  /// server has read nothing beyond the handshake. The socket is this
  /// object's from now on, also on failure (then it is closed).
  Status adopt_connection(int fd, std::uint32_t service_id);

  // ------------------------------------------------------- groups and pools

  /// ln_wait_and_handle_service_group_requests(): waits up to `timeout`
  /// seconds (< 0 without limit, 0 not at all) for requests of the group,
  /// handles all that have arrived, in this thread, and returns. Callers
  /// for one group take turns. `handled` (optional) counts the requests.
  Status wait_and_handle(const char* group_name, double timeout, int* handled = nullptr);
  /// The group's requests are served by the named pool from now on (the
  /// pool is created with one thread if needed).
  Status handle_in_pool(const char* group_name, const char* pool_name);
  /// The group's requests wait for wait_and_handle() again.
  Status remove_from_pool(const char* group_name);
  /// Makes wait_and_handle() for the group return now, or - if no thread
  /// waits - the next time it is called.
  Status unblock(const char* group_name);
  /// LN's meaning: 0 and 1 serve one request at a time (connection set-up
  /// always happens in the client core's peer server thread here, which is
  /// what 1 asks for), n >= 2 up to n requests at a time. Creates the pool.
  Status set_max_threads(const char* pool_name, unsigned n_threads);
  /// Scheduling of the pool's threads, now and for threads it starts later:
  /// `policy` (SCHED_*) and `priority` (-1 keeps each; a priority without
  /// policy keeps the thread's policy), CPU `affinity_mask` (bit i = CPU i;
  /// 0 keeps it). Errors (e.g. EPERM for real-time policies without the
  /// privilege, EINVAL) are returned as -LNE_CHECK_ERRNO with the errno, and
  /// then nothing has changed.
  Status set_pool_schedparam(const char* pool_name, int policy, int priority, unsigned affinity_mask);

 private:
  friend class Request;
  Status send_response(const std::shared_ptr<ProviderConnection>& connection, std::uint32_t request_id, int result,
                       std::string_view text, std::string_view body_flat, const MessageLayout* layout, const void* host,
                       std::size_t body_size);
  /// Closes the connections of `set` whose queued responses made no progress for response_timeout_ms.
  void expire_queued_responses(EventSet& set);
  /// Gives the connections whose last turn left requests their next turn.
  int serve_backlog(EventSet& set);
  Status group_locked(const char* name, ServiceGroup*& out);
  ServiceGroup* find_group_locked(const char* name);
  Status pool_locked(const char* name, ThreadPool*& out);
  void move_group_connections_locked(const ServiceGroup& group, int to_epoll);
  Status arm_locked(ProviderConnection& connection);
  void queue_event_locked(const std::shared_ptr<Provider>& provider, int event, int fd);
  void close_connection(const std::shared_ptr<ProviderConnection>& connection);
  std::shared_ptr<ProviderConnection> claim(std::uint64_t key);
  void release(const std::shared_ptr<ProviderConnection>& connection);
  void rearm(std::uint64_t key);
  int serve(std::uint64_t key);
  int serve_claimed(const std::shared_ptr<ProviderConnection>& connection);
  void handle_payload(const std::shared_ptr<ProviderConnection>& connection, frames::Payload payload);
  void run_handler(Request* request);
  void deliver_events(const ServiceGroup* only_group, const ThreadPool* only_pool);
  Status start_threads_locked(ThreadPool& pool, unsigned count);
  void reap_finished_locked(ThreadPool& pool);
  void pool_thread_main(ThreadPool* pool, PoolThread* self);

  void* const client_;
  std::shared_ptr<CallLog> log_;
  const Limits limits_;
  const WaitPolicy wait_;
  mutable std::mutex mutex_;
  std::condition_variable handlers_done_;
  std::unique_ptr<ServiceGroup> default_group_;
  std::map<std::string, std::unique_ptr<ServiceGroup>, std::less<>> groups_;
  std::map<std::string, std::unique_ptr<ThreadPool>, std::less<>> pools_;
  std::unordered_map<std::uint32_t, std::shared_ptr<Provider>> providers_;
  std::unordered_map<std::uint64_t, std::shared_ptr<ProviderConnection>> connections_;
  std::uint64_t next_connection_key_ = 1;  // 0 marks an event set's wake-up descriptor
};

}  // namespace ln::services
