// The conversation between clients and the manager, and between clients.
// Every message is a protocol::Message (wire.hpp). This file is the contract:
// the field lists below are what each side sends and what it may rely on.
// A request that fails gets an error response: error_code (a positive
// LNE_* value from ln/ln.h) and error (text for the user).
// Manager conventions (src/manager): ids it hands out (client, topic,
// subscription, service) are positive and come from one sequence. A missing
// or mistyped field -> LNE_INVALID_PARAMETER; an unknown method ->
// LNE_MANAGER_TOO_OLD; invalid topic/service/definition names ->
// LNE_INVALID_PARAMETER; an unknown topic or a topic/subscription id the
// client does not own -> LNE_PORT_NOT_FOUND; other refusals ->
// LNE_REQUEST_FAILED unless a method names a code. Responses and
// notifications other than topic_stats sent to the manager are ignored.
// A malformed frame, a request larger than 4 MiB, or more than 16 MiB of
// unsent messages (a client that does not read) closes the connection,
// which releases the client. So do the manager's other limits
// (manager.hpp ManagerLimits, all configurable): a connection must say hello
// within 10 s and send something every 2 s until then, may send 64 KiB
// before it, and the oldest unregistered connection is closed when there
// are more than 64 from one address or 256 in all; when all connections'
// partly received requests exceed 64 MiB (unsent messages: 256 MiB) the one
// holding the most is closed. A connection's requests are handled at most
// 16 in a row before other connections get their turn. A client may hold
// 4096 topics it publishes, subscriptions and services together
// (max_ports_per_client; beyond: LNE_REQUEST_FAILED).
//
// ---------------------------------------------------------------------------
// Client -> manager requests (over the client's TCP connection)
//
// hello            program_name (str), exact (bool: an "exact:" name),
//                  pid (int), host_name (str), host_id (str: boot id + network
//                  namespace; equal ids can share memory and Unix sockets),
//                  uid (int), library_version (int), peer_socket (str: the
//                  abstract Unix socket name of the client's peer server),
//                  peer_address (str: "IP:PORT" of its TCP peer server),
//                  previous_name (str, optional: the name it had before a
//                  manager restart; granted again when free)
//   -> client_name (str), client_id (int), manager_version (str)
//   The first message on a connection; anything else first is refused
//   (LNE_CLIENT_NOT_INITIALIZED), a second hello too (LNE_REGISTER_DENIED).
//   program_name is the name without "exact:"; only it is required, the
//   other fields default to ""/0. An exact name that is taken ->
//   LNE_CLNT_NAME_IN_USE; otherwise previous_name when free, else
//   program_name made unique with " 1", " 2", ...
//
// goodbye          (no fields) -> ok. The manager releases everything the
//                  client owns, as it does when the connection drops, and
//                  closes the connection after the response.
//
// ping             (no fields) -> ok
//
// get_message_definition   name (str: "md/name" or "md/name|hash")
//   -> name (str), hash (str), names (list), texts (list): the definition
//      and every definition it imports, so the client can rebuild the model
//      with md::Library; first entry is `name`. Also message_size (int:
//      md::packet_size). Names that are not valid definition names
//      (paths, "..") are refused; "not found" lists the searched dirs.
// get_message_definition_for_topic   topic (str) -> as above
// put_message_definition   name (str), text (str) -> name (str: real name), hash
//   The text is parsed first (LNE_INVALID_PARAMETER if it does not) and
//   stored in the generated-definitions dir, which is searched right after
//   the config's dirs, so the real name is `name`. The same content again
//   is a no-op; different content is refused when `name` exists outside the
//   generated dir or a topic uses it. Refused (LNE_REQUEST_FAILED) beyond
//   the quota: max_stored_definitions / _bytes in the dir, and
//   max_definitions_per_client new texts (parsed) per registration.
//
// publish          topic (str), message_definition (str, may carry |hash),
//                  buffers (int >= 1)
//   -> topic_id (int), message_size (int), hash (str),
//      subscriber_buffers (int: the largest buffers any subscriber asked for),
//      segment_limit (int: the largest segment the publisher may make for
//      the topic, max_topic_shm; it grows no bigger for any subscriber)
//   The publisher then creates its shared-memory segment and sends
//   publisher_ready; only then are subscribers told. buffers 1..65536.
//   subscriber_buffers is 0 without subscribers. A subscribers_changed
//   notification always follows the response. Refused: a topic that has a
//   publisher ("topic 'T' already published by client 'C'"), another
//   definition than the topic's ("you requested message_definition 'X' but
//   topic 'T' uses 'Y'"), service/event definitions and definitions with
//   dynamic fields (LNE_INVALID_PARAMETER), a wrong |hash (LNE_WRONG_MD_HASH),
//   and (LNE_SHM_IS_TOO_BIG, the message names the limit and how many
//   buffers fit) buffers whose segment (transport::topic_segment_size with
//   the subscribers' buffers) exceeds max_topic_shm, or makes the client's
//   published topics together exceed max_client_shm.
// publisher_ready  topic_id (int), segment_generation (int >= 0),
//                  packets (int >= 0, optional: the publisher's packet count
//                  now, see topic_stats), recovered (int, optional: the
//                  publisher replaced a segment it found corrupted, this
//                  many times so far; the manager logs it) -> ok
//   May be repeated (a new segment): subscribers get publisher_available
//   again. The first one after a publish is announced to every client as
//   topic_publisher_available. `packets` starts a new rate interval.
// unpublish        topic_id (int) -> ok   (publisher_gone goes to the
//                  subscribers that were told publisher_available, and
//                  topic_publisher_gone to every client if
//                  topic_publisher_available was sent)
//
// subscribe        topic (str), message_definition (str, may carry |hash;
//                  "" = whatever the topic uses), buffers (int >= 1),
//                  rate (double: -1 all, > 0 per second, -2 or -3 on request),
//                  reliable (bool), receive_address (str: "IP:PORT" where the
//                  client accepts remote data for this subscription)
//   -> subscription_id (int), topic_id (int), message_size (int), hash (str),
//      message_definition (str), and when the topic has a publisher the
//      publisher fields of the publisher_available notification (only once
//      that publisher sent publisher_ready).
//   "" for an unknown topic -> LNE_PORT_NOT_FOUND; definition and
//   shared-memory checks as for publish (buffers beyond the topic's current
//   segment count against the topic's and its publisher's limits).
// unsubscribe      subscription_id (int) -> ok
//
// register_service     name, interface, signature (str), group (str)
//   -> service_id (int), log_services (list: the service loggers that get
//      copies of its responses, see register_as_service_logger)
//   group is optional. The interface must be a valid definition name (may
//   carry |hash); it is not resolved. A taken name -> LNE_SVC_ALREADY_REGISTERED.
// unregister_service   service_id (int) -> ok  (not yours: LNE_SVC_NOT_REGISTERED)
// lookup_service       name, interface (str, "" = any), signature (str)
//   -> interface, signature, provider (str: client name), host_id,
//      peer_socket, peer_address, service_id, log_services (list: the
//      service loggers that get copies of the caller's requests)
//   Unknown name -> LNE_NO_PROVIDER_FOUND. Interfaces are compared by name
//   (hashes too when both carry one: LNE_WRONG_MD_HASH); signatures as
//   strings, "" = not checked; mismatches -> LNE_REQUEST_FAILED.
// get_service_signature            interface (str) -> definition, signature
// get_service_signature_for_service name (str) -> interface, definition, signature
//   definition is the text of the interface's definition; both also carry
//   the bundle fields of get_message_definition. signature: computed from the
//   definition (get_service_signature) or the provider's registered one
//   (..._for_service).
// find_services_with_interface     interface (str) -> services (list, sorted)
//
// connect_event    name (str: "ln.resource_event", the only event there is),
//                  signature (str: "<definition>: <connect signature>"),
//                  connect_data (str: the flat connect section: four
//                  fnmatch patterns), handler (str: the client's service,
//                  interface ln/event/call, that receives the events)
//   -> event_connection_id (int). Then the initial sync arrives as `event`
//   notifications (manager/events.hpp). Other names -> LNE_REQUEST_FAILED;
//   a signature that is not ln/resource_event's -> LNE_INVALID_SIGNATURE.
//   Events other than ln.resource_event are not the manager's: their
//   clients only register the handler service (the client library).
// disconnect_event event_connection_id (int) -> ok
//
// register_as_service_logger  logger_service (str: a service of the client,
//                  interface ln/log_service), patterns (str: comma-separated
//                  fnmatch patterns of service names, "!pattern" excludes)
//   -> ok. Callers and providers of matching services (of other clients;
//   never the logger service itself) send it a copy of every request and
//   response (ln/log_service; client/service_logging.hpp). Not a service
//   of the client -> LNE_SVC_NOT_REGISTERED.
//
// list_clients / list_topics / list_services (no fields) -> introspection
//   tables as parallel lists of strings, one entry per row (numbers in
//   decimal, name lists comma-joined):
//   list_clients:  names, ids, pids, hosts (host_name), host_ids, published,
//                  subscribed, services (comma-joined names, sorted)
//   list_topics:   names, ids, definitions, hashes, message_sizes,
//                  publishers ("" = none), subscribers (count),
//                  packets (the current publisher's packet count at its last
//                  topic_stats report; "0" without publisher), rates
//                  (packets per second over the interval that report closed,
//                  in shortest form rounded to 0.001, e.g. "99.87"; "0" when
//                  the count stopped changing, without publisher, and when
//                  the publisher sent no report for 3 s)
//   list_services: names, ids, interfaces, signatures, providers, groups
//
// manager_status   (no fields) -> version (str: as hello's manager_version),
//                  pid (int), address (str: "IP:PORT" it listens on),
//                  uptime (double: seconds since it started listening),
//                  clients, topics, services (int: how many there are now),
//                  message_definition_dirs (list: the definition search path
//                  in search order: configured dirs, generated dir, standard
//                  dirs; only directories that exist)
//
// Topic loggers (manager/loggers.hpp): the manager records, a logger is a
// name; its recording lives in the manager until the logger is enabled again.
// logger_enable    name (str), topics (list: topic names, in the logger's
//                  order), log_sizes (list: samples kept per topic, decimal,
//                  >= 1), divisors (list: record every n-th packet, decimal,
//                  0 counts as 1), only_ts (bool)
//   -> ok once every listed topic with a ready publisher records (the answer
//   waits for the recorder to attach to the publishers' segments); topics
//   without a publisher are recorded from its publisher_ready on. Starts a new
//   recording (earlier samples of the logger are dropped). Lists of unequal
//   length, log size 0, invalid topic names -> LNE_INVALID_PARAMETER; logs that
//   do not fit the manager's memory -> LNE_NO_MEM; a publisher whose segment
//   cannot be attached (another host) -> LNE_REQUEST_FAILED (the other
//   topics record).
// logger_disable   name -> ok; packets written before the request are
//   recorded, none after. An unknown logger is not an error.
// logger_download  name -> download (int), topics, log_sizes, divisors,
//   n_samples, sample_sizes (lists, numbers in decimal), md_names, mds (lists:
//   definition name and md::python_dict_text, "" for a topic never seen
//   published): a frozen view of the recording (an enabled logger goes on
//   recording). A logger never enabled -> LNE_REQUEST_FAILED.
// logger_download_data  download (int), topic (int: index), offset (int:
//   byte offset) -> data (str: the topic's samples from offset on, at most
//   logger::kDownloadChunk bytes). A view lives until the client's next
//   logger_download or until it leaves.
// logger_manager_save  name, filename, format (str) -> ok once the manager
//   wrote the file on its host (formats: manager/log_files.hpp).
//
// ---------------------------------------------------------------------------
// Client -> manager requests: the processes, states and groups of the config
// (manager/process_control.hpp). A manager without them answers an empty
// process_list and refuses the others for an unknown name.
//
// process_list     (no fields) -> introspection table as for list_topics:
//                  names, kinds ("process", "state", "group"), states,
//                  requested, pids, uptimes (seconds, shortest form),
//                  restarts, ready ("1"/"0"), last_exits, errors, commands,
//                  depends_on (comma-joined; "a|b" for alternatives, "!s" for
//                  a state that must be DOWN), members (groups, comma-joined)
//   Values as ObjectStatus (process_control.hpp) describes them.
// process_control  name (str), action (str: start, stop, restart for
//                  processes and groups; up, down, check for states),
//                  alt_command (str, optional: a process's alt_command to
//                  start with) -> ok once the request is accepted (it does
//                  not wait for the process: process_list tells).
//   Unknown name or action -> LNE_INVALID_PARAMETER; refused (the flag
//   disable_stop, shutting down) -> LNE_REQUEST_FAILED.
// process_output   name (str: a process or state), after (int >= 0: the
//                  number of the last line already seen; 0 = from the
//                  oldest kept), max_lines (int >= 0, optional: 0 = up to
//                  10000) -> lines (list), first (int: number of lines[0]),
//                  last (int: number of the newest line), dropped (int:
//                  lines after `after` the ring no longer holds)
// needs_provider   name (str: a service or topic) -> provider (str: "" when
//                  a registered client already provides or publishes it,
//                  else the process or state asked to start)
//   Nothing provides it and no process or state `provides` it ->
//   LNE_NO_PROVIDER_FOUND. The client then waits for the service or
//   publisher itself, and asks process_list whether the provider failed.
//
// ---------------------------------------------------------------------------
// Client -> manager notifications (the only notifications the manager reads;
// others, and those of a connection without hello, are dropped)
//
// topic_stats      topic_id (int: a topic the client publishes), packets
//                  (int >= 0: the publisher's total packets written on it)
//   Topic data never passes the manager, so publishers count for it: the
//   client library's I/O thread sends this about once per second per
//   published topic while the count changes, once more when it stopped
//   changing (so the rate drops to 0), then nothing until it changes again.
//   The manager's rate is (packets - previous count) / (seconds between the
//   two, by its own clock); the first interval starts at publish (count 0)
//   or at a publisher_ready that carries `packets`. A count below the
//   previous one restarts the interval (rate 0); reports for topics the
//   client does not publish are ignored.
//
// ---------------------------------------------------------------------------
// Manager -> client notifications
//
// publisher_available  subscription_id (int), topic_id (int),
//                      publisher (str: client name), host_id, peer_socket,
//                      peer_address (str), segment_generation (int)
// publisher_gone       subscription_id (int), topic_id (int)
// subscribers_changed  topic_id (int), subscribers (int),
//                      subscriber_buffers (int), local (list of the
//                      subscription ids, in decimal, of the subscribers on
//                      the publisher's host, which read its segment),
//                      remote (list of
//                      "subscription_id rate reliable IP:PORT" for subscribers
//                      on other hosts, which the publisher feeds itself;
//                      rate in shortest form ("-1", "10", "0.5"), reliable
//                      "1"/"0"; subscribers without an address are left out)
//   The publisher remembers, per local subscription id, its newest packet
//   when the id first appeared (before the new count is visible to the
//   program); open_segment answers with it.
// event                event_connection_id (int), handler (str: the service
//                      named at connect_event), data (str: the flat call
//                      section of the event), signature (str: "<definition>:
//                      <call signature>"). The client calls its handler
//                      service with {data, signature}, one event at a time.
// add_service_logger   service (str), logger_service (str): from now on
//                      send copies of `service`'s calls (as caller or
//                      provider) to logger_service
// del_service_logger   logger_service (str): it is gone (or re-registered)
// service_available    name (str), provider (str)   [for availability callbacks]
// service_gone         name (str)
//   Both go to every registered client (the provider too), for changes after
//   its hello; lookup_service tells the current state.
// topic_publisher_available  name (str: topic), publisher (str: client name)
// topic_publisher_gone       name (str: topic)
//   Both go to every registered client (the publisher too): available at the
//   first publisher_ready after a publish, gone when that publisher
//   unpublishes or leaves (crashes included). For publisher availability
//   callbacks; list_topics tells the current state.
//
// ---------------------------------------------------------------------------
// Client -> client (peer server: abstract Unix socket on one host, TCP across)
//
// open_segment     topic_id (int), subscription_id (int), topic (str,
//                  optional: the publisher may look the port up by name),
//                  buffers (int, optional: the subscriber's buffers; the
//                  publisher grows its segment to at least that many slots
//                  before answering)
//   A publisher that has not seen subscription_id in a subscribers_changed
//   `local` list yet holds the answer until it does (at most 0.5 s), so that
//   a subscriber gets no packet before the publisher counts it.
//   -> message_size, slots, segment_generation (int), last_sequence (int:
//      the subscriber reads the packets after this one: the publisher's
//      newest packet when subscribers_changed first listed subscription_id
//      in `local` (raised to just before the segment's first packet if the
//      segment was replaced since), or, when it was not listed within the
//      wait, the newest packet written so far; 0 = every packet in the
//      segment) and
//      the segment's file descriptor passed with SCM_RIGHTS alongside the
//      response frame.
//      Only answered for peers with the same uid (SO_PEERCRED), or a uid
//      LN_PEER_ALLOW_UIDS lists; `buffers` grows the segment only up to the
//      publish answer's segment_limit.
// call             service_id (int), request (str: the flattened request)
//   -> response (str) or an error response; see the services code.
//   On this host only for peers of the same uid (or LN_PEER_ALLOW_UIDS), as
//   open_segment; over TCP for anyone.
//   As implemented by services/ (call_frames.hpp): the caller opens a
//   connection of its own per service handle and sends `call` with
//   service_id only, as the handshake. The peer server answers ok if
//   services::Dispatcher::has_provider(service_id) (else an error response
//   with LNE_SVC_NOT_REGISTERED), then hands the socket to
//   Dispatcher::adopt_connection() and stops reading it. The caller sends
//   nothing before that ok. From then on both sides exchange only the
//   binary service frames of services/call_frames.hpp (same u32 size
//   envelope; first payload byte 0x10/0x11, never a Message kind).
#pragma once

#include <string_view>

namespace ln::protocol::method {

inline constexpr std::string_view hello = "hello";
inline constexpr std::string_view goodbye = "goodbye";
inline constexpr std::string_view ping = "ping";
inline constexpr std::string_view get_message_definition = "get_message_definition";
inline constexpr std::string_view get_message_definition_for_topic = "get_message_definition_for_topic";
inline constexpr std::string_view put_message_definition = "put_message_definition";
inline constexpr std::string_view publish = "publish";
inline constexpr std::string_view publisher_ready = "publisher_ready";
inline constexpr std::string_view unpublish = "unpublish";
inline constexpr std::string_view subscribe = "subscribe";
inline constexpr std::string_view unsubscribe = "unsubscribe";
inline constexpr std::string_view register_service = "register_service";
inline constexpr std::string_view unregister_service = "unregister_service";
inline constexpr std::string_view lookup_service = "lookup_service";
inline constexpr std::string_view get_service_signature = "get_service_signature";
inline constexpr std::string_view get_service_signature_for_service = "get_service_signature_for_service";
inline constexpr std::string_view find_services_with_interface = "find_services_with_interface";
inline constexpr std::string_view list_clients = "list_clients";
inline constexpr std::string_view list_topics = "list_topics";
inline constexpr std::string_view list_services = "list_services";
inline constexpr std::string_view manager_status = "manager_status";
inline constexpr std::string_view topic_stats = "topic_stats";
inline constexpr std::string_view logger_enable = "logger_enable";
inline constexpr std::string_view logger_disable = "logger_disable";
inline constexpr std::string_view logger_download = "logger_download";
inline constexpr std::string_view logger_download_data = "logger_download_data";
inline constexpr std::string_view logger_manager_save = "logger_manager_save";
inline constexpr std::string_view process_list = "process_list";
inline constexpr std::string_view process_control = "process_control";
inline constexpr std::string_view process_output = "process_output";
inline constexpr std::string_view needs_provider = "needs_provider";
inline constexpr std::string_view connect_event = "connect_event";
inline constexpr std::string_view disconnect_event = "disconnect_event";
inline constexpr std::string_view register_as_service_logger = "register_as_service_logger";

inline constexpr std::string_view publisher_available = "publisher_available";
inline constexpr std::string_view publisher_gone = "publisher_gone";
inline constexpr std::string_view subscribers_changed = "subscribers_changed";
inline constexpr std::string_view event = "event";
inline constexpr std::string_view add_service_logger = "add_service_logger";
inline constexpr std::string_view del_service_logger = "del_service_logger";
inline constexpr std::string_view service_available = "service_available";
inline constexpr std::string_view service_gone = "service_gone";
inline constexpr std::string_view topic_publisher_available = "topic_publisher_available";
inline constexpr std::string_view topic_publisher_gone = "topic_publisher_gone";

inline constexpr std::string_view open_segment = "open_segment";
inline constexpr std::string_view call = "call";

}  // namespace ln::protocol::method
