// The conversation between clients and the manager, and between clients.
// Every message is a protocol::Message (wire.hpp). This file is the contract:
// the field lists below are what each side sends and what it may rely on.
// A request that fails gets an error response: error_code (a positive
// LNE_* value from ln/ln.h) and error (text for the user).
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
//   The first message on a connection; anything else first is refused.
//
// goodbye          (no fields) -> ok. The manager releases everything the
//                  client owns, as it does when the connection drops.
//
// ping             (no fields) -> ok
//
// get_message_definition   name (str: "md/name" or "md/name|hash")
//   -> name (str), hash (str), names (list), texts (list): the definition
//      and every definition it imports, so the client can rebuild the model
//      with md::Library; first entry is `name`.
// get_message_definition_for_topic   topic (str) -> as above
// put_message_definition   name (str), text (str) -> name (str: real name), hash
//
// publish          topic (str), message_definition (str, may carry |hash),
//                  buffers (int >= 1)
//   -> topic_id (int), message_size (int), hash (str),
//      subscriber_buffers (int: the largest buffers any subscriber asked for)
//   The publisher then creates its shared-memory segment and sends
//   publisher_ready; only then are subscribers told.
// publisher_ready  topic_id (int), segment_generation (int) -> ok
// unpublish        topic_id (int) -> ok
//
// subscribe        topic (str), message_definition (str, may carry |hash;
//                  "" = whatever the topic uses), buffers (int >= 1),
//                  rate (double: -1 all, > 0 per second, -2 on request),
//                  reliable (bool), receive_address (str: "IP:PORT" where the
//                  client accepts remote data for this subscription)
//   -> subscription_id (int), topic_id (int), message_size (int), hash (str),
//      message_definition (str), and when the topic has a publisher the
//      publisher fields of the publisher_available notification.
// unsubscribe      subscription_id (int) -> ok
//
// register_service     name, interface, signature (str), group (str)
//   -> service_id (int)
// unregister_service   service_id (int) -> ok
// lookup_service       name, interface (str, "" = any), signature (str)
//   -> interface, signature, provider (str: client name), host_id,
//      peer_socket, peer_address, service_id
// get_service_signature            interface (str) -> definition, signature
// get_service_signature_for_service name (str) -> interface, definition, signature
// find_services_with_interface     interface (str) -> services (list)
//
// list_clients / list_topics / list_services (no fields) -> introspection
//   tables as parallel lists (see the manager's implementation).
//
// ---------------------------------------------------------------------------
// Manager -> client notifications
//
// publisher_available  subscription_id (int), topic_id (int),
//                      publisher (str: client name), host_id, peer_socket,
//                      peer_address (str), segment_generation (int)
// publisher_gone       subscription_id (int), topic_id (int)
// subscribers_changed  topic_id (int), subscribers (int),
//                      subscriber_buffers (int), remote (list of
//                      "subscription_id rate reliable IP:PORT" for subscribers
//                      on other hosts, which the publisher feeds itself)
// service_available    name (str), provider (str)   [for availability callbacks]
// service_gone         name (str)
//
// ---------------------------------------------------------------------------
// Client -> client (peer server: abstract Unix socket on one host, TCP across)
//
// open_segment     topic_id (int), subscription_id (int)
//   -> message_size, slots, segment_generation (int) and the segment's file
//      descriptor passed with SCM_RIGHTS alongside the response frame.
//      Only answered for peers with the same uid (SO_PEERCRED).
// call             service_id (int), request (str: the flattened request)
//   -> response (str) or an error response; see the services code.
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

inline constexpr std::string_view publisher_available = "publisher_available";
inline constexpr std::string_view publisher_gone = "publisher_gone";
inline constexpr std::string_view subscribers_changed = "subscribers_changed";
inline constexpr std::string_view service_available = "service_available";
inline constexpr std::string_view service_gone = "service_gone";

inline constexpr std::string_view open_segment = "open_segment";
inline constexpr std::string_view call = "call";

}  // namespace ln::protocol::method
