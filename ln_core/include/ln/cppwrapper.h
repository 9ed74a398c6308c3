/// @file ln/cppwrapper.h
/// @brief The C++ API of ln_core (namespace ln), source-compatible with
///        Links and Nodes 2.9.
///
/// A thin layer over the C API of ln/ln.h, implemented inline
/// (ln/cppwrapper_impl.h) so that it needs no C++ ABI from the library.
/// Including <ln/ln.h> from C++ includes this header too.
///
/// Rules of the wrapper:
/// - Failures throw ln::exception, which carries the LN error code and the
///   text of ln_format_error() plus the client's ln_get_error_message().
///   Destructors never throw.
/// - An ln::client owns everything created through it: ports, services,
///   multi-waiters, loggers and event connections are returned as plain
///   pointers, stay valid until released through the client (unpublish,
///   unsubscribe, release_service, disconnect_from_event) or until the client
///   is destroyed, and must not be deleted by the program.
/// - Threads: as for the C API. Set-up calls (constructing a client,
///   publish, subscribe, get_service, do_register, ...) from one thread at a
///   time; reading, writing, calling and responding from any thread.
/// - Exceptions thrown by a program's handlers (service, event and
///   availability handlers) never propagate into the library: a throwing
///   service handler fails the call with LNE_SVC_HANDLER_EXC and the
///   exception text; other handlers' exceptions are reported through
///   ln_debug() and dropped.
///
/// Members marked "ln_core" are extensions beyond LN 2.9 (see
/// LN_CORE_EXTENSIONS in ln/ln.h). Requires C++11 or newer.
#ifndef LN_CPPWRAPPER_H
#define LN_CPPWRAPPER_H

#include "ln.h"

// LN 2.9 programs and the headers ln_generate writes rely on <ln/ln.h>
// providing memset, fprintf/stderr, malloc/free, std::string and friends.
#include <errno.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cstdint>
#include <exception>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#if defined(__GNUC__) || defined(__clang__)
#define LN_PRINTF_FORMAT(format_index, first_arg) __attribute__((format(printf, format_index, first_arg)))
#else
#define LN_PRINTF_FORMAT(format_index, first_arg)
#endif

namespace ln {

namespace parameters {
class parameter_proxy;
}

class client;
class port_base;
class outport;
class inport;
class borrowed_sample;
class multi_waiter;
class service;
class service_request;
class service_future;
class logger;
class logger_data;
class event_connection;
class event_call;

/// ln_core: sequence number, loss count and timestamp of a read packet (see
/// ln_sample_info in ln/ln.h).
typedef ln_sample_info sample_info;

/// The exception every wrapper method throws on failure.
class exception : public std::exception {
 public:
  /// Full description: what failed, the LN error text and the detail the
  /// manager or the service provider sent. what() returns it.
  std::string msg;
  /// The LN error code; LNE_UNKNOWN when the failure has none;
  /// LNE_USER_DEFINED_ERROR when a service provider's handler failed with
  /// its own code.
  ln_error_t error;
  /// Additional number, 0 unless: error is LNE_CHECK_ERROR_CODE (then an
  /// errno value), or (ln_core) error is LNE_USER_DEFINED_ERROR (then the
  /// provider's own error code).
  int error_code;

  exception(const std::string& message)  // NOLINT: implicit as in LN 2.9
      : msg(message), error(LNE_UNKNOWN), error_code(0) {}
  exception(const std::string& message, ln_error_t code) : msg(message), error(code), error_code(0) {}
  exception(const std::string& message, ln_error_t code, int number) : msg(message), error(code), error_code(number) {}

  const char* what() const noexcept override { return msg.c_str(); }
};

/// A mutex (kept from LN 2.9; new code can use std::mutex). Satisfies
/// Lockable, so std::lock_guard<ln::mutex_t> works.
class mutex_t {
 public:
  mutex_t() = default;
  mutex_t(const mutex_t&) = delete;
  mutex_t& operator=(const mutex_t&) = delete;

  void lock() { mutex_.lock(); }
  void unlock() { mutex_.unlock(); }
  bool try_lock() { return mutex_.try_lock(); }

 private:
  std::mutex mutex_;
};

/// Holds a mutex_t for its lifetime (kept from LN 2.9); does nothing when
/// constructed with invalid_mutex = true.
class mutex_holder {
 public:
  explicit mutex_holder(mutex_t& mutex, bool invalid_mutex = false) : mutex_(mutex), engaged_(!invalid_mutex) {
    if (engaged_) mutex_.lock();
  }
  ~mutex_holder() {
    if (engaged_) mutex_.unlock();
  }
  mutex_holder(const mutex_holder&) = delete;
  mutex_holder& operator=(const mutex_holder&) = delete;

 private:
  mutex_t& mutex_;
  bool engaged_;
};

/// One event delivered to an event handler (see client::connect_to_event).
/// Only valid during the handler.
class event_call {
 public:
  event_connection* connection;  ///< the connection the event arrived on
  ln_event_call& call;           ///< the C handle

  /// Unpacks the event into @p host_ptr, the generated `X_call_t` struct;
  /// @p call_signature is the generated `x_call_signature`. Dynamic fields
  /// point into library memory valid during the handler.
  void set_data(void* host_ptr, const char* call_signature);
  /// Raw event bytes (valid during the handler).
  void* get_buffer(uint32_t* len);

 private:
  friend class event_connection;
  event_call(event_connection* arrived_on, ln_event_call& handle);
};

/// A subscription to an event source; created by client::connect_to_event,
/// owned by the client, ended by client::disconnect_from_event.
class event_connection {
 public:
  /// Handler of incoming events; runs in the thread that handles the
  /// client's default service group.
  typedef void (*handler_t)(event_call& call, void* user_data);

  client* clnt;
  std::string event_name;
  ln_event_connection conn;  ///< the C handle
  unsigned int id;           ///< client-unique id

  event_connection(const event_connection&) = delete;
  event_connection& operator=(const event_connection&) = delete;

 private:
  friend class client;
  event_connection(client* owner, const std::string& name, const std::string& connect_signature, void* connect_data,
                   uint32_t connect_data_len, handler_t handler, void* user_data, bool is_flat);
  ~event_connection();
  static void dispatch(ln_client, ln_event_call call, void* self);

  handler_t handler_;
  void* user_data_;
};

/// ln_core: a topic the manager knows (client::list_topics(); see
/// ln_topic_info).
struct topic_info {
  std::string name;
  std::string message_definition;
  std::string hash;
  unsigned int message_size;
  std::string publisher;  ///< client name of the publisher, "" if none
  unsigned int subscribers;
  uint64_t packets;  ///< packets the publisher wrote, as it last reported
  double rate;       ///< packets per second over its last report interval; 0 when idle
};

/// ln_core: a registered client (client::list_clients(); see ln_client_info).
struct client_info {
  std::string name;
  int64_t id;
  int64_t pid;
  std::string host;
  std::string host_id;
  std::vector<std::string> published;   ///< topic names, sorted
  std::vector<std::string> subscribed;  ///< topic names, sorted
  std::vector<std::string> services;    ///< provided service names, sorted
};

/// ln_core: a registered service (client::list_services(); see
/// ln_service_info).
struct service_info {
  std::string name;
  std::string interface;
  std::string signature;
  std::string provider;
  std::string group;  ///< "" for none
};

/// ln_core: the manager itself (client::get_manager_status(); see
/// ln_manager_status).
struct manager_status {
  std::string version;
  int64_t pid;
  std::string address;  ///< "IP:PORT"
  double uptime;        ///< seconds
  unsigned int clients;
  unsigned int topics;
  unsigned int services;
  std::vector<std::string> message_definition_dirs;  ///< in search order
};

/// A connection to the ln_manager; see ln_init() for how the manager and the
/// client name are found. Owns everything created through it. Not copyable.
class client {
 public:
  /// ln_core: receives name and new state of a watched service or topic.
  typedef std::function<void(const std::string& name, bool available)> availability_handler_t;

  ln_client clnt;    ///< the C handle
  std::string name;  ///< the name the manager granted (may differ from the requested one)

  /// Connects using LN_MANAGER. Throws on failure.
  explicit client(std::string client_name);
  /// Same as client(std::string). Exists so that `client(argv[0])` does not
  /// pick the wrapping constructor client(ln_client) (ln_core).
  explicit client(const char* client_name);
  /// Connects using the LN options in argv (--ln-manager HOST:PORT, ...),
  /// falling back to LN_MANAGER. get_remaining_args() returns the rest.
  client(std::string client_name, int argc, char* argv[]);
  /// Connects to the manager at "HOST:PORT"; LN_MANAGER only when empty.
  client(std::string client_name, std::string ln_manager);
  /// Wraps an existing C client without taking ownership: the destructor
  /// releases what was created through this wrapper, but not the client.
  explicit client(ln_client existing);
  /// Releases all ports, services, waiters, loggers and event connections
  /// and, if owned, disconnects.
  ~client();

  client(const client&) = delete;
  client& operator=(const client&) = delete;

  /// Command-line arguments not consumed by LN, argv[0] included.
  std::vector<std::string> get_remaining_args();
  /// Round-trip time to the manager in seconds; timeout -1 waits without
  /// limit, 0 only checks the connection.
  double ping(double timeout = -1);

  /// Human-readable description of a message definition.
  std::string describe_message_definition(std::string message_definition_name);
  /// Definition text, message size, hash and flattened text of a message
  /// definition (flat text empty if the manager cannot provide it).
  void get_message_definition(std::string message_definition_name, std::string& message_definition,
                              unsigned int& message_size, std::string& hash, std::string& flat_message_definition);
  /// Definition text, message size and hash of a message definition.
  void get_message_definition(std::string message_definition_name, std::string& message_definition,
                              unsigned int& message_size, std::string& hash);
  /// Definition text and message size (deprecated in LN 2.9).
  void get_message_definition(std::string message_definition_name, std::string& message_definition,
                              unsigned int& message_size);
  /// Message definition name, text, size and hash of a known topic.
  void get_message_definition_for_topic(std::string topic_name, std::string& message_definition_name,
                                        std::string& message_definition, unsigned int& message_size, std::string& hash);
  /// Message definition name, text and size of a known topic (deprecated in
  /// LN 2.9).
  void get_message_definition_for_topic(std::string topic_name, std::string& message_definition_name,
                                        std::string& message_definition, unsigned int& message_size);
  /// Hands a definition text to the manager; returns the name it is stored
  /// under.
  std::string put_message_definition(std::string message_definition_name, std::string message_definition);
  /// Interface, definition text and signature of a registered service.
  void get_service_signature_for_service(std::string service_name, std::string& service_interface,
                                         std::string& service_definition, std::string& service_signature);
  /// Definition text and signature of a service interface.
  void get_service_signature(std::string service_interface, std::string& service_definition,
                             std::string& service_signature);
  /// Byte offset and length of a member ("a.b[2]") in a message.
  void locate_member_in_message_definition(std::string message_definition_name, std::string member,
                                           unsigned int& member_offset, unsigned int& member_byte_len);

  /// Becomes the publisher of a topic (see ln_publish_with_buffers()).
  /// @p message_def_name may carry "|HASH" (generated *_MD_NAME).
  outport* publish(std::string topic_name, std::string message_def_name, unsigned int buffers = 1);
  /// Stops publishing and releases the port.
  void unpublish(outport* port);

  /// Subscribes to a topic (see ln_subscribe_with_buffers()).
  /// @param rate -1 every packet; > 0 at most that many per second;
  ///        RATE_ON_REQUEST_LAST (-2) for sporadic on-demand reads.
  /// @param need_reliable_transport across hosts: TCP instead of UDP.
  inport* subscribe(std::string topic_name, std::string message_def_name, double rate = -1, unsigned int buffers = 1,
                    bool need_reliable_transport = false);
  /// Ends the subscription and releases the port.
  void unsubscribe(inport* port);

  /// A new multi-waiter owned by this client.
  multi_waiter* get_multi_waiter();

  /// Throws ln::exception describing @p ret (a -LNE_* code) for a failure
  /// described by @p message, with this client's error detail (ln_core;
  /// replaces LN 2.9's std::string-format variant).
  [[noreturn]] void throw_error(int ret, const std::string& message);
  /// Throws ln::exception describing @p ret with a printf-style message.
  [[noreturn]] void throw_error(int ret, const char* format, ...) LN_PRINTF_FORMAT(3, 4);
  /// Throws ln::exception (LNE_UNKNOWN) with a printf-style message.
  [[noreturn]] void throw_error(const char* format, ...) LN_PRINTF_FORMAT(2, 3);
  /// Throws ln::exception for an errno-style value (LNE_CHECK_ERROR_CODE,
  /// error_code = retval).
  [[noreturn]] static void throw_retval_error(int retval, const char* format, ...) LN_PRINTF_FORMAT(2, 3);
  /// As throw_error(int, const char*, ...) without client detail.
  [[noreturn]] static void throw_error_no_client(int ret, const char* format, ...) LN_PRINTF_FORMAT(2, 3);

  /// Waits for requests to the providers of a group and handles them in
  /// this thread, one at a time (see ln_wait_and_handle_service_group_requests()).
  /// @param group_name nullptr is the default group.
  /// @param timeout -1 blocks, 0 handles what is pending, > 0 seconds.
  void wait_and_handle_service_group_requests(const char* group_name, double timeout = -1);
  /// Lets a thread pool (created with one thread on first use) handle a
  /// group; its handlers may then run concurrently.
  void handle_service_group_in_thread_pool(const char* group_name, std::string pool_name);
  /// Takes a group back from its thread pool.
  void remove_service_group_from_thread_pool(const char* group_name);
  /// Makes a thread waiting for requests of this group return.
  void unblock_service_group(const char* group_name);
  /// Thread-pool size: 0 strictly one request at a time; 1 one at a time
  /// but connections accepted in a thread of their own; n >= 2 up to n
  /// requests concurrently.
  void set_max_threads(std::string pool_name, unsigned int n_threads);
  /// Scheduling policy, priority (-1: unchanged) and CPU affinity mask (0:
  /// unchanged) of a pool's threads.
  void thread_pool_setschedparam(std::string pool_name, int policy = -1, int priority = -1,
                                 unsigned int affinity_mask = 0);

  /// A handle for calling a service. @p signature is the generated
  /// *_SIGNATURE; @p service_interface its message definition name.
  service* get_service(std::string service_name, std::string service_interface, std::string signature);
  /// A handle for providing a service: set_handler() then do_register().
  service* get_service_provider(std::string service_name, std::string service_interface, std::string signature);
  /// Releases a service handle; a provider is unregistered first.
  void release_service(service* svc);

  /// Asks the manager to start a provider of this service or topic if there
  /// is none (see ln_needs_provider()). timeout -1 blocks, 0 only asks.
  void needs_provider(std::string service_or_topic_name, double timeout = -1);

  /// The topic logger of that name (created on first use; owned by the
  /// client).
  logger* get_logger(std::string logger_name);

  /// Names of the services registered with an interface, one per line.
  std::string find_services_with_interface(std::string interface_name);

  /// Connects to an event source. @p event_connect_signature is the
  /// generated *_CONNECT_SIGNATURE, @p connect_data the *_connect_t struct.
  event_connection* connect_to_event(std::string event_name, std::string event_connect_signature, void* connect_data,
                                     event_connection::handler_t handler, void* user_data = nullptr);
  /// As connect_to_event() with the connect data already flattened.
  event_connection* connect_to_event_flat(std::string event_name, std::string event_connect_signature,
                                          void* connect_data_flat, uint32_t connect_data_flat_len,
                                          event_connection::handler_t handler, void* user_data = nullptr);
  /// Disconnects and releases an event connection.
  void disconnect_from_event(event_connection* conn);

  /// Allows set-up calls from several threads (see ln_client_set_thread_safe()).
  void set_thread_safe(bool enable);

  /// Makes a service this client provides (ln/log_service) the logger of
  /// the services matching the comma-separated patterns (see
  /// ln_register_as_service_logger()).
  void register_as_service_logger(std::string logger_service_name, std::string service_name_patterns_to_log);
  /// Sets a client setting (see ln_client_set_float_parameter()); throws
  /// for unknown names and invalid values.
  void set_float_parameter(std::string parameter_name, float value);

  /// The parameters other clients provide below @p group_prefix; include
  /// ln/parameter_client.h (which defines it) to use it.
  parameters::parameter_proxy get_parameters(std::string group_prefix = "", bool strict_type_checks = false);

  /// ln_core: waits until a provider of @p service_name is registered
  /// (never starts one). timeout < 0 waits without limit, 0 only checks.
  /// @return true if a provider is registered.
  bool wait_for_service(const std::string& service_name, double timeout = -1);

  /// ln_core: calls @p handler whenever a provider of @p service_name
  /// appears or disappears, and once right away with the current state. It
  /// runs in a library thread and must return quickly. One handler per name;
  /// a new one replaces it, an empty std::function removes it.
  void set_service_availability_handler(const std::string& service_name, availability_handler_t handler);
  /// ln_core: as set_service_availability_handler() for the publisher of a
  /// topic.
  void set_publisher_availability_handler(const std::string& topic_name, availability_handler_t handler);

  /// ln_core: the topics the manager knows, in the order they appeared.
  std::vector<topic_info> list_topics();
  /// ln_core: the registered clients, in the order they registered.
  std::vector<client_info> list_clients();
  /// ln_core: the registered services, in the order they registered.
  std::vector<service_info> list_services();
  /// ln_core: version, pid, address, uptime, counts and definition search
  /// path of the manager.
  manager_status get_manager_status();

 private:
  friend class service;
  friend class event_connection;
  struct availability_slot;
  typedef std::map<std::string, std::unique_ptr<availability_slot>> availability_slots;

  void connect_with(int ret);
  void forget(service* svc);
  void set_availability_handler(bool for_service, const std::string& watched_name, availability_handler_t handler);
  static void dispatch_availability(ln_client, const char* watched_name, int available, void* slot);

  bool owns_client_;
  std::mutex mutex_;  // guards the containers below
  std::list<outport*> outports_;
  std::list<inport*> inports_;
  std::list<multi_waiter*> multi_waiters_;
  std::list<service*> services_;
  std::map<std::string, logger*> loggers_;
  std::map<unsigned int, event_connection*> event_connections_;
  availability_slots service_watches_;
  availability_slots publisher_watches_;
  // Replaced handlers are kept until the client goes, because a replacement
  // may happen from inside the very handler being replaced.
  std::list<std::unique_ptr<availability_slot>> retired_watches_;
};

/// What input and output ports have in common.
class port_base {
 public:
  client* clnt;  ///< owning client
  std::string topic_name;
  std::string topic_md;       ///< message definition name as given
  unsigned int message_size;  ///< bytes per packet
  std::string msg_def_hash;   ///< hash of the message definition

  explicit port_base(client* owner) : clnt(owner), message_size(0) {}
};

/// The publisher end of a topic; created by client::publish().
class outport : public port_base {
 public:
  ln_outport port;  ///< the C handle

  /// Publishes message_size bytes from @p data, timestamped with
  /// ln_get_time(). Never blocks. Throws on failure.
  void write(void* data);
  /// Publishes with an explicit timestamp in seconds (used by rate-limited
  /// subscribers).
  void write(void* data, double timestamp);
  /// Buffer the next write() publishes from; fill it in place and pass it
  /// to write() to save a copy.
  void* get_next_buffer(unsigned int* buffer_len);
  /// Number of subscribers; 0 also when it cannot be determined.
  unsigned int has_subscriber();

  outport(const outport&) = delete;
  outport& operator=(const outport&) = delete;

 private:
  friend class client;
  outport(client* owner, const std::string& topic, const std::string& md_name, unsigned int buffers);
  ~outport();
};

/// The subscriber end of a topic; created by client::subscribe().
class inport : public port_base {
 public:
  ln_inport port;    ///< the C handle
  double timestamp;  ///< publisher timestamp of the last packet read (0 before)

  /// Copies the next unread packet into @p data (message_size bytes).
  /// @param blocking true waits until one arrives, false returns at once.
  /// @return true if a new packet was copied; false leaves @p data
  ///         untouched. Throws on failure, also with LNE_PORT_UNBLOCKED when
  ///         unblock() ended the wait.
  bool read(void* data, bool blocking = true);
  /// As read(void*, bool), waiting at most @p timeout seconds; <= 0 does not
  /// wait.
  bool read(void* data, double timeout);
  /// True while the topic has a publisher.
  bool has_publisher();
  /// Makes a read blocked on this port in another thread end (it throws
  /// with LNE_PORT_UNBLOCKED).
  void unblock();

  /// ln_core: read() that also reports sequence number and loss.
  /// @param timeout < 0 waits without limit, 0 polls, > 0 seconds (note:
  ///        unlike read(void*, double), a negative timeout blocks).
  /// @param info filled when a packet was copied; may be nullptr.
  bool read(void* data, double timeout, sample_info* info);
  /// ln_core: zero-copy read. Lends the next unread packet in place (see
  /// ln_read_borrow()); the loan ends when the returned object is destroyed
  /// or released. One loan per port at a time.
  /// @param timeout < 0 waits without limit, 0 polls, > 0 seconds.
  /// @return an empty borrowed_sample if no packet arrived in time.
  borrowed_sample borrow(double timeout = -1);

  inport(const inport&) = delete;
  inport& operator=(const inport&) = delete;

 private:
  friend class client;
  inport(client* owner, const std::string& topic, const std::string& md_name, double rate, unsigned int buffers,
         bool need_reliable_transport);
  ~inport();
};

/// ln_core: a packet lent by inport::borrow(), readable in place until this
/// object is destroyed or release() is called; the publisher keeps writing
/// meanwhile without touching it. Move-only. Must not outlive its port.
class borrowed_sample {
 public:
  borrowed_sample() noexcept = default;  ///< empty: nothing lent
  borrowed_sample(borrowed_sample&& other) noexcept;
  borrowed_sample& operator=(borrowed_sample&& other) noexcept;
  borrowed_sample(const borrowed_sample&) = delete;
  borrowed_sample& operator=(const borrowed_sample&) = delete;
  ~borrowed_sample() { release(); }

  /// True while a packet is lent.
  explicit operator bool() const noexcept { return data_ != nullptr; }
  /// The packet (read-only), nullptr when empty.
  const void* data() const noexcept { return data_; }
  /// Size of the packet in bytes.
  unsigned int size() const noexcept { return size_; }
  /// Sequence, loss and timestamp of the packet.
  const sample_info& info() const noexcept { return info_; }
  /// The packet as the generated message type, or nullptr when empty or
  /// smaller than T.
  template <typename T>
  const T* as() const noexcept {
    return size_ >= sizeof(T) ? static_cast<const T*>(data_) : nullptr;
  }
  /// Ends the loan early; the object becomes empty.
  void release() noexcept;

 private:
  friend class inport;
  borrowed_sample(inport* lender, const void* packet, unsigned int packet_size, const sample_info& packet_info) noexcept
      : port_(lender), data_(packet), size_(packet_size), info_(packet_info) {}

  inport* port_ = nullptr;
  const void* data_ = nullptr;
  unsigned int size_ = 0;
  sample_info info_{};
};

/// Waits until at least one of several input ports can be read; created by
/// client::get_multi_waiter(), owned by the client.
class multi_waiter {
 public:
  client* clnt;
  ln_multi_waiter waiter;  ///< the C handle

  void add_port(inport* port);
  void remove_port(inport* port);
  /// @param timeout -1 waits without limit, 0 polls, > 0 seconds.
  /// @return true if a port became readable, false on timeout.
  bool wait(double timeout = -1);
  /// True if a read on @p port would not wait.
  bool can_read(inport* port);
  /// Starts a thread that makes @p *fd readable on activity (for external
  /// event loops); see ln_multi_waiter_start_pipe_notifier_thread().
  int start_pipe_notifier_thread(ln_pipe_fd_t* fd);
  /// Consumes one notification of that thread.
  int ack_pipe_notification();

  multi_waiter(const multi_waiter&) = delete;
  multi_waiter& operator=(const multi_waiter&) = delete;

 private:
  friend class client;
  explicit multi_waiter(client* owner);
  ~multi_waiter();
};

/// A service request: on the provider side the request a handler answers;
/// on the caller side an asynchronous call returned by service::call_async()
/// (owned by the service, reused by its next asynchronous call).
class service_request {
 public:
  service* svc;  ///< the service the request belongs to

  /// Provider: copies the request into @p data (the generated `X_t`
  /// struct, fills data->req). @p signature is the generated `x_signature`.
  void set_data(void* data, const char* signature);
  /// Provider: raw request bytes.
  void get_request_data(char** buffer, uint64_t* buffer_len);
  /// Provider: sends data->resp of the struct given to set_data(). On return
  /// the caller has the response, so dynamic response fields (strings,
  /// arrays) must stay alive only until then. Respond exactly once.
  int respond();
  /// Provider: responds with the response fields as a scatter-gather list.
  int respondv(struct iovec* iov, unsigned int iov_len);
  /// Provider: responds with @p data, the complete generated service struct.
  int respond_data(void* data);
  /// Provider: true if the caller has aborted the call.
  bool is_aborted();

  /// Caller (asynchronous call): false while running, true when finished
  /// successfully; throws if the call failed.
  bool finished();
  /// Caller: aborts the asynchronous call.
  void abort();
  /// Caller: descriptor that becomes readable when the call finishes.
  int get_finished_notification_fd();

  /// ln_core, provider: fails the request with @p error (> 0 application
  /// code, < 0 LN code) and an explanation for the caller; counts as the
  /// response.
  void respond_error(int error, const std::string& message);
  /// ln_core, caller: waits for the asynchronous call; timeout < 0 without
  /// limit. @return as finished() (false on timeout).
  bool wait(double timeout = -1);

 private:
  friend class service;
  service_request(service* owner, ln_service_request handle, bool is_async)
      : svc(owner), req_(handle), is_async_(is_async) {}
  [[noreturn]] void fail(int ret, const std::string& context) const;
  bool check_finished(int ret, int retval, const char* context);

  ln_service_request req_;
  bool is_async_;
};

/// ln_core: a running service call started by service::call_future(),
/// used like std::future<void>: the response arrives in the data passed to
/// call_future(), get() reports success or throws the failure. Move-only.
/// Destroying a future whose call is still running aborts the call, after
/// which the library no longer touches the data. Must not outlive its
/// service handle.
class service_future {
 public:
  service_future() noexcept = default;  ///< no call: valid() is false
  service_future(service_future&& other) noexcept;
  service_future& operator=(service_future&& other) noexcept;
  service_future(const service_future&) = delete;
  service_future& operator=(const service_future&) = delete;
  ~service_future();

  /// True from call_future() until get() (or abort()).
  bool valid() const noexcept { return req_ != nullptr; }
  /// Waits up to @p timeout seconds (< 0 without limit); true when the call
  /// has finished, successfully or not.
  bool wait_for(double timeout);
  /// Waits until the call has finished.
  void wait() { wait_for(-1); }
  /// Waits, then returns if the call succeeded or throws ln::exception: for
  /// a provider's own error code with error LNE_USER_DEFINED_ERROR and
  /// error_code set, for LN failures with their code; the message includes
  /// the provider's explanation. The future becomes invalid.
  void get();
  /// Aborts the call; the future becomes invalid.
  void abort();

 private:
  friend class service;
  service_future(service* owner, ln_service_request handle) noexcept : svc_(owner), req_(handle) {}

  service* svc_ = nullptr;
  ln_service_request req_ = nullptr;
};

/// A service handle for calling (client::get_service) or providing
/// (client::get_service_provider); owned by the client.
class service {
 public:
  /// Provider handler: answer @p req (see ln_service_handler in ln/ln.h for
  /// the return protocol; 0 after req.respond()). Exceptions fail the call
  /// with LNE_SVC_HANDLER_EXC and their text.
  typedef int (*handler_t)(client&, service_request& req, void* user_data);
  /// Observer of the provider's connections (see ln_service_fd_handler).
  typedef void (*fd_handler_t)(client&, ln_svc_client_event_t event, int fd, void* user_data);

  client* clnt;    ///< owning client
  ln_service svc;  ///< the C handle

  /// Releases the handle (as client::release_service()).
  ~service();
  service(const service&) = delete;
  service& operator=(const service&) = delete;

  /// Provider: sets the request handler (required before do_register()).
  void set_handler(handler_t handler, void* user_data = nullptr);
  /// Provider: registers with the manager in a service group (nullptr: the
  /// default group). Requests are handled while the group is served
  /// (client::wait_and_handle_service_group_requests() or a thread pool).
  void do_register(const char* group_name = nullptr);
  /// Provider: descriptor that signals work, for external event loops.
  int get_fd();
  /// Provider: installs an observer of the provider's connections.
  void set_client_fd_handler(fd_handler_t handler, void* user_data = nullptr);

  /// Caller: calls and waits. @p data is the generated `X_t` struct: the
  /// request from data->req (zero unused fields, e.g. `X_t d{}`), the
  /// response lands in data->resp. Not type-checked.
  /// @param timeout seconds, 0 waits without limit.
  /// Throws on failure, with LNE_USER_DEFINED_ERROR if the provider failed
  /// the call with its own error code.
  void call(void* data, double timeout = 0);
  /// Caller: call with the request as a scatter-gather list (see
  /// ln_service_callv()).
  void callv(struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens, char** response_buffer,
             uint32_t* response_len, uint8_t* need_swap, double timeout = 0);
  /// Caller: aborts a call() running in another thread.
  void abort();
  /// Caller: starts a call and returns at once (one at a time per handle);
  /// @p data must stay valid until it finished. The returned request is
  /// owned by the service.
  service_request* call_async(void* data);
  /// Caller: callv() started asynchronously.
  service_request* callv_async(struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens);
  /// Caller: raw response of a finished callv_async().
  void callv_async_get_response(char** response_buffer, uint32_t* response_len);
  /// Caller: response of a finished callv_async() unpacked into the complete
  /// generated service struct.
  void callv_async_get_response_data(void* data);

  /// ln_core, caller: starts a call and returns a future for its outcome
  /// (one asynchronous call at a time per handle). @p data must stay valid
  /// until the future is finished, aborted or destroyed.
  service_future call_future(void* data);

 private:
  friend class client;
  friend class service_request;
  friend class service_future;
  service(client& owner, const std::string& service_name, const std::string& service_interface,
          const std::string& signature, bool is_provider);
  [[noreturn]] void fail(int ret, const std::string& context) const;
  void require_provider(const char* operation) const;
  service_request* track_async(ln_service_request request);
  static int dispatch_request(ln_client, ln_service_request request, void* self);
  static void dispatch_fd_event(ln_client, ln_svc_client_event_t event, int fd, void* self);

  std::string name_;
  std::string interface_;
  std::string signature_;
  bool is_provider_;
  handler_t handler_ = nullptr;
  void* handler_data_ = nullptr;
  fd_handler_t fd_handler_ = nullptr;
  void* fd_handler_data_ = nullptr;
  std::unique_ptr<service_request> async_request_;
};

/// Fills a dynamic `char*` field of a generated struct (for instance a
/// string in a service response) and its companion `_len` field, which the
/// generated layout places directly before it. Owns the characters for its
/// own lifetime, so it has to outlive the respond() that sends them.
class string_buffer {
 public:
  string_buffer(char** target_ptr, const std::stringstream& src);
  string_buffer(char** target_ptr, const std::string& src);
  ~string_buffer() = default;
  string_buffer(const string_buffer&) = delete;
  string_buffer& operator=(const string_buffer&) = delete;

  operator std::string() const;  // NOLINT: implicit as in LN 2.9
  /// The characters, NUL-terminated.
  const char* c_str() const;

 private:
  void assign(char** target_ptr, const std::string& src);

  std::unique_ptr<char[]> storage_;
  uint32_t length_ = 0;
};

/// A named recording of topics, made and kept by the manager (see ln.h,
/// "Topic loggers"); obtained from client::get_logger(), owned by the client.
class logger {
 public:
  client* clnt;
  ln_logger _logger;  ///< the C handle
  std::string name;
  logger_data* data;  ///< result of the last download (owned by the logger)

  /// Records @p log_size samples of a topic, every @p divisor-th packet.
  void add_topic(std::string topic_name, uint64_t log_size, unsigned int divisor = 1);
  void clear_topics();
  void enable();
  void disable();
  /// Fetches the recording through the manager; the result is owned by the
  /// logger and replaced by the next download.
  logger_data* download();
  /// As LN 2.9: disables the logger, then downloads.
  logger_data* direct_download();
  /// Lets the manager save the recording on its host ("auto": format by
  /// file name).
  void manager_save(std::string filename, std::string format = "auto");
  /// Records timestamps only.
  void set_only_ts(bool only_ts);

  logger(const logger&) = delete;
  logger& operator=(const logger&) = delete;

 private:
  friend class client;
  logger(client* owner, const std::string& logger_name, ln_logger handle);
  ~logger();
};

/// Recorded topic data: downloaded (owned by its logger) or loaded from a
/// file with load() (owned by the caller, who deletes it).
class logger_data {
 public:
  /// Read access to one recorded topic.
  class topic_cursor {
   public:
    std::string name;
    logger_topic* topic;
    /// Sample @p i (0-based, below topic->n_samples).
    logger_sample* get_sample(unsigned int i);

   private:
    friend class logger_data;
    explicit topic_cursor(logger_topic* recorded);
  };
  typedef std::list<topic_cursor*> topics_t;
  typedef topics_t::const_iterator topic_iterator;

  logger* _logger;      ///< the logger it came from; nullptr when loaded
  ln_logger_data data;  ///< the C handle
  topics_t topics;

  ~logger_data();
  logger_data(const logger_data&) = delete;
  logger_data& operator=(const logger_data&) = delete;

  void save(std::string filename);
  /// Loads logger data from a file; the caller deletes the result.
  static logger_data* load(std::string filename);

 private:
  friend class logger;
  logger_data(logger* owner, ln_logger_data contents, bool own_data);
  void set_data(ln_logger_data contents, bool own_data);
  void clear_topics();

  bool own_data_;
};

/// Signs @p message with the DSA private key in a PEM file; returns the
/// signature. Throws std::runtime_error on failure.
std::string dsa_dss1_sign_message(const std::string& pem_private_key_filename, const std::string& message);
/// True if @p signature is valid for @p message and the OpenSSH public key
/// file, false if it is not (LN 2.9 throws then); throws std::runtime_error
/// when the key cannot be read.
bool dsa_dss1_verify_message_signature(const std::string& openssh_public_key_filename, const std::string& message,
                                       const std::string& signature);
/// As dsa_dss1_verify_message_signature() with the key given as text.
bool dsa_dss1_verify_message_signature_memkey(const std::string& openssh_public_key_contents,
                                              const std::string& message, const std::string& signature);
/// Writes a new DSA key pair (PEM private key, OpenSSH public key).
void dsa_dss1_generate_key_pair(const std::string& pem_private_key_filename,
                                const std::string& openssh_public_key_filename);

}  // namespace ln

#include "cppwrapper_impl.h"  // also retires LN_PRINTF_FORMAT

#endif  // LN_CPPWRAPPER_H
