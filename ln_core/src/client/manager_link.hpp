// The client's TCP connection to the ln_manager: sends requests from any
// thread, matches responses to them, and hands notifications to the client.
// One ManagerLink lives as long as its client; each successful (re)connect is
// a new *session* on it. Reading happens in the event loop.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "client/event_loop.hpp"
#include "client/net.hpp"
#include "protocol/wire.hpp"

namespace ln::clientlib {

/// The answer to a request: a response, or why there is none.
struct Reply {
  int error = 0;           ///< 0: `message` is a successful response; else a positive LNE_* code
  std::string error_text;  ///< what went wrong (the manager's text for failed requests)
  protocol::Message message;
};

class ManagerLink {
 public:
  using ReplyHandler = std::function<void(Reply&)>;
  using MessageHandler = std::function<void(const protocol::Message&)>;
  using DisconnectHandler = std::function<void(const std::string& reason)>;

  /// `on_notification` and `on_disconnect` run in the loop thread.
  ManagerLink(EventLoop& loop, MessageHandler on_notification, DisconnectHandler on_disconnect);
  ~ManagerLink();

  /// A request for `method` with a fresh id; fill in its fields and send it.
  protocol::Message new_request(std::string_view method);

  /// Starts a session on a connected socket (loop thread, or before the loop runs).
  void attach(UniqueFd socket, std::string peer_description);
  /// Ends the session: closes the socket and fails every request in flight
  /// with LNE_LOST_CONNECTION. Does not call on_disconnect. Loop thread.
  void detach(const std::string& reason);
  bool connected() const;
  /// Counts sessions: changes with every attach.
  std::uint64_t session() const;
  /// The local IPv4 address of the connection ("" when not connected): the
  /// address this host uses towards the manager's network.
  std::string local_ip() const;

  /// Sends `request`; `handler` runs in the loop thread with the reply, or
  /// with LNE_LOST_CONNECTION when the session ends first (also when there
  /// is no session now: then it runs in the loop thread soon). Any thread.
  void send_request(protocol::Message request, ReplyHandler handler);

  /// Sends a one-way message (no reply); dropped while there is no
  /// session. Any thread.
  void send_notification(const protocol::Message& notification);

  /// Sends `request` and waits for the reply, at most `timeout`. Returns the
  /// successful response; throws Failure otherwise (the manager's error,
  /// LNE_LOST_CONNECTION, or LNE_REQUEST_FAILED on timeout). `in_loop`, if
  /// given, runs in the loop thread on success before this returns, so that
  /// state it registers is in place before any later notification is handled;
  /// it is skipped when the caller gave up waiting. Not from the loop thread.
  protocol::Message call(protocol::Message request, std::chrono::milliseconds timeout,
                         std::function<void(const protocol::Message&)> in_loop = {});

 private:
  struct Pending {
    std::uint64_t session;
    ReplyHandler handler;
  };

  void on_readable(short revents);
  void handle_message(protocol::Message message);
  void fail_pending_of_session(std::uint64_t session, const std::string& reason);
  /// After a failed send (part of a frame may be out) the stream is
  /// unusable: ends `session` from the loop thread.
  void end_session_after_send_error(std::uint64_t session, int error);
  void close_socket_locked();

  EventLoop& loop_;
  MessageHandler on_notification_;
  DisconnectHandler on_disconnect_;

  mutable std::mutex mutex_;  // socket, session and pending requests
  UniqueFd socket_;
  std::string peer_;
  std::uint64_t session_ = 0;
  bool connected_ = false;
  std::map<std::uint32_t, Pending> pending_;
  std::uint32_t next_id_ = 1;

  std::mutex send_mutex_;         // one frame at a time on the socket
  protocol::FrameReader reader_;  // loop thread only
};

}  // namespace ln::clientlib
