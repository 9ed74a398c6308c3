/**
 * @file ln/ln.h
 * @brief The C API of ln_core, source-compatible with Links and Nodes 2.9
 *        (LN_LIBRARY_VERSION 32).
 *
 * Every LN 2.9 declaration is here with its exact name, parameter types and
 * return type, so LN 2.9 C programs (and the headers ln_generate writes)
 * compile unchanged. Additions of ln_core are collected in the section
 * "ln_core extensions" at the end and are announced by LN_CORE_EXTENSIONS.
 *
 * Conventions that hold unless a function says otherwise:
 * - Functions return 0 on success and a negative error code (-LNE_*) on
 *   failure; ln_format_error() names the code and ln_get_error_message()
 *   holds the detail the manager sent.
 * - All handles (ln_client, ln_inport, ln_service, ...) are opaque pointers.
 *   Everything obtained through a client belongs to that client: it becomes
 *   invalid when the client is deinitialised, and a handle must not be used
 *   after it was released.
 * - Strings returned through `char**` parameters of the message-definition and
 *   service-signature queries are allocated with malloc(); the caller frees
 *   them. Other returned strings belong to the library.
 * - Threads: set-up calls (init, publish, subscribe, service init/register,
 *   logger and event set-up) must come from one thread at a time, unless
 *   ln_client_set_thread_safe() was enabled. Communication calls (read,
 *   write, call, respond, wait, unblock, abort) may be made from any thread.
 * - Timeouts are in seconds. Timestamps are seconds as doubles, normally on
 *   the ln_get_time() clock.
 * - fork() is not supported while a client exists.
 *
 * In C++, including this header also includes the C++ wrapper ln/cppwrapper.h
 * (namespace ln) unless NO_CPP_WRAPPER is defined first.
 */

#if defined(__cplusplus) && !defined(NO_CPP_WRAPPER)
#include "cppwrapper.h"
#endif

#ifndef LN_H
#define LN_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#if !defined(_WIN32) && !defined(__WIN32__)
#include <sys/socket.h>
#include <sys/uio.h>
#endif

/* Scatter-gather element of the vector service calls (POSIX <sys/uio.h>).
   Declared here as well so the prototypes below name the same struct on
   platforms without that header. */
struct iovec;

/** Marks the functions the shared library exports (it is built with hidden
    visibility so that nothing else leaks). */
#if defined(__GNUC__) || defined(__clang__)
#define LN_API __attribute__((visibility("default")))
#else
#define LN_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ======================================================================== */
/** @name Versions and constants */
/* ======================================================================== */
/**@{*/

/** API level of this header. ln_core implements LN 2.9, which is level 32.
    Compare with ln_get_library_version() to detect a library that is older
    than the header a program was compiled against. */
#define LN_LIBRARY_VERSION 32

/** Subscription rate: deliver every packet as the publisher writes it. */
#define RATE_AS_PUBLISHED (-1)
/** Subscription rate: nothing is streamed; every ln_read() fetches the most
    recently published packet from the publisher through a service call (a
    network round trip of unbounded duration). Reads are non-blocking and
    return 0 while there is no publisher. Meant for sporadic reads, not for
    waiting on data. */
#define RATE_ON_REQUEST_LAST (-2)
/** Subscription rate named "the next packet on request". As in LN 2.9 it
    behaves exactly like RATE_ON_REQUEST_LAST: a read returns the most recently
    published packet. */
#define RATE_ON_REQUEST_NEXT (-3)

/** Returns the API level of the linked library (LN_LIBRARY_VERSION it was
    built with). Thread-safe. */
LN_API int ln_get_library_version(void);

/**@}*/

/* ======================================================================== */
/** @name Errors */
/* ======================================================================== */
/**@{*/

/** Error codes. Functions return them negated (-LNE_NO_MEM). The numbering
    starts at 1 and the values are those of LN 2.9, so codes are
    interchangeable with LN programs and logs. */
enum ln_error_t {
  LNE_CHECK_ERRNO = 1,                 /**< a system call failed; see errno */
  LNE_NO_MEM = 2,                      /**< out of memory */
  LNE_NO_MANAGER_ADDRESS = 3,          /**< neither --ln-manager nor LN_MANAGER given */
  LNE_INVALID_MANAGER_ADDRESS = 4,     /**< manager address is not HOST:PORT */
  LNE_INVALID_HOSTNAME = 5,            /**< host is neither a name nor an IPv4 address */
  LNE_UNKNOWN_HOSTNAME = 6,            /**< host name does not resolve */
  LNE_HOST_WRONG_NET = 7,              /**< host resolved to a non-IPv4 address */
  LNE_GOT_INVALID_RESPONSE = 8,        /**< malformed answer from the manager */
  LNE_REGISTER_DENIED = 9,             /**< manager refused to register the client */
  LNE_CLIENT_NOT_INITIALIZED = 10,     /**< client handle is not initialised */
  LNE_REQUEST_FAILED = 11,             /**< manager reported an error; see ln_get_error_message() */
  LNE_FIELD_NOT_IN_HEADER = 12,        /**< field missing in a manager message */
  LNE_STRING_LENGTH_SPEC_MISSING = 13, /**< string format lacks a length */
  LNE_PORT_NOT_FOUND = 14,             /**< no such port */
  LNE_INVALID_PORT_OBJECT = 15,        /**< handle is not a port of the expected kind */
  LNE_SHM_IS_TOO_SMALL = 16,           /**< shared-memory segment too small */
  LNE_SHM_IS_TOO_BIG = 17,             /**< shared-memory segment too big */
  LNE_SHM_DOES_NOT_EXIT = 18,          /**< shared-memory segment does not exist (LN's spelling) */
  LNE_PACKET_TOO_LARGE = 19,           /**< packet larger than the topic's message size */
  LNE_SHM_READ_ERROR = 20,             /**< reading the shared-memory segment failed */
  LNE_LOST_CONNECTION = 21,            /**< connection to the manager lost */
  LNE_REGISTER_FAILED = 22,            /**< registering with the manager failed (daemon running?) */
  LNE_SVC_IS_PROVIDER = 23,            /**< caller operation on a provider handle */
  LNE_SVC_IS_CLIENT = 24,              /**< provider operation on a caller handle */
  LNE_SVC_RECV_RESP = 25,              /**< receiving the service response failed */
  LNE_SVC_RECV_RESP_MEM = 26,          /**< no memory for the service response */
  LNE_SVC_ALREADY_REGISTERED = 27,     /**< service provider already registered */
  LNE_SVC_NOT_REGISTERED = 28,         /**< service provider not registered yet */
  LNE_SVC_RECV_REQ = 29,               /**< receiving the service request failed */
  LNE_SVC_RECV_REQ_MEM = 30,           /**< no memory for the service request */
  LNE_SVC_REQ_SET_DATA_WRONG = 31,     /**< signature given to set_data does not match the service */
  LNE_SVC_HANDLER_NO_RESP = 32,        /**< handler returned 0 without responding */
  LNE_INVALID_REQ_FIELD_FORMAT = 33,   /**< invalid field format character */
  LNE_USER_DEFINED_ERROR = 34,         /**< provider handler returned its own (positive) error */
  LNE_SVC_NO_HANDLER = 35,             /**< registering a provider without handler */
  LNE_SVC_HANDLER_EXC = 36,            /**< provider handler threw an exception */
  LNE_SVC_REQ_RUNNING = 37,            /**< a call is already running on this handle */
  LNE_SVC_REQ_NOT_RUNNING = 38,        /**< no asynchronous call running */
  LNE_SVC_REQ_ABORTED = 39,            /**< the call was aborted */
  LNE_NO_PROVIDER_FOUND = 40,          /**< nothing known provides this service/topic */
  LNE_START_PROVIDER_FAILED = 41,      /**< starting the providing process failed */
  LNE_ERROR_GETTING_SHM_FD = 42,       /**< no file descriptor for the shared-memory name */
  LNE_SHM_NAME_TOO_LONG = 43,          /**< shared-memory name too long */
  LNE_NOT_YET_IMPLEMENTED = 44,        /**< feature not implemented */
  LNE_NO_LOGGER_TOPICS = 45,           /**< logger has no topics */
  LNE_INTERNAL_ERROR = 46,             /**< internal error (a bug) */
  LNE_TOPIC_ID_OUT_OF_RANGE = 47,      /**< logger topic index out of range */
  LNE_LOG_FILE_TOO_NEW = 48,           /**< log file format unknown or newer */
  LNE_WRONG_BYTE_ORDER = 49,           /**< data is not in host byte order */
  LNE_INVALID_SHM_MAGIC = 50,          /**< shared-memory segment has a foreign layout */
  LNE_SHM_VERSION_TOO_NEW = 51,        /**< shared-memory layout newer than this library */
  LNE_WRONG_SHM_SIZE = 52,             /**< shared-memory segment size inconsistent */
  LNE_INVALID_SIGNATURE = 53,          /**< invalid event or DSA signature */
  LNE_INVALID_PARAMETER = 54,          /**< invalid argument */
  LNE_SVC_RESP_LATER = 55,             /**< handler return value: response follows later */
  LNE_SVC_GRP_UNKNOWN = 56,            /**< unknown service group */
  LNE_THREADP_INIT = 57,               /**< thread pool unavailable */
  LNE_NOT_ON_THIS_OS = 58,             /**< not available on this operating system */
  LNE_PORT_UNBLOCKED = 59,             /**< blocking read ended by ln_unblock() */
  LNE_UNKNOWN_PARAMETER = 60,          /**< unknown parameter name */
  LNE_SVC_HANDLER_MULTI_RESP = 61,     /**< handler responded more than once */
  LNE_MANAGER_TOO_OLD = 62,            /**< manager lacks a needed feature */
  LNE_INVALID_DSA_SIGNATURE = 63,      /**< DSA signature does not verify */
  LNE_SVC_TIMEOUT = 64,                /**< service call timed out */
  LNE_SVC_GRP_HANDLED_IN_POOL = 65,    /**< group already served by a thread pool */
  LNE_CLNT_NAME_IN_USE = 66,           /**< exact client name already taken */
  LNE_CHECK_ERROR_CODE = 67,           /**< C++ only: see ln::exception::error_code */
  LNE_UNKNOWN = 68,                    /**< unknown error; see the message text */
  LNE_WRONG_MD_HASH = 69               /**< message definition has another hash than expected */
};

/** Returns a static, human-readable description of an error code. Accepts
    the code negated (as functions return it) or positive; unknown values give
    a generic text. Never NULL. Thread-safe. */
LN_API const char* ln_format_error(int ret);

/**@}*/

/* ======================================================================== */
/** @name Time */
/* ======================================================================== */
/**@{*/

/** Wall-clock time in seconds since the Unix epoch. The default timestamp of
    ln_write(). Thread-safe. */
LN_API double ln_get_time(void);

/** Monotonic time in seconds (arbitrary origin); falls back to ln_get_time()
    where the platform has no monotonic clock. Thread-safe. */
LN_API double ln_get_monotonic_time(void);

/** Sleeps for the given number of seconds (fractions allowed). */
LN_API void ln_sleep_seconds(double seconds);

/**@}*/

/* ======================================================================== */
/** @name Client */
/* ======================================================================== */
/**@{*/

/** Connection of one program to the ln_manager. Owns every port, service,
    multi-waiter, logger and event connection created through it. */
typedef void* ln_client;

/** Connects to the manager and registers a client.

    Command-line options of LN are taken from argv (which is not modified):
    `--ln-manager HOST:PORT` (also `-ln_manager`), `--ln-program-name NAME`,
    `--ln-map-topic SRC DST`, `--ln-map-service SRC DST`. Without a manager
    option, the LN_MANAGER environment variable gives the address. All other
    arguments stay available through ln_get_remaining_args().

    @p client_name is the default name; LN_PROGRAM_NAME and then
    --ln-program-name override it. A name of the form `exact:NAME` requests
    exactly NAME, ignores both overrides and fails with -LNE_CLNT_NAME_IN_USE
    if it is taken; otherwise the manager makes the name unique by appending
    a number (see ln_client_get_name()).

    LN_MANAGER_CONNECT_TIMEOUT=SECONDS (ln_core) makes it wait that long for
    a manager that does not listen yet, so that a program may start before
    its manager (tried until the whole wait passed; the error message then
    says it waited); unset or 0, a refused connection fails at once (LN 2.9).

    @param[out] clnt receives the new client; NULL on failure.
    @param argc, argv may be 0 and NULL.
    @return 0, or e.g. -LNE_NO_MANAGER_ADDRESS, -LNE_INVALID_MANAGER_ADDRESS,
            -LNE_UNKNOWN_HOSTNAME, -LNE_REGISTER_FAILED, -LNE_CLNT_NAME_IN_USE. */
LN_API int ln_init(ln_client* clnt, const char* client_name, int argc, char** argv);

/** Like ln_init() with an explicit manager address "HOST:PORT" instead of
    command-line options. LN_MANAGER is used only when @p ln_manager is NULL
    or empty. */
LN_API int ln_init_to_manager(ln_client* clnt, const char* client_name, const char* ln_manager);

/** The final client name granted by the manager. @p *name belongs to the
    client and stays valid until ln_deinit(). */
LN_API int ln_client_get_name(ln_client clnt, char** name);

/** Unregisters from the manager and releases the client with everything it
    owns (ports, services, waiters, loggers, event connections). Sets *clnt
    to NULL. No other thread may use the client or its handles meanwhile. */
LN_API int ln_deinit(ln_client* clnt);

/** printf-style debug output of the library. Emitted only while debugging is
    enabled for this client (LN_DEBUG set, a client name containing "dbg", or
    enabled by the manager at run time); otherwise does nothing. */
LN_API void ln_debug(ln_client clnt_, const char* format, ...);

/** Measures the round trip to the manager.
    @param timeout seconds to wait for the answer; -1 waits without limit;
           0 only checks that the connection is up (rtt is then 0).
    @param[out] rtt round-trip time in seconds.
    @return 0, -LNE_LOST_CONNECTION, or another error. */
LN_API int ln_ping(ln_client clnt, double timeout, double* rtt);

/** Enables (non-zero) or disables internal serialisation of the client's
    manager requests, which allows set-up calls from several threads at the
    same time. Off by default. */
LN_API int ln_client_set_thread_safe(ln_client clnt, int enable);

/** Command-line arguments that ln_init() did not consume, argv[0] included,
    in their original order.
    @param[out] n_args number of arguments.
    @param[out] args_ptr the arguments stored back to back, each terminated by
                a NUL byte. Belongs to the client. */
LN_API int ln_get_remaining_args(ln_client clnt, unsigned int* n_args, char** args_ptr);

/** Detail of the last failure on this client (for instance the manager's
    explanation behind -LNE_REQUEST_FAILED). Every failing call sets it, to ""
    when it has no detail, so right after a failure it describes that
    failure (the C++ wrapper appends it to its exceptions). Belongs to the
    client. For a NULL client (ln_core): the detail of this thread's last
    failed call that has no client - why ln_init() or ln_init_to_manager()
    failed, or ln_logger_data_save/_load/... - and "" when the last such call
    succeeded; never NULL. Not synchronised with failures in other threads. */
LN_API char* ln_get_error_message(ln_client clnt_);

/**@}*/

/* ======================================================================== */
/** @name Message definitions */
/* ======================================================================== */
/**@{*/

/** Raw packet pointer (kept for source compatibility; unused by the API). */
typedef void* ln_packet;

/** Message-definition name, definition text and message size of a topic
    known to the manager. Output strings are malloc()ed; the caller frees. */
LN_API int ln_get_message_definition_for_topic(ln_client clnt, const char* topic_name, char** message_definition_name,
                                               char** message_definition, unsigned int* message_size);

/** As ln_get_message_definition_for_topic(), plus the definition's hash
    (malloc()ed, caller frees). */
LN_API int ln_get_message_definition_for_topic_v17(ln_client clnt, const char* topic_name,
                                                   char** message_definition_name, char** message_definition,
                                                   unsigned int* message_size, char** hash);

/** Definition text and message size of a named message definition, resolved
    by the manager on its search path. Output strings are malloc()ed; the
    caller frees. */
LN_API int ln_get_message_definition(ln_client clnt, const char* message_definition_name, char** message_definition,
                                     unsigned int* message_size);

/** As ln_get_message_definition(), plus the hash (malloc()ed). */
LN_API int ln_get_message_definition_v17(ln_client clnt, const char* message_definition_name, char** message_definition,
                                         unsigned int* message_size, char** hash);

/** As ln_get_message_definition_v17(), plus the flattened definition (all
    sub-types expanded; malloc()ed). @p *flat_message_definition is NULL when
    the manager cannot provide it. */
LN_API int ln_get_message_definition_v21(ln_client clnt, const char* message_definition_name, char** message_definition,
                                         unsigned int* message_size, char** hash, char** flat_message_definition);

/** Human-readable description of a message definition (layout, offsets and
    sizes) as a NUL-terminated string, malloc()ed; the caller frees. */
LN_API int ln_describe_message_definition(ln_client clnt, const char* message_definition_name,
                                          char** message_definition);

/** Byte offset and length of a member inside a message, for member paths
    such as "pose.position[2]". */
LN_API int ln_locate_member_in_message_definition(ln_client clnt, const char* message_definition_name,
                                                  const char* member, unsigned int* member_offset,
                                                  unsigned int* member_byte_len);

/** Hands a message definition (text) to the manager, for definitions that
    are not on the manager's search path. @p *real_message_definition_name
    receives the name the manager stored it under (malloc()ed). */
LN_API int ln_put_message_definition(ln_client clnt, const char* message_definition_name,
                                     const char* message_definition, char** real_message_definition_name);

/** Asks the manager to make sure a service or topic of this name is
    provided: if nothing provides it yet, the manager starts a configured
    process that declares it (config key `provides:`).
    @param timeout -1 waits until provided; 0 only asks; > 0 waits at most
           that many seconds.
    @return 0 when provided (or, with 0 timeout, when the request was
            accepted), -LNE_NO_PROVIDER_FOUND, -LNE_START_PROVIDER_FAILED,
            or another error. */
LN_API int ln_needs_provider(ln_client clnt, const char* service_or_topic_name, double timeout);

/**@}*/

/* ======================================================================== */
/** @name Topics: subscribing and reading */
/* ======================================================================== */
/**@{*/

/** Subscriber end of a topic (owned by its client). */
typedef void* ln_inport;

/** Subscribes to a topic with one receive buffer. See
    ln_subscribe_with_buffers(). */
LN_API int ln_subscribe(ln_client clnt, const char* topic_name, const char* message_definition_name, ln_inport* port,
                        double rate, int reliable_transport);

/** Subscribes to a topic. A topic may be subscribed before it is published;
    reads then find no data until a publisher appears.

    @param message_definition_name the topic's message definition, optionally
           followed by "|HASH" as in the generated *_MD_NAME macros; the hash
           then has to match (-LNE_WRONG_MD_HASH). A different definition than
           the topic already has is refused.
    @param[out] port the new input port.
    @param rate RATE_AS_PUBLISHED (-1) for every packet; > 0 for at most that
           many packets per second, thinned out by publisher timestamp (a
           packet is skipped when it is less than 1/rate newer than the last
           one delivered); RATE_ON_REQUEST_LAST for on-demand reads.
    @param reliable_transport non-zero: across hosts use TCP instead of UDP.
           No effect on the same host.
    @param buffers ring-buffer slots (>= 1). With one slot a reader only ever
           sees the newest packet; with N it can fall behind by up to N
           packets and still read them in order; falling further behind skips
           to the newest. */
LN_API int ln_subscribe_with_buffers(ln_client clnt, const char* topic_name, const char* message_definition_name,
                                     ln_inport* port, double rate, int reliable_transport, unsigned int buffers);

/** Ends a subscription, releases the port and sets *port to NULL. A read
    blocked on it in another thread must have been unblocked first. */
LN_API int ln_unsubscribe(ln_inport* port);

/** @return 1 if the topic currently has a publisher, 0 if not, < 0 on error. */
LN_API int ln_has_publisher(ln_inport port);

/** Copies the next unread packet, whole or not at all.
    @param packet receives the packet; @p size must be the topic's message
           size (ln_get_message_size()).
    @param[out] timestamp the publisher's timestamp of the packet; may be NULL.
    @param blocking non-zero: wait until a packet arrives; 0: return at once.
    @return 1 if a new packet was copied, 0 if there was none (packet and
            timestamp untouched), -LNE_PORT_UNBLOCKED if ln_unblock() ended the
            wait, other negative codes on error. */
LN_API int ln_read(ln_inport port, void* packet, unsigned int size, double* timestamp, int blocking);

/** As ln_read(), waiting at most @p timeout seconds; timeout <= 0 does not
    wait. @return 1 packet copied, 0 timed out, < 0 error. */
LN_API int ln_read_timeout(ln_inport port, void* packet, unsigned int packet_size, double* ts, double timeout);

/** Makes a read currently blocked on this port (in another thread) return
    -LNE_PORT_UNBLOCKED. Thread-safe. */
LN_API int ln_unblock(ln_inport port);

/**@}*/

/* ======================================================================== */
/** @name Topics: publishing and writing */
/* ======================================================================== */
/**@{*/

/** Publisher end of a topic (owned by its client). */
typedef void* ln_outport;

/** Publishes a topic with one buffer. See ln_publish_with_buffers(). */
LN_API int ln_publish(ln_client clnt, const char* topic_name, const char* message_definition_name, ln_outport* port);

/** Becomes the publisher of a topic. A topic has at most one publisher; a
    second one is refused (-LNE_REQUEST_FAILED, reason in
    ln_get_error_message()).
    @param message_definition_name as for ln_subscribe_with_buffers().
    @param buffers ring-buffer slots offered to local subscribers (the
           segment grows to the largest number a local subscriber asks for). */
LN_API int ln_publish_with_buffers(ln_client clnt, const char* topic_name, const char* message_definition_name,
                                   unsigned int buffers, ln_outport* port);

/** Stops publishing, releases the port and sets *port to NULL. */
LN_API int ln_unpublish(ln_outport* port);

/** @return the number of subscribers (0: nobody listens), < 0 on error. */
LN_API int ln_has_subscriber(ln_outport port);

/** Publishes one packet. Never blocks; every subscriber gets the packet
    whole or not at all. The packet is copied, so the buffer may be reused
    at once.
    @param size at most the topic's message size (-LNE_PACKET_TOO_LARGE).
    @param timestamp the packet's timestamp in seconds (used by rate-limited
           subscribers); NULL stamps it with ln_get_time(). */
LN_API int ln_write(ln_outport port, void* packet, unsigned int size, double* timestamp);

/** Buffer that the next ln_write() on this port publishes from. Filling it
    in place and passing it to ln_write() saves one copy. Valid until that
    write.
    @param[out] buffer the buffer; @param[out] buffer_len its size. */
LN_API int ln_outport_get_next_buffer(ln_outport port, void** buffer, unsigned int* buffer_len);

/** Message size in bytes of an ln_inport or ln_outport (< 0 on error). */
LN_API int ln_get_message_size(void* p_);

/** Hash of the message definition of an ln_inport or ln_outport. Belongs to
    the port; NULL on error. */
LN_API const char* ln_get_msg_def_hash(void* p_);

/**@}*/

/* ======================================================================== */
/** @name Multi-waiter: waiting on several input ports */
/* ======================================================================== */
/**@{*/

/** Waits until at least one of a set of input ports can be read. */
typedef void* ln_multi_waiter;

/** Descriptor a multi-waiter can signal through (see
    ln_multi_waiter_start_pipe_notifier_thread()). */
#if defined(__WIN32__)
#ifndef HAVE_LN_PIPE_FD
#define HAVE_LN_PIPE_FD
typedef void* ln_pipe_fd_t;
#endif
#else
typedef int ln_pipe_fd_t;
#endif

/** Creates a multi-waiter owned by @p clnt. */
LN_API int ln_multi_waiter_init(ln_client clnt, ln_multi_waiter* waiter);
/** Releases a multi-waiter and sets *waiter to NULL. */
LN_API int ln_multi_waiter_deinit(ln_multi_waiter* waiter);
/** Adds an input port to the set. @return >= 0 on success. */
LN_API int ln_multi_waiter_add_port(ln_multi_waiter waiter, ln_inport port);
/** Removes an input port from the set. */
LN_API int ln_multi_waiter_remove_port(ln_multi_waiter waiter, ln_inport port);
/** Waits until at least one port of the set has an unread packet.
    @param timeout -1 waits without limit, 0 polls, > 0 seconds.
    @return > 0 if a port is readable, 0 on timeout, < 0 on error. */
LN_API int ln_multi_waiter_wait(ln_multi_waiter waiter, double timeout);
/** @return 1 if a read on @p port would return a packet without waiting,
    0 if not, < 0 on error. Valid after ln_multi_waiter_wait(). */
LN_API int ln_multi_waiter_can_read(ln_multi_waiter waiter, ln_inport port);
/** Starts a background thread that makes @p *fd readable whenever a port of
    the set becomes readable, for integration into select()/poll() loops.
    Acknowledge each notification with ln_multi_waiter_ack_pipe_notification(). */
LN_API int ln_multi_waiter_start_pipe_notifier_thread(ln_multi_waiter waiter, ln_pipe_fd_t* fd);
/** Consumes one notification of the pipe notifier thread. */
LN_API int ln_multi_waiter_ack_pipe_notification(ln_multi_waiter waiter);

/**@}*/

/* ======================================================================== */
/** @name Services: calling */
/* ======================================================================== */
/**@{*/

/** A service handle: either a caller (ln_service_init() for calling) or a
    provider (same init, then ln_service_provider_register*()). */
typedef void* ln_service;
/** One request: on the provider side the request being handled; on the
    caller side an asynchronous call in flight. */
typedef void* ln_service_request;

/** Creates a service handle owned by @p clnt.
    @param service_interface the service's message definition name.
    @param signature the generated *_SIGNATURE string; caller and provider
           must agree on it.
    A handle becomes a provider when it is registered; otherwise it calls. */
LN_API int ln_service_init(ln_client clnt, ln_service* svc, const char* service_name, const char* service_interface,
                           const char* signature);

/** Releases a service handle (providers are unregistered first, a running
    asynchronous call is aborted) and sets *svc to NULL. */
LN_API int ln_service_deinit(ln_service* svc);

/** Calls the service and waits for the response without time limit.
    @param data the generated service struct (`X_t`): the request is taken
           from data->req, the response written to data->resp. Unused request
           fields should be zeroed. Dynamic response fields point into memory
           of the handle, valid until the next call on it.
    @return 0 on success; < 0 an LN error (-LNE_NO_PROVIDER_FOUND,
            -LNE_SVC_REQ_ABORTED, ...); > 0 the error the provider's handler
            returned. On failure, ln_get_error_message() holds the detail,
            including a provider's explanation (ln_core: see
            ln_service_request_respond_error()). Calls on one handle from
            several threads are serialised. */
LN_API int ln_service_call(ln_service svc, void* data);

/** As ln_service_call(), giving up after @p timeout seconds
    (-LNE_SVC_TIMEOUT); 0 waits without limit. */
LN_API int ln_service_call_with_timeout(ln_service svc, void* data, double timeout);

/** Aborts a blocking call running on this handle in another thread; that
    call returns -LNE_SVC_REQ_ABORTED. */
LN_API int ln_service_call_abort(ln_service svc);

/** Calls with the request given as a scatter-gather list of its flat
    fields instead of a generated struct (used by language bindings).
    @param iov, iov_len request fields in signature order.
    @param iov_element_lens element size in bytes of each field (for byte
           swapping).
    @param[out] response_buffer, response_len raw response; belongs to the
           handle, valid until its next call.
    @param[out] need_swap set non-zero when the provider's byte order
           differs and the response has to be swapped by the caller.
    @return as ln_service_call(). */
LN_API int ln_service_callv(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens,
                            char** response_buffer, uint32_t* response_len, uint8_t* need_swap);

/** ln_service_callv() with a timeout as for ln_service_call_with_timeout(). */
LN_API int ln_service_callv_with_timeout(ln_service svc, struct iovec* iov, unsigned int iov_len,
                                         uint8_t* iov_element_lens, char** response_buffer, uint32_t* response_len,
                                         uint8_t* need_swap, double timeout);

/** Starts a call and returns at once. At most one asynchronous call per
    handle runs at a time (-LNE_SVC_REQ_RUNNING otherwise).
    @param data as for ln_service_call(); must stay valid until the call has
           finished or was aborted.
    @param[out] req the call in flight, owned by the service handle and valid
           until the next asynchronous call on it or its release. Poll with
           ln_service_request_finished(). */
LN_API int ln_service_call_async(ln_service svc, void* data, ln_service_request* req);

/** Asynchronous variant of ln_service_callv(). Fetch the response with
    ln_service_callv_async_get_response() once finished. */
LN_API int ln_service_callv_async(ln_service svc, struct iovec* iov, unsigned int iov_len, uint8_t* iov_element_lens,
                                  ln_service_request* req);

/** Raw response of a finished ln_service_callv_async() call (belongs to the
    handle). @return as ln_service_call(). */
LN_API int ln_service_callv_async_get_response(ln_service svc, char** response_buffer, uint32_t* response_len);

/** Response of a finished ln_service_callv_async() call unpacked into
    @p data, the complete generated service struct (not only its response
    part). @return as ln_service_call(). */
LN_API int ln_service_callv_async_get_response_data(ln_service svc, void* data);

/** Aborts an asynchronous call. Afterwards the library no longer writes to
    the call's data; ln_service_request_finished() reports
    -LNE_SVC_REQ_ABORTED. */
LN_API int ln_service_request_abort(ln_service_request req);

/** Polls an asynchronous call.
    @param[out] retval once finished: 0 success, < 0 LN error, > 0 the
           provider handler's error.
    @return 0 still running, 1 finished (retval set), < 0 error. */
LN_API int ln_service_request_finished(ln_service_request req, int* retval);

/** File descriptor that becomes readable when the asynchronous call
    finishes, for select()/poll() loops. Belongs to the request. */
LN_API int ln_service_request_get_finished_notification_fd(ln_service_request req, int* fd);

/**@}*/

/* ======================================================================== */
/** @name Services: providing */
/* ======================================================================== */
/**@{*/

/** Events reported to an ln_service_fd_handler. */
typedef enum {
  LN_NEW_SVC_CLIENT,    /**< a caller connected (fd: its connection) */
  LN_REMOVE_SVC_CLIENT, /**< a caller disconnected */
  LN_NEW_SVC_FD,        /**< the provider opened a listening descriptor */
  LN_REMOVE_SVC_FD      /**< the provider closed a listening descriptor */
} ln_svc_client_event_t;

/** Observer of a provider's connections, for programs that run their own
    event loop. Called from the thread that handles the service group. */
typedef void (*ln_service_fd_handler)(ln_client clnt, ln_svc_client_event_t event, int fd, void* user_data);

/** Handles one request on the provider side.

    Runs in the thread that handles the service's group (see
    ln_wait_and_handle_service_group_requests()) or in a pool thread. Copy the
    request with ln_service_request_set_data(), fill the response and call
    ln_service_request_respond() (once). Then return:
    - 0 after responding;
    - -LNE_SVC_RESP_LATER to respond later, possibly from another thread;
    - any other value, without responding, to fail the call: negative values
      are LN codes, positive values reach the caller as its own error code.
    Returning 0 without a response fails the call with
    -LNE_SVC_HANDLER_NO_RESP. (ln_core: ln_service_request_respond_error()
    fails a call with an explanation for the caller.) */
typedef int (*ln_service_handler)(ln_client clnt, ln_service_request req, void* user_data);

/** Sets the request handler of a provider; required before registering. */
LN_API int ln_service_provider_set_handler(ln_service svc, ln_service_handler handler, void* user_data);
/** Registers the provider with the manager in the default group (NULL).
    Only one provider per service name (-LNE_REQUEST_FAILED otherwise). */
LN_API int ln_service_provider_register(ln_client clnt, ln_service svc);
/** Registers the provider in a named service group; NULL names the default
    group. Requests are only executed while the group is being handled. */
LN_API int ln_service_provider_register_in_group(ln_client clnt, ln_service svc, const char* group_name);
/** Descriptor that becomes readable when the provider has work (a new
    connection or request), for external event loops. @return fd, or < 0. */
LN_API int ln_service_provider_get_fd(ln_service svc);
/** Installs an observer of the provider's connections (see
    ln_service_fd_handler). */
LN_API int ln_service_provider_set_client_fd_handler(ln_service svc, ln_service_fd_handler handler, void* user_data);

/** Copies the received request into @p data (the generated service struct;
    fills data->req). Dynamic request fields point into library memory valid
    until the request is answered.
    @param signature the generated *_signature; must match the service's
           (-LNE_SVC_REQ_SET_DATA_WRONG). */
LN_API int ln_service_request_set_data(ln_service_request req, void* data, const char* signature);
/** Raw request bytes as received (belongs to the request). */
LN_API int ln_service_request_get_request_data(ln_service_request req, char** buffer, uint64_t* buffer_len);
/** Sends data->resp of the struct given to ln_service_request_set_data().
    When it returns, the response has reached the caller, so dynamic response
    fields only need to live until then. Responding twice fails with
    -LNE_SVC_HANDLER_MULTI_RESP. Thread-safe (for deferred responses). */
LN_API int ln_service_request_respond(ln_service_request req);
/** Responds with the response's flat fields given as a scatter-gather list. */
LN_API int ln_service_request_respondv(ln_service_request req, struct iovec* iov, unsigned int iov_len);
/** Responds with the response part of @p data, which is the complete
    generated service struct (not only the response part). */
LN_API int ln_service_request_respond_data(ln_service_request req, void* data);
/** @return 1 if the caller aborted this request (the response will be
    dropped), 0 if not, < 0 on error. For long-running handlers. */
LN_API int ln_service_request_is_aborted(ln_service_request req);

/**@}*/

/* ======================================================================== */
/** @name Services: groups and thread pools */
/* ======================================================================== */
/**@{*/

/** Waits for requests to the providers of one group and runs their handlers
    in the calling thread, one after the other.
    @param group_name the group; NULL is the default group.
    @param timeout -1 blocks until requests arrive; 0 handles what is pending
           and returns; > 0 waits at most that many seconds.
    @return >= 0 on success (also on timeout), < 0 on error. Concurrent
            callers for the same group are serialised. */
LN_API int ln_wait_and_handle_service_group_requests(ln_client clnt, const char* group_name, double timeout);
/** Hands a group to a named thread pool: its handlers then run in pool
    threads, possibly concurrently (protect shared data). The pool is
    created on first use with one thread. */
LN_API int ln_handle_service_group_in_thread_pool(ln_client clnt, const char* group_name, const char* pool_name);
/** Takes a group back from its thread pool. */
LN_API int ln_remove_service_group_from_thread_pool(ln_client clnt_, const char* group_name);
/** Makes a thread waiting in ln_wait_and_handle_service_group_requests() for
    this group return. Thread-safe. */
LN_API int ln_unblock_service_group(ln_client clnt_, const char* group_name);
/** Sets the size of a thread pool: 0 serves strictly one request at a time
    in one thread; 1 also one request at a time but accepts connections in a
    thread of its own; n >= 2 serves up to n requests concurrently. */
LN_API int ln_set_max_threads(ln_client clnt, const char* pool_name, unsigned int n_threads);
/** Scheduling of a pool's threads, also of those it starts later: policy
    (SCHED_*) and priority (-1 keeps each unchanged) and CPU affinity (bit
    mask; 0 keeps it).
    @return 0, or (ln_core; LN 2.9 ignores such failures) -LNE_CHECK_ERRNO
            when the system refuses, e.g. a real-time policy without the
            privilege or a CPU that does not exist; ln_get_error_message()
            says why, and nothing has changed. */
LN_API int ln_thread_pool_setschedparam(ln_client clnt, const char* pool_name, int policy, int priority,
                                        unsigned int affinity_mask);

/**@}*/

/* ======================================================================== */
/** @name Services: introspection and logging */
/* ======================================================================== */
/**@{*/

/** Definition text and signature of a service interface (message definition
    name). Outputs malloc()ed; the caller frees. */
LN_API int ln_get_service_signature(ln_client clnt, const char* service_interface, char** definition, char** signature);
/** Interface, definition text and signature of a registered service.
    Outputs malloc()ed; the caller frees. */
LN_API int ln_get_service_signature_for_service(ln_client clnt, const char* service_name, char** service_interface,
                                                char** definition, char** signature);
/** Names of the registered services with the given interface, separated
    by newlines ("" if none), as one malloc()ed string (the caller frees). */
LN_API int ln_client_find_services_with_interface(ln_client clnt, const char* interface_name, char** services);
/** Makes @p logger_service_name, a service this client provides with
    interface ln/log_service (else -LNE_SVC_NOT_REGISTERED /
    -LNE_INVALID_PARAMETER), a service logger: callers and providers in
    other clients of every service whose name matches the comma-separated
    fnmatch patterns ("!pattern" excludes; the logger itself never) send it
    an ln/log_service item for each request sent (item_type 0) and each
    response sent (item_type 1), filled as LN 2.9 fills them (data: the
    request or response as LN 2.9 puts it on the wire; client_id and
    request_id pair the two items of a call). Unlike LN 2.9 the logged calls
    never wait for the logger: items are queued (at most 10000 per client)
    and sent by a library thread. Kept across manager restarts. */
LN_API int ln_register_as_service_logger(ln_client clnt, const char* logger_service_name,
                                         const char* service_name_patterns_to_log);

/**@}*/

/* ======================================================================== */
/** @name Topic loggers
    A logger records topics at the publisher's side: the ln_manager maps
    each publisher's shared-memory segment and copies its packets into a ring
    of log_size samples per topic (there are no daemons in ln_core). It is
    not a subscriber (ln_has_subscriber(), ln_list_topics() do not count it).
    A logger is a name the manager knows from its first enable on, for every
    client; its recording stays in the manager until the logger is enabled
    again, also after the publisher (or the client that enabled it) is gone.
    Publishers on another host (network namespace) cannot be recorded:
    enabling such a topic fails with -LNE_REQUEST_FAILED. */
/* ======================================================================== */
/**@{*/

/** A named recording of topics, made and kept by the manager. */
typedef void* ln_logger;
/** Downloaded or loaded logger contents. */
typedef void* ln_logger_data;

/** Returns the logger of that name, creating it on first use (the same
    handle for the same name). Owned by the client. */
LN_API int ln_client_get_logger(ln_client clnt, ln_logger* logger, const char* logger_name);
/** Adds a topic to record (or changes the settings of one added before):
    the newest @p log_size samples (>= 1; -LNE_INVALID_PARAMETER for 0),
    every @p divisor-th packet counted from ln_logger_enable() (0 counts as
    1). The topic need not be published yet: it is recorded from the moment
    it is. Takes effect with the next ln_logger_enable(). */
LN_API int ln_logger_add_topic(ln_logger logger, const char* topic_name, unsigned int log_size, unsigned int divisor);
/** ln_logger_add_topic() for sizes beyond 32 bits. Logs that do not fit the
    manager's memory fail at ln_logger_enable() with -LNE_NO_MEM. */
LN_API int ln_logger_add_topic64(ln_logger logger, const char* topic_name, uint64_t log_size, unsigned int divisor);
/** Removes all topics from the logger (takes effect with the next enable). */
LN_API int ln_logger_clear_topics(ln_logger logger);
/** Non-zero: record only the sample headers (timestamps and packet
    counters), no packet data; samples are then 20 bytes. */
LN_API int ln_logger_set_only_ts(ln_logger logger, int only_ts);
/** Starts a new recording of the added topics (the previous samples of the
    logger are dropped); returns once every published topic records.
    -LNE_NO_LOGGER_TOPICS without topics. */
LN_API int ln_logger_enable(ln_logger logger);
/** Stops recording; the packets written before are recorded. */
LN_API int ln_logger_disable(ln_logger logger);
/** Fetches the recording through the manager: every topic of the logger in
    its order, the samples oldest first (while enabled: as recorded so far).
    Can be repeated. @p *logger_data belongs to the logger and is replaced
    (freed) by its next download. -LNE_REQUEST_FAILED for a logger that was
    never enabled. */
LN_API int ln_logger_download(ln_logger logger, ln_logger_data* logger_data);
/** As in LN 2.9: disables the logger, then downloads (the manager holds
    the data, so there is no more direct way). */
LN_API int ln_logger_direct_download(ln_logger logger, ln_logger_data* logger_data);
/** Lets the manager write the recording to a file on its host.
    @param format "raw" (the samples of a one-topic logger back to back),
    "pcap" (LN's recorder format), "mat" (MATLAB 5), "mat4" (MATLAB 4),
    "mcap" (MCAP for ROS 2 tools: the pcap converted by ln_bag's
    `ln bag convert`, which must be the `ln` on the manager's PATH), or
    "auto"/NULL: chosen by the file name's extension (.raw, .pcap, .mat,
    .mcap).
    "pickle" is refused: the manager is not a Python program. */
LN_API int ln_logger_manager_save(ln_logger logger, const char* filename, const char* format);
/** Writes logger data to a file in LN 2.9's format (loadable by LN 2.9).
    On failure ln_get_error_message(NULL) says why. */
LN_API int ln_logger_data_save(ln_logger_data logger_data, const char* filename);
/** Loads logger data from a file written by ln_logger_data_save() (also by
    LN 2.9); free it with ln_logger_data_deinit(). A file of the other byte
    order: -LNE_WRONG_BYTE_ORDER; a newer format: -LNE_LOG_FILE_TOO_NEW; a
    damaged file: -LNE_INVALID_PARAMETER; ln_get_error_message(NULL) says
    why. */
LN_API int ln_logger_data_load(ln_logger_data* logger_data, const char* filename);
/** Frees logger data obtained from ln_logger_data_load() (not from a
    download: -LNE_INVALID_PARAMETER) and sets *logger_data to NULL. */
LN_API int ln_logger_data_deinit(ln_logger_data* logger_data);

#include "packed.h"
/** One recorded sample; samples of a topic are sample_size bytes apart. */
typedef struct LN_PACKED {
  double log_ts;           /**< when the manager's recorder copied it (wall clock;
                                it polls, so up to a few ms after the write) */
  double src_ts;           /**< the publisher's timestamp */
  uint32_t packet_counter; /**< the publisher's packet counter (low 32 bits) */
  uint8_t data;            /**< first byte of the packet (absent with only_ts) */
} logger_sample;
#include "endpacked.h"

struct logger_topic_;
typedef struct logger_topic_ logger_topic;

/** One recorded topic of logger data. */
struct logger_topic_ {
  char* name;
  uint64_t log_size;
  uint32_t divisor;
  /* Filled in by a download or load: */
  uint32_t n_samples;
  uint32_t sample_size;   /**< distance between samples in bytes: 20 + message
                               size, 20 with only_ts, 0 for a topic never seen
                               published */
  char* md_name;          /**< message definition name ("" if never seen) */
  char* md;               /**< the definition in LN 2.9's Python dict notation */
  logger_sample* samples; /**< n_samples samples, oldest first */
};

/** Number of topics in logger data. */
LN_API int ln_logger_data_get_info(ln_logger_data logger_data, unsigned int* n_topics);
/** Topic @p topic_id (0-based) of logger data; belongs to the data.
    -LNE_TOPIC_ID_OUT_OF_RANGE beyond the last topic. */
LN_API int ln_logger_data_get_topic(ln_logger_data logger_data, unsigned int topic_id, logger_topic** topic);

/**@}*/

/* ======================================================================== */
/** @name Events */
/* ======================================================================== */
/**@{*/

/* Events, as LN 2.9 has them. Connecting to event NAME registers the
   handler service "NAME.<client name>" (interface ln/event/call) in the
   client's default service group; whoever emits the event calls that
   service with the flat call data and "<definition>: <call signature>", so
   the handler runs in the thread that handles the default group
   (ln_wait_and_handle_service_group_requests() or a thread pool), one event
   at a time. The ln_manager emits "ln.resource_event" (definition
   ln/resource_event): connect with four fnmatch patterns (event, name, md,
   client) to hear of service providers, topic publishers and subscribers
   coming and going, after an initial sync ending with "initial_sync_done".
   Other "ln.*" names fail with -LNE_REQUEST_FAILED; events with other names
   need no manager: a program emits them by calling the handler service. */

/** Subscription to an event source. */
typedef void* ln_event_connection;
/** One event being delivered (valid during the handler). */
typedef void* ln_event_call;

/** Receives an event; runs in the thread that handles the client's default
    service group. Unpack it with ln_event_call_set_data(). */
typedef void (*ln_event_handler)(ln_client clnt, ln_event_call call, void* user_data);

/** Connects to an event source.
    @param connect_signature the generated *_CONNECT_SIGNATURE
           ("<definition>: <signature>"; else -LNE_INVALID_SIGNATURE).
    @param connect_data the generated *_connect_t struct (filters).
    @return 0, -LNE_REQUEST_FAILED when this client is connected to the
            event already or the manager refuses (ln_get_error_message()). */
LN_API int ln_event_connect(ln_client clnt, ln_event_connection* conn, const char* event_name,
                            const char* connect_signature, void* connect_data, ln_event_handler handler,
                            void* user_data);
/** As ln_event_connect() with the connect data already flattened. */
LN_API int ln_event_connect_flat(ln_client clnt, ln_event_connection* conn, const char* event_name,
                                 const char* connect_signature, void* connect_data_flat, uint32_t connect_data_flat_len,
                                 ln_event_handler handler, void* user_data);
/** Disconnects (no event reaches the handler afterwards) and releases; sets
 *conn to NULL. */
LN_API int ln_event_connection_deinit(ln_event_connection* conn);
/** The connection's id, unique per client from 1 (LN 2.9 gives 0 to every
    connection to an event that is not "ln.*"). */
LN_API unsigned int ln_event_connection_get_id(ln_event_connection conn);
/** Unpacks an event into @p call_data (the generated *_call_t struct);
    @p call_signature is the generated *_CALL_SIGNATURE and must be the one
    the event came with (else -LNE_SVC_REQ_SET_DATA_WRONG); malformed event
    data: -LNE_SVC_RECV_REQ. Dynamic fields point into the call's memory. */
LN_API int ln_event_call_set_data(ln_event_call call, const char* call_signature, void* call_data);
/** The event's flat call data (belongs to the call). */
LN_API int ln_event_call_get_buffer(ln_event_call call, void** ptr, uint32_t* len);

/**@}*/

/* ======================================================================== */
/** @name Miscellaneous */
/* ======================================================================== */
/**@{*/

/** Sets a named setting of the client (LN 2.9's names): "debug" (the
    LN_DEBUG level, 0 = quiet), "reconnect_interval" (the longest wait, in
    seconds, between attempts to reach a restarted manager; 0 < value <=
    3600), "win32_async_ping_timeout", "win32_async_ping_interval",
    "win32_wait_for_service_request_timeout" (accepted; for Windows only).
    "__LN_CPP_WRAPPER_VERSION" answers 0 even without a client.
    @return 0; -LNE_UNKNOWN_PARAMETER for other names, -LNE_INVALID_PARAMETER
            for a value out of range or a NULL name. (Parameters that programs
            expose to others are a different thing: ln/parameters_c.h.) */
LN_API int ln_client_set_float_parameter(ln_client clnt, const char* name, float value);

/** Features of the shared-memory implementation (LN 2.9 diagnostics), each
    0 or 1: blocking reads sleep in futex(2) (1 on Linux), and the library
    was built against glibc 2.25 or later. NULL outputs are skipped. */
LN_API void ln_get_v16_features(unsigned int* is_with_sys_futex, unsigned int* is_glibc_atleast_2_25);

/** DSA signatures with SHA-1 ("DSS1"; OpenSSL's libcrypto does the work),
    interchangeable with LN 2.9's: keys in its files (a traditional PEM
    "BEGIN DSA PRIVATE KEY" file, an OpenSSH "ssh-dss ..." public key line),
    signatures DER-encoded. These functions return 0 on success, else
    -LNE_CHECK_ERRNO when a file cannot be read or written (errno says why;
    EINVAL: not a DSA key in the expected format), -LNE_INVALID_PARAMETER for
    a NULL argument.
    Signs @p message with the private key; @p *signature_out is malloc()ed,
    the caller frees it. */
LN_API int ln_dsa_dss1_sign_message(const char* pem_private_key_filename, const uint8_t* message,
                                    unsigned int message_len, uint8_t** signature_out, unsigned int* signature_out_len);
/** Verifies a signature against an OpenSSH public key file.
    @return 0 valid, -LNE_INVALID_DSA_SIGNATURE when it does not verify (also
    when it is no DER signature at all), other < 0 on error. */
LN_API int ln_dsa_dss1_verify_message_signature(const char* openssh_public_key_filename, const uint8_t* message,
                                                unsigned int message_len, const uint8_t* signature,
                                                unsigned int signature_len);
/** As ln_dsa_dss1_verify_message_signature() with the key line given as text
    (a trailing comment is allowed). */
LN_API int ln_dsa_dss1_verify_message_signature_memkey(const char* openssh_public_key_contents, const uint8_t* message,
                                                       unsigned int message_len, const uint8_t* signature,
                                                       unsigned int signature_len);
/** Writes a new 1024-bit DSA key pair: the PEM private key (mode 0600) and
    the OpenSSH public key; existing files are replaced atomically. */
LN_API int ln_dsa_dss1_generate_key_pair(const char* pem_private_key_filename, const char* openssh_public_key_filename);

/**@}*/

/* ======================================================================== */
/** @name Low-level shared-memory rings
    Named segments (/dev/shm/NAME) in LN 2.9's byte layout, shared by name
    between processes; topics do not use them (ports do that for you).
    Either side creates the segment (create_*: replaces one of that name;
    version 0..3, n_elements >= 1), the other opens it (open_*); close_*
    detaches, destroy_* also removes the name. A target writes packets of up
    to element_size bytes (get_next_buffer_from_shm_target() + a write with
    data NULL writes in place); a source reads them in order, each once,
    only those written after it attached; a reader that fell n_elements or
    more behind continues with the oldest packet still in the ring.
    read_last_from_shm_source() returns the newest packet again and again.
    Reads return 1 (a packet: the timestamp, the packet's number in
    *packet_counter and min(len, element_size) bytes), 0 (none; after a wait
    that timed out errno is ETIMEDOUT), -2 when unblock_shm_source() ended
    the wait. Version-3 segments interoperate with LN 2.9 processes in both
    directions (versions 0..2 only among ln_core processes). Other failures
    are < 0 with errno set: -1 (-LNE_CHECK_ERRNO) for system errors (ENOENT
    ...), -LNE_INVALID_SHM_MAGIC, -LNE_SHM_VERSION_TOO_NEW,
    -LNE_WRONG_SHM_SIZE, -LNE_SHM_NAME_TOO_LONG, -LNE_PACKET_TOO_LARGE,
    -LNE_INVALID_PARAMETER (NULL or stale handles, no elements). One writer
    at a time; the packet counter passed to reads is only written. */
/* ======================================================================== */
/**@{*/

typedef void* shm_target_t; /**< writer end of a ring */
LN_API int create_shm_target(shm_target_t*, const char* name, unsigned int element_size, unsigned int n_elements,
                             unsigned int version);
LN_API int destroy_shm_target(shm_target_t*);
LN_API int open_shm_target(shm_target_t*, const char* name);
LN_API int close_shm_target(shm_target_t*);
LN_API int write_to_shm_target(shm_target_t, double ts, void* data, unsigned int len);
LN_API int get_next_buffer_from_shm_target(shm_target_t, void** buffer);

typedef void* shm_source_t; /**< reader end of a ring */
LN_API int create_shm_source(shm_source_t*, const char* name, unsigned int element_size, unsigned int n_elements,
                             unsigned int version);
LN_API int destroy_shm_source(shm_source_t*);
LN_API int open_shm_source(shm_source_t*, const char* name);
/** The newest packet's number (0: none yet). Takes the handle or, as LN
    2.9's library does, the handle itself cast to shm_source_t*. */
LN_API int shm_source_get_last_counter(shm_source_t* source_, uint32_t* counter);
LN_API int close_shm_source(shm_source_t*);
LN_API int read_from_shm_source(shm_source_t, double* ts, uint32_t* packet_counter, void* data, unsigned int len,
                                int blocking);
LN_API int read_from_shm_source_timeout(shm_source_t, double* ts, uint32_t* packet_counter, void* data,
                                        unsigned int len, double timeout);
LN_API int read_last_from_shm_source(shm_source_t, double* ts, uint32_t* packet_counter, void* data, unsigned int len);
/** Waits until the segment's newest packet number differs from
    *packet_counter (timeout < 0: no limit), stores it there and counts it as
    read: 1, 0 (timeout, errno ETIMEDOUT) or -2 (unblocked). */
LN_API int block_only_on_shm_source(shm_source_t source_, uint32_t* packet_counter, double timeout);
LN_API int unblock_shm_source(shm_source_t source_);

#ifdef __ANDROID__
LN_API int get_shm_fd(void* source_or_target, unsigned int* shm_size);
#define ANDROID_FD_UNIX_SOCKET "\0ln_android_fd_unix_socket"
#endif

/**@}*/

/* ======================================================================== */
/** @name ln_core extensions
    Not part of LN 2.9. Portable code tests LN_CORE_EXTENSIONS before using
    them. Return conventions as above: >= 0 success, -LNE_* on failure. */
/* ======================================================================== */
/**@{*/

/** Defined (as the extension API level) when the ln_core extensions below
    are available. */
#define LN_CORE_EXTENSIONS 1

/** What a read delivered besides the packet. */
typedef struct ln_sample_info {
  /** The publisher's packet counter: increases by one per ln_write() on the
      topic and starts again when a new publisher takes over. */
  uint64_t sequence;
  /** Packets published since the previous packet this port delivered that
      this port skipped: overwritten in the ring before being read, dropped
      in transport (also on the network, from a publisher on another host),
      or left out by a rate limit. For the first packet after subscribing or
      after a publisher change: those skipped since that publisher counted
      the subscription (has_subscriber), usually 0. */
  uint64_t lost;
  /** The publisher's timestamp of the packet (as ln_read() reports it). */
  double timestamp;
} ln_sample_info;

/** ln_read_timeout() that also reports sequence and loss.
    @param timeout < 0 waits without limit, 0 polls, > 0 waits at most that
           many seconds.
    @param[out] info filled when a packet was copied; may be NULL.
    @return 1 packet copied, 0 none within the timeout, -LNE_PORT_UNBLOCKED,
            or another error. */
LN_API int ln_read_with_info(ln_inport port, void* packet, unsigned int size, ln_sample_info* info, double timeout);

/** Zero-copy read: lends the next unread packet in place instead of copying
    it.

    On success @p *packet points to the packet (read-only, ln_get_message_size()
    bytes, reported in @p *size) and stays valid and unchanged until
    ln_read_release() on this port, however many packets the publisher
    writes meanwhile: the lent ring slot is skipped by the publisher until it
    is released. Each port lends at most one packet at a time, which is what
    keeps the publisher's ring usable; release promptly, since the slot is
    missing from the ring meanwhile. Where no shared memory segment is
    involved (remote publisher, RATE_ON_REQUEST_LAST) the packet lies in a
    buffer of the port instead, with the same guarantees.

    @param[out] packet, size the lent packet.
    @param[out] info as for ln_read_with_info(); may be NULL.
    @param timeout as for ln_read_with_info().
    @return 1 a packet is lent (release it), 0 no new packet within the
            timeout (nothing to release), -LNE_PORT_UNBLOCKED,
            -LNE_INVALID_PARAMETER if the previous loan was not released yet,
            or another error. Other reads on the port are allowed while a
            packet is lent; the loan belongs to the port, not to a thread.
            ln_unsubscribe() ends an outstanding loan. */
LN_API int ln_read_borrow(ln_inport port, const void** packet, unsigned int* size, ln_sample_info* info,
                          double timeout);

/** Ends the loan of ln_read_borrow(); the packet pointer becomes invalid.
    @return 0, or -LNE_INVALID_PARAMETER if nothing was lent. */
LN_API int ln_read_release(ln_inport port);

/** Waits until a provider for @p service_name is registered with the
    manager. Unlike ln_needs_provider() it never starts a process.
    @param timeout < 0 waits without limit, 0 only checks, > 0 seconds.
    @return 1 provider registered, 0 not within the timeout, < 0 error. */
LN_API int ln_wait_for_service(ln_client clnt, const char* service_name, double timeout);

/** Waits for an asynchronous call (ln_service_call_async()) to finish.
    @param timeout < 0 waits without limit, 0 polls, > 0 seconds.
    @param[out] retval as for ln_service_request_finished().
    @return 1 finished (retval set), 0 still running after the timeout, < 0
            error. */
LN_API int ln_service_request_wait(ln_service_request req, double timeout, int* retval);

/** Provider side: fails a request with an error code and an explanation
    that travels to the caller (see ln_service_request_get_error_message()).
    Counts as the response: the handler returns 0 afterwards. Usable for
    deferred (-LNE_SVC_RESP_LATER) requests too. Thread-safe.
    @param error > 0 an application error code, < 0 an LN code; 0 and
           -LNE_SVC_RESP_LATER are refused (-LNE_INVALID_PARAMETER).
    @param message explanation for the caller; may be NULL.
    @return 0, -LNE_SVC_HANDLER_MULTI_RESP if the request was already
            answered, or another error. */
LN_API int ln_service_request_respond_error(ln_service_request req, int error, const char* message);

/** Caller side: the provider's explanation of a failed asynchronous call
    (see ln_service_request_respond_error()), or an LN description of the
    failure. NULL while running, after success, or when there is none.
    Belongs to the request (valid as long as the request handle). */
LN_API const char* ln_service_request_get_error_message(ln_service_request req);

/** Called when a watched service provider or topic publisher appears
    (available = 1) or disappears (available = 0).

    Runs in a thread of the library: return quickly, and do not call
    ln_deinit() from it. Calling other functions of the client (including
    the set_*_availability_handler functions) is allowed. */
typedef void (*ln_availability_handler)(ln_client clnt, const char* name, int available, void* user_data);

/** Watches whether a provider of @p service_name is registered.

    Right after installing, the handler is called once with the current
    state, then at every change. One handler per name and client: installing
    another replaces it, a NULL handler removes it. After this function
    returns, the previous handler for that name neither runs in another
    thread nor will be called again, so its user_data may be freed; called
    from inside that handler, the running invocation simply completes.
    ln_deinit() removes all availability handlers the same way. */
LN_API int ln_set_service_availability_handler(ln_client clnt, const char* service_name,
                                               ln_availability_handler handler, void* user_data);

/** Watches whether @p topic_name has a publisher; otherwise as
    ln_set_service_availability_handler(). */
LN_API int ln_set_publisher_availability_handler(ln_client clnt, const char* topic_name,
                                                 ln_availability_handler handler, void* user_data);

/* ---- Introspection: what the manager knows (like `ln topic list`) ---- */

/** One topic of ln_list_topics(). */
typedef struct ln_topic_info {
  const char* name;
  const char* message_definition; /**< the topic's message-definition name */
  const char* hash;               /**< that definition's hash */
  unsigned int message_size;      /**< bytes per packet */
  const char* publisher;          /**< client name of the publisher, "" if none */
  unsigned int subscribers;       /**< number of subscriptions */
  /** Packets the publisher wrote, as it last reported: publishers report
      about once per second while they write. 0 without publisher. */
  uint64_t packets;
  /** Packets per second over the publisher's last report interval (about
      one second); 0 once it stopped writing or reporting, or without
      publisher. */
  double rate;
} ln_topic_info;

/** One client of ln_list_clients(). The name lists are NULL-terminated
    arrays (possibly just the NULL), sorted by name. */
typedef struct ln_client_info {
  const char* name;
  int64_t id;                    /**< the manager's id of the client */
  int64_t pid;                   /**< process id on its host (0 if it did not say) */
  const char* host;              /**< host name */
  const char* host_id;           /**< boot id + network namespace: clients with equal
                                      ids share memory */
  const char* const* published;  /**< topics it publishes */
  const char* const* subscribed; /**< topics it subscribes to */
  const char* const* services;   /**< services it provides */
} ln_client_info;

/** One service of ln_list_services(). */
typedef struct ln_service_info {
  const char* name;
  const char* interface; /**< service definition name, may carry "|hash" */
  const char* signature; /**< the provider's service signature */
  const char* provider;  /**< client name of the provider */
  const char* group;     /**< its service group, "" for none */
} ln_service_info;

/** The manager itself (ln_get_manager_status()). */
typedef struct ln_manager_status {
  const char* version;   /**< e.g. "ln_core 0.1.0" */
  int64_t pid;           /**< process id of the manager */
  const char* address;   /**< "IP:PORT" it listens on */
  double uptime;         /**< seconds since it started listening */
  unsigned int clients;  /**< clients registered now */
  unsigned int topics;   /**< topics known now */
  unsigned int services; /**< services registered now */
  /** Its message-definition search path, in search order, NULL-terminated. */
  const char* const* message_definition_dirs;
} ln_manager_status;

/** Lists the topics the manager knows (published or only subscribed), in
    the order they appeared.
    @param[out] topics receives @p *count entries in a single block of memory,
                strings included; release it with ln_free_list(). Never NULL
                on success, even when the list is empty.
    @param[out] count number of entries.
    @return 0, -LNE_LOST_CONNECTION, -LNE_MANAGER_TOO_OLD (a manager without
            introspection), or another error. */
LN_API int ln_list_topics(ln_client clnt, ln_topic_info** topics, unsigned int* count);

/** Lists the registered clients in the order they registered; otherwise as
    ln_list_topics(). */
LN_API int ln_list_clients(ln_client clnt, ln_client_info** clients, unsigned int* count);

/** Lists the registered services in the order they registered; otherwise as
    ln_list_topics(). */
LN_API int ln_list_services(ln_client clnt, ln_service_info** services, unsigned int* count);

/** Describes the manager.
    @param[out] status receives one entry in a single block of memory;
                release it with ln_free_list().
    @return as ln_list_topics(). */
LN_API int ln_get_manager_status(ln_client clnt, ln_manager_status** status);

/** A copy of logger data that belongs to the caller (free it with
    ln_logger_data_deinit()): a download kept beyond the logger's next one.
    @return 0, or -LNE_INVALID_PARAMETER for an invalid handle. */
LN_API int ln_logger_data_copy(ln_logger_data logger_data, ln_logger_data* copy);

/** Releases the result of ln_list_topics(), ln_list_clients(),
    ln_list_services(), ln_get_manager_status(), ln_list_processes() or
    ln_get_process_output(); NULL does nothing. Every pointer into the block
    becomes invalid. */
LN_API void ln_free_list(void* list);

/**@}*/

/* ======================================================================== */
/** @name ln_core: processes, states and groups of the manager
    The manager runs what its .lnc config describes (process, state and
    group sections). These calls list them, start and stop them and read
    their output, as `ln process|state|group` does. A manager without a
    config that has any lists nothing. */
/* ======================================================================== */
/**@{*/

/** One process, state or group (ln_list_processes()). */
typedef struct ln_process_info {
  const char* name;
  const char* kind; /**< "process", "state" or "group" */
  /** processes: "stopped", "starting" (waiting for its dependencies),
      "started" (runs; not ready yet, or without a ready condition), "ready",
      "stopping", "restarting" (waiting for its automatic restart), "failed";
      states: "UP", "DOWN", "unknown", "checking", "going up", "going down",
      "error"; groups: "N/M running" */
  const char* state;
  const char* requested; /**< on its way: "start", "stop", "up", "down", "check" or "" */
  int64_t pid;           /**< 0 when it does not run */
  double uptime;         /**< seconds since it started; 0 when it does not run */
  unsigned int restarts; /**< automatic restarts so far */
  /** Processes: ready (or running without a ready condition); states: UP;
      groups: every member process runs. */
  int ready;
  const char* last_exit; /**< how it ended last: "exit status 3", "killed by SIGKILL", "" */
  const char* error;     /**< why it failed or cannot start, "" */
  const char* command;   /**< a process's command, a state's check command */
  /** What it depends on (NULL-terminated): "a|b" is satisfied by either
      (providers), "!s" needs state s DOWN. */
  const char* const* depends_on;
  const char* const* members; /**< groups: their processes and states (NULL-terminated) */
} ln_process_info;

/** Lists the manager's processes, states and groups (in that order, each in
    config order); memory and return values as ln_list_topics(). */
LN_API int ln_list_processes(ln_client clnt, ln_process_info** processes, unsigned int* count);

/** Asks the manager to start, stop or restart a process or group, or to
    bring a state up or down or check it; returns once the manager accepted
    the request (ln_list_processes() tells how it goes).
    @param action "start", "stop", "restart" (processes, groups) or "up",
           "down", "check" (states)
    @param alt_command NULL, or the name of one of the process's
           alt_command keys to start it with
    @return 0, -LNE_INVALID_PARAMETER (no such name or action; see
            ln_get_error_message()), -LNE_REQUEST_FAILED (refused: the flag
            disable_stop, the manager shuts down), or another error. */
LN_API int ln_control_process(ln_client clnt, const char* name, const char* action, const char* alt_command);

/** Output of a process or state (ln_get_process_output()); lines are
    numbered from 1 in the order the manager received them. */
typedef struct ln_process_output {
  const char* const* lines; /**< NULL-terminated, oldest first, without newlines */
  uint64_t first;           /**< number of lines[0] */
  uint64_t last;            /**< number of the newest line the manager has (0: none yet) */
  uint64_t dropped;         /**< lines after `after` that the manager no longer keeps */
} ln_process_output;

/** The lines a process or state printed after line number `after` (0: all
    the manager keeps; see the config key max_output_lines); ask again with
    `after` = last to follow it. Release with ln_free_list().
    @return 0, -LNE_INVALID_PARAMETER (no such process or state), or
            another error. */
LN_API int ln_get_process_output(ln_client clnt, const char* name, uint64_t after, ln_process_output** output);

/**@}*/

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* LN_H */
