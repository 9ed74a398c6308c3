#include "client/peer.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <random>

#include "client/c_api.hpp"
#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

constexpr std::chrono::milliseconds kPeerSendTimeout{2000};
// A peer connection that sends more than this without forming a frame is
// cut off (the frame codec enforces the same limit per frame).
constexpr std::size_t kMaxBufferedPeerBytes = protocol::max_frame_size + 16;

}  // namespace

bool PeerConnection::send(const protocol::Message& message, int fd) {
  std::string frame;
  try {
    frame = protocol::encode(message);
  } catch (const protocol::ProtocolError&) {
    return false;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!socket_.valid()) return false;
  return send_all(socket_.get(), frame, fd, kPeerSendTimeout) == 0;
}

bool PeerConnection::local_user_allowed() const {
  if (over_tcp_ || peer_uid_ < 0) return false;
  if (peer_uid_ == static_cast<long>(::getuid())) return true;
  const char* text = std::getenv("LN_PEER_ALLOW_UIDS");
  const std::string allowed = "," + std::string(text ? text : "") + ",";
  return allowed == ",*," || allowed.find("," + std::to_string(peer_uid_) + ",") != std::string::npos;
}

void PeerConnection::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  // shutdown, not close: the loop still polls this descriptor and will see EOF.
  if (socket_.valid()) ::shutdown(socket_.get(), SHUT_RDWR);
}

void PeerRequest::fail(int error_code, const std::string& text) const {
  connection->send(protocol::Message::error_response_to(message, error_code, text));
}

PeerServer::~PeerServer() { stop(); }

void PeerServer::add_method(std::string name, Method method) { methods_[std::move(name)] = std::move(method); }

void PeerServer::start(const std::string& socket_name) {
  listener_ = listen_abstract_unix(socket_name);
  socket_name_ = socket_name;
  loop_.watch(listener_.get(), POLLIN, [this](short) { accept_all(listener_.get(), false); });
}

void PeerServer::listen_tcp(const std::string& ipv4) {
  if (tcp_listener_.valid() && ipv4 == tcp_ip_) return;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  if (::inet_pton(AF_INET, ipv4.c_str(), &address.sin_addr) != 1 || address.sin_addr.s_addr == htonl(INADDR_ANY))
    throw Failure(LNE_INVALID_PARAMETER, "no IPv4 address for the TCP peer server: '" + ipv4 + "'");
  UniqueFd listener(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  socklen_t length = sizeof address;
  if (!listener.valid() || ::bind(listener.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(listener.get(), 64) != 0 ||
      ::getsockname(listener.get(), reinterpret_cast<sockaddr*>(&address), &length) != 0)
    throw errno_failure(errno, "opening the TCP peer server on " + ipv4);
  if (tcp_listener_.valid()) loop_.unwatch(tcp_listener_.get());
  tcp_listener_ = std::move(listener);
  tcp_ip_ = ipv4;
  tcp_address_ = ipv4 + ":" + std::to_string(ntohs(address.sin_port));
  loop_.watch(tcp_listener_.get(), POLLIN, [this](short) { accept_all(tcp_listener_.get(), true); });
}

void PeerServer::stop() {
  if (listener_.valid()) loop_.unwatch(listener_.get());
  listener_.reset();
  if (tcp_listener_.valid()) loop_.unwatch(tcp_listener_.get());
  tcp_listener_.reset();
  tcp_address_.clear();
  for (auto& [fd, connection] : connections_) {
    loop_.unwatch(fd);
    std::lock_guard<std::mutex> lock(connection->mutex_);
    connection->socket_.reset();
  }
  connections_.clear();
}

UniqueFd PeerServer::take_over(const std::shared_ptr<PeerConnection>& connection) {
  std::lock_guard<std::mutex> lock(connection->mutex_);
  const int fd = connection->socket_.get();
  if (fd < 0) return UniqueFd();
  loop_.unwatch(fd);
  connections_.erase(fd);
  return std::move(connection->socket_);
}

void PeerServer::accept_all(int listener, bool over_tcp) {
  for (int i = 0; i < 64; ++i) {
    UniqueFd accepted(::accept4(listener, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC));
    if (!accepted.valid()) return;  // EAGAIN, or a failure we cannot act on
    const int fd = accepted.get();
    if (over_tcp) {
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    }
    auto connection = std::make_shared<PeerConnection>(std::move(accepted), over_tcp ? -1 : peer_uid(fd), over_tcp);
    connections_[fd] = connection;
    std::weak_ptr<PeerConnection> weak = connection;
    loop_.watch(fd, POLLIN, [this, weak](short) {
      if (auto alive = weak.lock()) on_readable(alive);
    });
  }
}

void PeerServer::drop(const std::shared_ptr<PeerConnection>& connection) {
  std::lock_guard<std::mutex> lock(connection->mutex_);
  const int fd = connection->socket_.get();
  if (fd < 0) return;
  loop_.unwatch(fd);
  connections_.erase(fd);
  connection->socket_.reset();
}

void PeerServer::on_readable(const std::shared_ptr<PeerConnection>& connection) {
  std::string received;
  std::vector<UniqueFd> passed;  // peers have no reason to pass us descriptors; they are closed
  bool ended = false;
  int fd;
  {
    std::lock_guard<std::mutex> lock(connection->mutex_);
    fd = connection->socket_.get();
  }
  if (fd < 0) return;
  for (int rounds = 0; rounds < 16; ++rounds) {
    const long n = receive_some(fd, received, passed);
    if (n > 0) continue;
    ended = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
    break;
  }
  std::vector<protocol::Message> requests;
  try {
    connection->reader_.append(received.data(), received.size());
    while (auto message = connection->reader_.next()) requests.push_back(std::move(*message));
    if (connection->reader_.buffered() > kMaxBufferedPeerBytes) ended = true;
  } catch (const protocol::ProtocolError&) {
    ended = true;
  }
  for (protocol::Message& message : requests) {
    {
      std::lock_guard<std::mutex> lock(connection->mutex_);
      if (!connection->socket_.valid()) return;  // taken over by a handler, or closed
    }
    if (message.kind() != protocol::Kind::Request) continue;
    PeerRequest request{std::move(message), connection};
    const std::string method = request.message.method();
    auto found = methods_.find(method);
    if (found == methods_.end()) {
      request.fail(LNE_NOT_YET_IMPLEMENTED, "this client does not offer '" + method + "'");
      continue;
    }
    try {
      found->second(request);
    } catch (const Failure& failure) {
      request.fail(failure.code(), failure.what());
    } catch (const std::exception& error) {
      request.fail(LNE_INTERNAL_ERROR, error.what());
    }
  }
  if (ended) drop(connection);
}

namespace {

// One outgoing peer request, owned by the event loop until it completes.
struct PeerCall : std::enable_shared_from_this<PeerCall> {
  EventLoop& loop;
  UniqueFd socket;
  protocol::FrameReader reader;
  std::vector<UniqueFd> fds;
  std::uint32_t id = 0;
  EventLoop::TimerId timer = 0;
  std::function<void(Reply&, UniqueFd)> done;
  bool finished = false;

  explicit PeerCall(EventLoop& l) : loop(l) {}

  void finish(Reply& reply) {
    if (finished) return;
    finished = true;
    loop.cancel(timer);
    if (socket.valid()) loop.unwatch(socket.get());
    UniqueFd passed = fds.empty() ? UniqueFd() : std::move(fds.front());
    socket.reset();
    auto callback = std::move(done);
    callback(reply, std::move(passed));
  }

  void fail(int code, const std::string& text) {
    Reply reply;
    reply.error = code;
    reply.error_text = text;
    finish(reply);
  }

  void on_readable() {
    std::string received;
    bool ended = false;
    for (int rounds = 0; rounds < 16; ++rounds) {
      const long n = receive_some(socket.get(), received, fds);
      if (n > 0) continue;
      ended = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
      break;
    }
    try {
      reader.append(received.data(), received.size());
      while (auto message = reader.next()) {
        if (message->kind() != protocol::Kind::Response || message->id() != id) continue;
        Reply reply;
        if (message->is_error()) {
          reply.error = message->error_code() > 0 ? message->error_code() : LNE_REQUEST_FAILED;
          reply.error_text = message->error_text();
        }
        reply.message = std::move(*message);
        finish(reply);
        return;
      }
    } catch (const protocol::ProtocolError& error) {
      fail(LNE_GOT_INVALID_RESPONSE, std::string("a peer sent a malformed message: ") + error.what());
      return;
    }
    if (ended) fail(LNE_REQUEST_FAILED, "the peer closed the connection without answering");
  }
};

}  // namespace

UniqueFd connect_peer_tcp(const std::string& address, std::chrono::milliseconds timeout) {
  ManagerAddress parsed;
  try {
    parsed = parse_manager_address(address);
  } catch (const Failure& failure) {
    throw Failure(LNE_INVALID_PARAMETER, "invalid peer address '" + address + "': " + failure.what());
  }
  sockaddr_in resolved{};
  resolved.sin_family = AF_INET;
  resolved.sin_port = htons(parsed.port);
  if (::inet_pton(AF_INET, parsed.host.c_str(), &resolved.sin_addr) != 1)
    throw Failure(LNE_INVALID_PARAMETER, "invalid peer address '" + address + "': not an IPv4 address");
  UniqueFd socket = connect_tcp(resolved, timeout);
  const int one = 1;
  ::setsockopt(socket.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return socket;
}

void call_peer(EventLoop& loop, const std::string& socket_name, protocol::Message request,
               std::chrono::milliseconds timeout, std::function<void(Reply&, UniqueFd)> done) {
  auto call = std::make_shared<PeerCall>(loop);
  call->done = std::move(done);
  call->id = request.id();
  try {
    call->socket = connect_abstract_unix(socket_name);
  } catch (const Failure& failure) {
    call->fail(LNE_REQUEST_FAILED, failure.what());
    return;
  }
  std::string frame;
  try {
    frame = protocol::encode(request);
  } catch (const protocol::ProtocolError& error) {
    call->fail(LNE_INVALID_PARAMETER, error.what());
    return;
  }
  if (const int error = send_all(call->socket.get(), frame, -1, timeout); error != 0) {
    call->fail(LNE_REQUEST_FAILED, "sending to peer '" + socket_name + "' failed: " + std::strerror(error));
    return;
  }
  // The loop's watch and timer keep the call alive until one of them finishes it.
  loop.watch(call->socket.get(), POLLIN, [call](short) { call->on_readable(); });
  call->timer = loop.run_after(timeout, [call, socket_name] {
    call->fail(LNE_REQUEST_FAILED, "peer '" + socket_name + "' did not answer in time");
  });
}

std::string new_peer_socket_name() {
  static std::atomic<unsigned> counter{0};
  static const unsigned long long process_nonce = std::random_device{}() * 4294967296ull + std::random_device{}();
  char name[96];
  std::snprintf(name, sizeof name, "ln_core/%d/%llx/%u", static_cast<int>(::getpid()), process_nonce,
                counter.fetch_add(1));
  return name;
}

}  // namespace ln::clientlib
