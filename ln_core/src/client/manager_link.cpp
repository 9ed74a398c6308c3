#include "client/manager_link.hpp"

#include <arpa/inet.h>
#include <sys/socket.h>

#include <cerrno>
#include <cstring>

#include "client/c_api.hpp"
#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

constexpr std::chrono::milliseconds kSendTimeout{5000};

}  // namespace

ManagerLink::ManagerLink(EventLoop& loop, MessageHandler on_notification, DisconnectHandler on_disconnect)
    : loop_(loop), on_notification_(std::move(on_notification)), on_disconnect_(std::move(on_disconnect)) {}

ManagerLink::~ManagerLink() = default;

protocol::Message ManagerLink::new_request(std::string_view method) {
  std::uint32_t id;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    id = next_id_++;
    if (next_id_ == 0) next_id_ = 1;
  }
  return protocol::Message::request(id, method);
}

void ManagerLink::attach(UniqueFd socket, std::string peer_description) {
  const int fd = socket.get();
  {
    std::lock_guard<std::mutex> send_lock(send_mutex_);
    std::lock_guard<std::mutex> lock(mutex_);
    close_socket_locked();
    socket_ = std::move(socket);
    peer_ = std::move(peer_description);
    ++session_;
    connected_ = true;
  }
  reader_ = protocol::FrameReader();
  loop_.watch(fd, POLLIN, [this](short revents) { on_readable(revents); });
}

void ManagerLink::close_socket_locked() {
  if (socket_.valid()) loop_.unwatch(socket_.get());
  socket_.reset();
  connected_ = false;
}

void ManagerLink::detach(const std::string& reason) {
  std::uint64_t ended;
  {
    std::lock_guard<std::mutex> send_lock(send_mutex_);
    std::lock_guard<std::mutex> lock(mutex_);
    if (!socket_.valid()) return;
    close_socket_locked();
    ended = session_;
  }
  fail_pending_of_session(ended, reason);
}

bool ManagerLink::connected() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return connected_;
}

std::uint64_t ManagerLink::session() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return session_;
}

std::string ManagerLink::local_ip() const {
  std::lock_guard<std::mutex> lock(mutex_);
  sockaddr_in local{};
  socklen_t length = sizeof local;
  if (!socket_.valid() || ::getsockname(socket_.get(), reinterpret_cast<sockaddr*>(&local), &length) != 0 ||
      local.sin_family != AF_INET)
    return "";
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &local.sin_addr, text, sizeof text);
  return text;
}

void ManagerLink::fail_pending_of_session(std::uint64_t session, const std::string& reason) {
  std::vector<ReplyHandler> failed;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->second.session == session) {
        failed.push_back(std::move(it->second.handler));
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }
  for (ReplyHandler& handler : failed) {
    Reply reply;
    reply.error = LNE_LOST_CONNECTION;
    reply.error_text = reason;
    handler(reply);
  }
}

void ManagerLink::send_request(protocol::Message request, ReplyHandler handler) {
  const std::uint32_t id = request.id();
  std::string frame;
  try {
    frame = protocol::encode(request);
  } catch (const protocol::ProtocolError& error) {
    loop_.post([handler = std::move(handler), text = std::string(error.what())]() mutable {
      Reply reply;
      reply.error = LNE_INVALID_PARAMETER;
      reply.error_text = text;
      handler(reply);
    });
    return;
  }

  std::lock_guard<std::mutex> send_lock(send_mutex_);
  std::uint64_t session;
  int fd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!connected_) {
      const std::string reason = "not connected to the ln_manager" + (peer_.empty() ? "" : " at " + peer_) +
                                 " (reconnecting in the background)";
      loop_.post([handler = std::move(handler), reason]() mutable {
        Reply reply;
        reply.error = LNE_LOST_CONNECTION;
        reply.error_text = reason;
        handler(reply);
      });
      return;
    }
    session = session_;
    fd = socket_.get();
    pending_[id] = Pending{session, std::move(handler)};
  }
  if (const int error = send_all(fd, frame, -1, kSendTimeout); error != 0) end_session_after_send_error(session, error);
}

void ManagerLink::end_session_after_send_error(std::uint64_t session, int error) {
  const std::string reason = std::string("sending to the ln_manager failed: ") + std::strerror(error);
  loop_.post([this, session, reason] {
    if (this->session() != session || !connected()) return;
    detach(reason);
    on_disconnect_(reason);
  });
}

void ManagerLink::send_notification(const protocol::Message& notification) {
  const std::string frame = protocol::encode(notification);
  std::lock_guard<std::mutex> send_lock(send_mutex_);
  std::uint64_t session;
  int fd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!connected_) return;
    session = session_;
    fd = socket_.get();
  }
  if (const int error = send_all(fd, frame, -1, kSendTimeout); error != 0) end_session_after_send_error(session, error);
}

protocol::Message ManagerLink::call(protocol::Message request, std::chrono::milliseconds timeout,
                                    std::function<void(const protocol::Message&)> in_loop) {
  if (loop_.in_loop_thread())
    throw Failure(LNE_INTERNAL_ERROR, "a blocking manager request was made from the library's I/O thread");

  struct CallState {
    std::mutex mutex;
    std::condition_variable done_cv;
    bool done = false;
    bool abandoned = false;
    Reply reply;
  };
  auto state = std::make_shared<CallState>();
  const std::string method = request.method();
  send_request(std::move(request), [state, in_loop = std::move(in_loop)](Reply& reply) {
    std::lock_guard<std::mutex> lock(state->mutex);
    if (state->abandoned) return;
    if (reply.error == 0 && in_loop) {
      try {
        in_loop(reply.message);
      } catch (const Failure& failure) {
        reply.error = failure.code();
        reply.error_text = failure.what();
      } catch (const std::exception& error) {
        reply.error = LNE_GOT_INVALID_RESPONSE;
        reply.error_text = error.what();
      }
    }
    state->reply = std::move(reply);
    state->done = true;
    state->done_cv.notify_all();
  });

  std::unique_lock<std::mutex> lock(state->mutex);
  if (!state->done_cv.wait_for(lock, timeout, [&] { return state->done; })) {
    state->abandoned = true;
    throw Failure(LNE_REQUEST_FAILED, "the ln_manager did not answer '" + method + "' within " +
                                          std::to_string(timeout.count() / 1000.0) + " s");
  }
  Reply& reply = state->reply;
  if (reply.error != 0) throw Failure(reply.error, reply.error_text);
  return std::move(reply.message);
}

void ManagerLink::on_readable(short revents) {
  (void)revents;
  int fd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fd = socket_.get();
  }
  if (fd < 0) return;
  std::string received;
  std::vector<UniqueFd> unexpected_fds;  // the manager never passes descriptors
  std::string reason;
  for (int rounds = 0; rounds < 16; ++rounds) {
    const long n = receive_some(fd, received, unexpected_fds);
    if (n > 0) continue;
    if (n == 0)
      reason = "the ln_manager closed the connection";
    else if (errno != EAGAIN && errno != EWOULDBLOCK)
      reason = std::string("reading from the ln_manager failed: ") + std::strerror(errno);
    break;
  }
  std::vector<protocol::Message> messages;
  try {
    reader_.append(received.data(), received.size());
    while (auto message = reader_.next()) messages.push_back(std::move(*message));
  } catch (const protocol::ProtocolError& error) {
    reason = std::string("the ln_manager sent a malformed message: ") + error.what();
  }
  const std::uint64_t session_now = session();
  for (protocol::Message& message : messages) {
    handle_message(std::move(message));
    if (session() != session_now) return;  // a handler ended this session
  }
  if (!reason.empty()) {
    detach(reason);
    on_disconnect_(reason);
  }
}

void ManagerLink::handle_message(protocol::Message message) {
  if (message.kind() == protocol::Kind::Response) {
    ReplyHandler handler;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = pending_.find(message.id());
      if (it == pending_.end()) return;  // its caller gave up
      handler = std::move(it->second.handler);
      pending_.erase(it);
    }
    Reply reply;
    if (message.is_error()) {
      const int code = message.error_code();
      reply.error = code >= LNE_CHECK_ERRNO && code <= LNE_WRONG_MD_HASH ? code : LNE_REQUEST_FAILED;
      reply.error_text = message.error_text();
    }
    reply.message = std::move(message);
    handler(reply);
    return;
  }
  if (message.kind() == protocol::Kind::Notification) {
    on_notification_(message);
    return;
  }
  // The contract has no manager-to-client requests yet; answer so that the
  // manager is never left waiting.
  protocol::Message refusal = protocol::Message::error_response_to(
      message, LNE_NOT_YET_IMPLEMENTED, "this client does not handle '" + message.method() + "'");
  std::string frame = protocol::encode(refusal);
  std::lock_guard<std::mutex> send_lock(send_mutex_);
  int fd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fd = socket_.get();
  }
  if (fd >= 0) send_all(fd, frame, -1, kSendTimeout);
}

}  // namespace ln::clientlib
