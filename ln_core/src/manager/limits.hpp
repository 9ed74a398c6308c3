// The manager's limits (ManagerLimits) and their names: one table for the .lnc
// `instance` keys (max_topic_shm: 64M), the ln_manager options
// (--max-topic-shm 64M) and the help text, so all three always agree.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ln::manager {

/// What the manager allows each connection, client and topic, so that no
/// client (buggy or hostile) can stall or exhaust the others: it is
/// disconnected, or its request refused, with a logged reason. Every field
/// is also an `instance` key of a .lnc file and an ln_manager option
/// (limit_table() below; README "Limits" says why the defaults are what they are).
struct ManagerLimits {
  /// Connections (registered or not); beyond, the oldest unregistered one
  /// is closed, or the new one when all are registered.
  std::size_t max_clients = 4096;
  /// A request may be this large (the wire allows 64 MiB; no request needs
  /// more than a 1 MiB definition text), so a client cannot make the
  /// manager buffer more.
  std::size_t max_request_size = 4u * 1024 * 1024;
  /// A client whose unsent messages exceed this is disconnected.
  std::size_t max_output_queue = 16u * 1024 * 1024;
  /// All connections' partly received requests together; beyond, the one
  /// holding the most is disconnected.
  std::size_t max_total_input = 64u * 1024 * 1024;
  /// All connections' unsent messages together; beyond, the client with
  /// the most is disconnected.
  std::size_t max_total_output = 256u * 1024 * 1024;
  /// A connection must have registered (hello) this long after it was
  /// accepted, else it is closed.
  double handshake_timeout = 10.0;
  /// An unregistered connection that sends nothing for this long is closed.
  double pending_idle_timeout = 2.0;
  /// Unregistered connections in all; a new one beyond closes the oldest.
  std::size_t max_pending = 256;
  /// Unregistered connections from one IP address; a new one beyond
  /// closes the oldest of that address.
  std::size_t max_pending_per_peer = 64;
  /// Topics one client publishes, its subscriptions and its services
  /// together (every one of them is state the manager keeps and reports).
  std::size_t max_ports_per_client = 4096;
  /// The shared-memory segment of one topic (its buffers times its packet
  /// size, as transport::topic_segment_size counts): publish and subscribe
  /// requests that would need more are refused.
  std::uint64_t max_topic_shm = 256ull * 1024 * 1024;
  /// The segments of all topics one client publishes together.
  std::uint64_t max_client_shm = 1024ull * 1024 * 1024;
  /// put_message_definition: the generated-definitions directory holds at
  /// most this many files and bytes (counted at start and on every put).
  std::size_t max_stored_definitions = 1000;
  std::uint64_t max_stored_definition_bytes = 64ull * 1024 * 1024;
  /// New definition texts (ones that must be parsed; the same text again
  /// is free) one client may put per registration: parsing 1 MiB takes
  /// about 0.1 s of the manager's thread.
  std::size_t max_definitions_per_client = 100;
};

struct LimitInfo {
  std::string key;           ///< .lnc key; the option is "--" + key with '-' for '_'
  std::string value_text;    ///< what the value is: "BYTES", "SECONDS", "COUNT"
  std::string description;   ///< one line
  std::string default_text;  ///< the default, as written in a config
};

/// Every limit, in the order of the help text.
const std::vector<LimitInfo>& limit_table();
bool is_limit_key(std::string_view key);
/// Sets the limit `key` of `limits` from `value`: a count, seconds (may
/// have a fraction), or bytes with an optional K, M or G suffix (powers of
/// 1024). Throws std::invalid_argument with a message that names the key
/// and says what is expected.
void set_limit(ManagerLimits& limits, std::string_view key, std::string_view value);
/// "4 KiB", "256 MiB", "1.5 GiB": a byte count for messages.
std::string byte_text(std::uint64_t bytes);

}  // namespace ln::manager
