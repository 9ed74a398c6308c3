// Client-to-client requests (methods.hpp, "Client -> client"): every client
// runs a peer server on an abstract Unix socket; other clients on the same
// host connect to it, e.g. to receive a publisher's shared-memory segment.
// The server also listens on TCP (the IP used to reach the manager), so that
// clients on other hosts can call services; such connections carry no uid
// (peer_uid() -1) and are marked over_tcp().
//
// Methods are looked up by name in a dispatch table, so other parts of the
// library (services: "call") add theirs with add_method(). Handlers run in the
// event loop and must not block; they may keep the request's connection and
// respond later from any thread.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "client/event_loop.hpp"
#include "client/manager_link.hpp"
#include "client/net.hpp"
#include "protocol/wire.hpp"

namespace ln::clientlib {

/// One accepted connection of the peer server. Shared, so that a handler can
/// answer after its dispatch returned.
class PeerConnection {
 public:
  PeerConnection(UniqueFd socket, long peer_uid, bool over_tcp = false)
      : socket_(std::move(socket)), peer_uid_(peer_uid), over_tcp_(over_tcp) {}
  /// Sends a response, passing `fd` along with it when >= 0. Thread-safe.
  /// False when the connection is gone.
  bool send(const protocol::Message& message, int fd = -1);
  /// The uid of the peer process (Unix socket), -1 over TCP.
  long peer_uid() const { return peer_uid_; }
  /// True for connections that came in over TCP (maybe from another host).
  bool over_tcp() const { return over_tcp_; }
  /// The access rule for segments and services on this host: a peer
  /// process of our own user, or of a user that LN_PEER_ALLOW_UIDS lists
  /// ("1001,1002"; "*" for every user). False over TCP (no uid to check).
  bool local_user_allowed() const;
  /// Closes the connection (further sends fail). Thread-safe.
  void close();

 private:
  friend class PeerServer;
  std::mutex mutex_;
  UniqueFd socket_;
  long peer_uid_;
  bool over_tcp_;
  protocol::FrameReader reader_;  // loop thread only
};

struct PeerRequest {
  protocol::Message message;
  std::shared_ptr<PeerConnection> connection;
  /// Answers the request with an error (for handlers that refuse).
  void fail(int error_code, const std::string& text) const;
};

class PeerServer {
 public:
  using Method = std::function<void(PeerRequest&)>;

  explicit PeerServer(EventLoop& loop) : loop_(loop) {}
  ~PeerServer();

  /// Adds or replaces a method. Before start() or in the loop thread.
  void add_method(std::string name, Method method);
  /// Listens on a new, unique abstract socket. Before the loop runs or in the
  /// loop thread. Throws Failure.
  void start(const std::string& socket_name);
  const std::string& socket_name() const { return socket_name_; }
  /// Also listens on TCP at `ipv4` (never the wildcard), ephemeral port,
  /// replacing an earlier TCP listener on another IP; keeps the current one
  /// when the IP is the same. Same threads as start(). Throws Failure.
  void listen_tcp(const std::string& ipv4);
  /// "IP:PORT" of the TCP listener, or "" when there is none.
  const std::string& tcp_address() const { return tcp_address_; }
  /// Closes the listening socket and all connections. Loop thread (or after
  /// the loop stopped).
  void stop();

  /// Hands a connection over to its handler for good (services: after
  /// answering `call`, the socket carries service frames only). The server
  /// stops watching it and ignores anything it had read beyond the request
  /// being handled (the protocol sends nothing more before the answer).
  /// Returns the socket (non-blocking, close-on-exec), or an invalid one if
  /// the connection is already gone. Only from a method handler.
  UniqueFd take_over(const std::shared_ptr<PeerConnection>& connection);

 private:
  void accept_all(int listener, bool over_tcp);
  void on_readable(const std::shared_ptr<PeerConnection>& connection);
  void drop(const std::shared_ptr<PeerConnection>& connection);

  EventLoop& loop_;
  std::string socket_name_;
  UniqueFd listener_;
  std::string tcp_ip_, tcp_address_;
  UniqueFd tcp_listener_;
  std::map<std::string, Method, std::less<>> methods_;
  std::map<int, std::shared_ptr<PeerConnection>> connections_;
};

/// Connects to a peer server's TCP address "IP:PORT" (non-blocking socket,
/// TCP_NODELAY). Throws Failure (LNE_INVALID_PARAMETER for a malformed
/// address, LNE_CHECK_ERRNO when the connect fails or times out).
UniqueFd connect_peer_tcp(const std::string& address, std::chrono::milliseconds timeout);

/// Sends one request to the peer server `socket_name` and calls `done` in the
/// loop thread with the reply and the descriptor that came with it (if any).
/// Never blocks; gives up after `timeout` (reply.error LNE_REQUEST_FAILED).
/// Loop thread only.
void call_peer(EventLoop& loop, const std::string& socket_name, protocol::Message request,
               std::chrono::milliseconds timeout, std::function<void(Reply&, UniqueFd)> done);

/// A process-unique name for a peer server socket.
std::string new_peer_socket_name();

}  // namespace ln::clientlib
