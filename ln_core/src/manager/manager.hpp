// The ln_manager as a library: a single-threaded epoll loop that serves the
// client protocol (protocol/methods.hpp) on one TCP socket. Topic and
// service data never pass through it; it only brokers who talks to whom.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "manager/log.hpp"

namespace ln::manager {

/// What the manager allows each connection, client and topic, so that no
/// client (buggy or hostile) can stall or exhaust the others: it is
/// disconnected, or its request refused, with a logged reason. Every field
/// is also an `instance` key of a .lnc file and an ln_manager option
/// (limits.hpp; README "Limits" says why the defaults are what they are).
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

struct ManagerOptions {
  /// Loopback unless asked otherwise: reaching the manager from other hosts
  /// is an explicit choice ("0.0.0.0" or an interface address).
  std::string listen_host = "127.0.0.1";
  std::uint16_t port = 0;  ///< 0: an ephemeral port (see Manager::port())
  std::string instance_name = "ln_core";
  /// Searched first, in this order (the config's add_message_definition_dir).
  std::vector<std::string> message_definition_dirs;
  /// Where put_message_definition stores; "" = ~/ln_message_definitions/gen.
  std::string generated_definition_dir;
  ManagerLimits limits;
  LogFunction log;
};

class Manager {
 public:
  explicit Manager(ManagerOptions options);
  /// Stops the loop (and joins run_in_thread's thread).
  ~Manager();
  Manager(const Manager&) = delete;
  Manager& operator=(const Manager&) = delete;

  /// Binds and listens. Throws std::runtime_error with the reason.
  void start();
  /// The bound port (after start()).
  std::uint16_t port() const;
  /// Serves until stop(). Call after start().
  void run();
  /// run() in a new thread.
  void run_in_thread();
  /// Ends run() soon; from any thread (also a signal-handling one), any
  /// number of times. Joins the thread of run_in_thread() unless called
  /// from it.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ln::manager
