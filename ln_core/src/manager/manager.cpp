#include "manager/manager.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <list>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "manager/definitions.hpp"
#include "manager/dispatch.hpp"
#include "manager/limits.hpp"
#include "manager/loggers.hpp"
#include "manager/registry.hpp"
#include "manager/request_error.hpp"
#include "protocol/wire.hpp"

#ifndef LN_MANAGER_VERSION
#define LN_MANAGER_VERSION "unknown"
#endif

namespace ln::manager {
namespace {

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

std::string default_generated_dir() {
  const char* home = std::getenv("HOME");
  return std::string(home && *home ? home : "/tmp") + "/ln_message_definitions/gen";
}

in_addr resolve_ipv4(const std::string& host) {
  in_addr address{};
  if (::inet_pton(AF_INET, host.c_str(), &address) == 1) return address;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int status = ::getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (status != 0 || !found) throw std::runtime_error("cannot listen on '" + host + "': " + ::gai_strerror(status));
  address = reinterpret_cast<sockaddr_in*>(found->ai_addr)->sin_addr;
  ::freeaddrinfo(found);
  return address;
}

std::string ip_text(const sockaddr_in& address) {
  char text[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &address.sin_addr, text, sizeof text);
  return text;
}

std::string endpoint_text(const sockaddr_in& address) {
  return ip_text(address) + ":" + std::to_string(ntohs(address.sin_port));
}

using Clock = std::chrono::steady_clock;

Clock::duration seconds(double value) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(value));
}

// Requests of one connection handled in a row before the others get their
// turn: a client that floods the manager only delays everyone by this many.
constexpr int requests_per_turn = 16;
// What an unregistered connection may send before its hello is complete:
// a hello is a few hundred bytes.
constexpr std::size_t max_pending_input = 64 * 1024;
// How often deadlines of unregistered connections are checked.
constexpr auto pending_check_interval = std::chrono::milliseconds(100);

struct Connection {
  int fd = -1;
  std::string peer;     ///< "IP:PORT"
  std::string peer_ip;  ///< for max_pending_per_peer
  protocol::FrameReader reader;
  std::string outgoing;     ///< encoded frames not yet written ...
  std::size_t written = 0;  ///< ... of which this many bytes are out
  bool waiting_for_writable = false;
  Session session;
  bool doomed = false;
  Clock::time_point accepted_at;
  Clock::time_point last_received;
  /// Unregistered: its place in Impl::pending (oldest first).
  std::optional<std::list<int>::iterator> pending_entry;
  /// It had more complete requests than its turn allowed: handled in the
  /// next round, before anything more is read from it.
  bool backlogged = false;
  /// Bytes this connection contributes to Impl::total_input.
  std::size_t counted_input = 0;

  std::size_t unsent() const { return outgoing.size() - written; }
};

}  // namespace

struct Manager::Impl {
  explicit Impl(ManagerOptions o)
      : options(std::move(o)),
        definitions(
            options.message_definition_dirs,
            options.generated_definition_dir.empty() ? default_generated_dir() : options.generated_definition_dir,
            options.limits),
        registry(definitions, options.limits),
        dispatcher(registry, definitions, std::string("ln_core ") + LN_MANAGER_VERSION, options.log),
        loggers(
            registry, definitions, [this](Loggers::Task task) { post(std::move(task)); }, options.log) {
    dispatcher.serve_loggers(loggers);
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lock(posted_mutex);
      wake_fd_closing = true;  // the loggers' threads still run until they are destroyed
    }
    for (auto& entry : connections) ::close(entry.first);
    for (int fd : {listen_fd, wake_fd, epoll_fd, spare_fd})
      if (fd >= 0) ::close(fd);
  }

  void log(LogLevel level, const std::string& text) const {
    if (options.log) options.log(level, text);
  }

  // ------------------------------------------------------------- set-up

  void start() {
    if (listen_fd >= 0) throw std::runtime_error("the manager is already started");
    epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
    if (epoll_fd < 0) throw std::runtime_error(errno_text("epoll_create1"));
    wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (wake_fd < 0) throw std::runtime_error(errno_text("eventfd"));
    watch(wake_fd, EPOLLIN);
    // Kept in reserve so that, out of descriptors, a waiting connection can
    // still be accepted and closed instead of spinning on it.
    spare_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);

    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr = resolve_ipv4(options.listen_host);
    address.sin_port = htons(options.port);
    listen_fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (listen_fd < 0) throw std::runtime_error(errno_text("socket"));
    const int on = 1;
    ::setsockopt(listen_fd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    if (::bind(listen_fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
      throw std::runtime_error(errno_text("cannot listen on " + endpoint_text(address)));
    if (::listen(listen_fd, SOMAXCONN) != 0) throw std::runtime_error(errno_text("listen"));
    socklen_t size = sizeof address;
    ::getsockname(listen_fd, reinterpret_cast<sockaddr*>(&address), &size);
    bound_port = ntohs(address.sin_port);
    dispatcher.listening_at(endpoint_text(address));
    watch(listen_fd, EPOLLIN);
    log(LogLevel::Info, "instance '" + options.instance_name + "' listening on " + endpoint_text(address));
    std::string dirs;
    for (const auto& dir : definitions.search_dirs()) dirs += (dirs.empty() ? "" : ", ") + dir;
    log(LogLevel::Info,
        "message-definition search path: " + (dirs.empty() ? std::string("(no existing directory)") : dirs));
    log(LogLevel::Info, "put_message_definition stores into " + definitions.generated_dir());
    start_processes(address);
  }

  void start_processes(const sockaddr_in& address) {
    const LncSettings* system = options.system.get();
    if (system == nullptr || (system->processes.empty() && system->states.empty() && system->groups.empty())) return;
    ProcessControlOptions process_options = options.process_options;
    process_options.log = options.log;
    sockaddr_in reachable = address;
    if (reachable.sin_addr.s_addr == htonl(INADDR_ANY)) reachable.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    process_options.manager_address = endpoint_text(reachable);
    process_options.definition_dirs = definitions.search_dirs();
    process_options.instance_name = options.instance_name;
    processes = std::make_unique<ProcessControl>(*system, process_options);
    dispatcher.set_process_control(processes.get());
    watch(processes->fd(), EPOLLIN);
    for (const auto& name : options.start) {
      try {
        const bool state = std::any_of(system->states.begin(), system->states.end(),
                                       [&](const StateConfig& s) { return s.name == name; });
        processes->request(name, state ? "up" : "start");
      } catch (const RequestError& e) {
        log(LogLevel::Error, "--start " + name + ": " + e.what());
      }
    }
  }

  void watch(int fd, std::uint32_t events) {
    epoll_event event{};
    event.events = events;
    event.data.fd = fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &event) != 0) throw std::runtime_error(errno_text("epoll_ctl"));
  }

  // --------------------------------------------------------------- loop

  void run() {
    if (listen_fd < 0) throw std::runtime_error("Manager::run() needs start() first");
    loop_thread.store(std::this_thread::get_id());
    std::array<epoll_event, 64> events;
    while (!stopping_done()) {
      // Backlogged requests are handled at once; unregistered connections
      // have deadlines; while listening is paused (out of descriptors),
      // look again soon.
      int timeout_ms = -1;
      if (!backlogged.empty())
        timeout_ms = 0;
      else if (listening_paused || !pending.empty())
        timeout_ms = static_cast<int>(pending_check_interval.count());
      const int count = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), timeout_ms);
      if (count < 0) {
        if (errno == EINTR) continue;
        log(LogLevel::Error, errno_text("epoll_wait failed; the manager stops"));
        break;
      }
      if (listening_paused) resume_listening();
      for (int i = 0; i < count; ++i) {
        const int fd = events[static_cast<std::size_t>(i)].data.fd;
        const std::uint32_t what = events[static_cast<std::size_t>(i)].events;
        if (fd == wake_fd) {
          std::uint64_t ignored;
          (void)!::read(wake_fd, &ignored, sizeof ignored);
          run_posted_tasks();
        } else if (fd == listen_fd) {
          accept_connections();
        } else if (processes && fd == processes->fd()) {
          processes->handle_events();
        } else if (auto it = connections.find(fd); it != connections.end() && !it->second->doomed) {
          Connection& connection = *it->second;
          if (what & (EPOLLIN | EPOLLHUP | EPOLLERR)) receive(connection);
          if (!connection.doomed && (what & EPOLLOUT)) flush(connection);
        }
      }
      serve_backlog();
      check_pending_deadlines();
      close_doomed_connections();
    }
    log(LogLevel::Info, "stopping; " + std::to_string(connections.size()) + " connection(s) closed");
    for (auto& entry : connections) ::close(entry.first);
    connections.clear();
    by_client.clear();
    pending.clear();
    pending_per_peer.clear();
    backlogged.clear();
  }

  // Work finished by other threads (the loggers' workers) comes back here,
  // to run in the loop thread.
  void post(Loggers::Task task) {
    std::lock_guard<std::mutex> lock(posted_mutex);
    if (wake_fd_closing) return;
    posted.push_back(std::move(task));
    const std::uint64_t one = 1;
    if (wake_fd >= 0) (void)!::write(wake_fd, &one, sizeof one);
  }

  void run_posted_tasks() {
    std::vector<Loggers::Task> tasks;
    {
      std::lock_guard<std::mutex> lock(posted_mutex);
      tasks.swap(posted);
    }
    for (auto& task : tasks) {
      Outbox out;
      task(out);
      deliver(out);
    }
  }

  // Whether run() may end: once stop() was called and, with processes,
  // they are all stopped. Keeps serving clients meanwhile.
  bool stopping_done() {
    const int requests = stop_requests.load();
    if (requests == 0) return false;
    if (!processes) return true;
    if (!shutdown_begun) {
      shutdown_begun = true;
      processes->begin_shutdown();
    }
    if (requests > 1 && !killed_all) {
      killed_all = true;
      log(LogLevel::Warning, "asked to stop again: killing all processes (SIGKILL)");
      processes->kill_all();
    }
    return processes->finished();
  }

  void stop() {
    stop_requests.fetch_add(1);
    const std::uint64_t one = 1;
    if (wake_fd >= 0) (void)!::write(wake_fd, &one, sizeof one);
  }

  // ---------------------------------------------------------- accepting

  void accept_connections() {
    for (;;) {
      sockaddr_in address{};
      socklen_t size = sizeof address;
      const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&address), &size, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (errno == EMFILE || errno == ENFILE)
          shed_connection_without_descriptor();
        else if (errno != EAGAIN && errno != EWOULDBLOCK)
          log(LogLevel::Warning, errno_text("accept failed"));
        return;
      }
      const std::string peer = endpoint_text(address);
      const std::string ip = ip_text(address);
      make_room_for_pending(ip);
      if (connections.size() >= options.limits.max_clients) {
        log(LogLevel::Warning, "refused the connection from " + peer + ": already " +
                                   std::to_string(connections.size()) + " connections (the limit), max_clients");
        ::close(fd);
        continue;
      }
      const int on = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);  // small requests, answered at once
      epoll_event event{};
      event.events = EPOLLIN;
      event.data.fd = fd;
      if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &event) != 0) {
        log(LogLevel::Warning, errno_text("refused the connection from " + peer + ": epoll_ctl"));
        ::close(fd);
        continue;
      }
      auto owned = std::make_unique<Connection>();
      Connection& connection = *owned;
      connection.fd = fd;
      connection.peer = peer;
      connection.peer_ip = ip;
      connection.accepted_at = connection.last_received = Clock::now();
      connections[fd] = std::move(owned);
      pending.push_back(fd);
      connection.pending_entry = std::prev(pending.end());
      ++pending_per_peer[ip];
      log(LogLevel::Debug, "connection from " + peer);
      // A client sends its hello right after connecting: often it is here
      // already, and the connection is registered before the next one comes.
      receive(connection);
    }
  }

  // Unregistered connections are capped in all and per address; a new one
  // closes the oldest (a real client registers within a round trip, so
  // only connections that hold a place without registering lose it).
  // Beyond max_clients, an unregistered connection makes room as well.
  void make_room_for_pending(const std::string& ip) {
    auto close_oldest = [&](const std::string* of_ip, const std::string& why) {
      for (int fd : pending) {
        Connection& victim = *connections.at(fd);
        if (victim.doomed || (of_ip && victim.peer_ip != *of_ip)) continue;
        doom(victim, LogLevel::Warning, "closed: " + why);
        return true;
      }
      return false;
    };
    bool closed_any = false;
    const auto from_peer = pending_per_peer.find(ip);
    if (from_peer != pending_per_peer.end() && from_peer->second >= options.limits.max_pending_per_peer)
      closed_any |= close_oldest(&ip, "the oldest of " + std::to_string(options.limits.max_pending_per_peer) +
                                          " connections from " + ip + " that did not register (max_pending_per_peer)");
    if (pending.size() >= options.limits.max_pending)
      closed_any |= close_oldest(nullptr, "the oldest of " + std::to_string(options.limits.max_pending) +
                                              " connections that did not register (max_pending)");
    if (connections.size() >= options.limits.max_clients)
      closed_any |= close_oldest(nullptr,
                                 "the oldest connection that did not register, to make room for a new one "
                                 "(max_clients " +
                                     std::to_string(options.limits.max_clients) + ")");
    if (closed_any) close_doomed_connections();
  }

  void leave_pending(Connection& connection) {
    if (!connection.pending_entry) return;
    pending.erase(*connection.pending_entry);
    connection.pending_entry.reset();
    const auto it = pending_per_peer.find(connection.peer_ip);
    if (it != pending_per_peer.end() && --it->second == 0) pending_per_peer.erase(it);
  }

  void check_pending_deadlines() {
    const Clock::time_point now = Clock::now();
    if (now < next_pending_check) return;
    next_pending_check = now + pending_check_interval;
    const auto handshake = seconds(options.limits.handshake_timeout);
    const auto idle = seconds(options.limits.pending_idle_timeout);
    for (auto it = pending.begin(); it != pending.end();) {
      Connection& connection = *connections.at(*it++);  // doom() takes it out of `pending`
      if (connection.doomed) continue;
      if (now - connection.accepted_at > handshake)
        doom(connection, LogLevel::Warning,
             "did not register within " + shortest_text(options.limits.handshake_timeout) +
                 " s (handshake_timeout); closed");
      else if (now - connection.last_received > idle)
        doom(connection, LogLevel::Warning,
             "sent nothing for " + shortest_text(options.limits.pending_idle_timeout) +
                 " s without registering (pending_idle_timeout); closed");
    }
  }

  // Out of descriptors, a pending connection keeps the listening socket
  // readable: give up the spare descriptor to accept and close it, or, if
  // even that is gone, stop listening for a moment.
  void shed_connection_without_descriptor() {
    if (spare_fd >= 0) {
      ::close(spare_fd);
      const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) ::close(fd);
      spare_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
      log(LogLevel::Warning,
          "out of file descriptors (" + std::to_string(connections.size()) + " connections): refused a new connection");
      if (spare_fd >= 0) return;
    }
    log(LogLevel::Warning, "out of file descriptors: not accepting connections for a moment");
    ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, listen_fd, nullptr);
    listening_paused = true;
  }

  void resume_listening() {
    if (spare_fd < 0) spare_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (spare_fd < 0) return;  // still none to spare
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.fd = listen_fd;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, listen_fd, &event) == 0) listening_paused = false;
  }

  // ------------------------------------------------------------ reading

  void receive(Connection& connection) {
    // A backlogged connection is not read: what it sends waits in the
    // kernel (and, once that is full, in the sender) until its turn.
    if (connection.backlogged) return;
    const ssize_t count = ::recv(connection.fd, receive_buffer.data(), receive_buffer.size(), 0);
    if (count == 0) return doom(connection, LogLevel::Info, "closed the connection");
    if (count < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
      return doom(connection, LogLevel::Info, errno_text("connection failed"));
    }
    connection.last_received = Clock::now();
    try {
      connection.reader.append(receive_buffer.data(), static_cast<std::size_t>(count));
    } catch (const protocol::ProtocolError& e) {
      return doom(connection, LogLevel::Warning,
                  "sent a malformed message (" + std::string(e.what()) + "); disconnected");
    }
    handle_turn(connection);
  }

  // Handles up to requests_per_turn complete requests of `connection`.
  void handle_turn(Connection& connection) {
    int handled = 0;
    try {
      while (!connection.doomed && !connection.session.close_after_response) {
        if (handled == requests_per_turn) {
          if (!connection.backlogged) backlogged.push_back(connection.fd);
          connection.backlogged = true;
          break;
        }
        auto message = connection.reader.next();
        if (!message) {
          connection.backlogged = false;
          break;
        }
        ++handled;
        handle(connection, *message);
      }
    } catch (const protocol::ProtocolError& e) {
      doom(connection, LogLevel::Warning, "sent a malformed message (" + std::string(e.what()) + "); disconnected");
    }
    if (connection.doomed) return;
    // What is left is at most one incomplete request (plus a backlog).
    const std::size_t limit = connection.session.client ? options.limits.max_request_size : max_pending_input;
    if (!connection.backlogged && connection.reader.buffered() > limit)
      return doom(
          connection, LogLevel::Warning,
          connection.session.client
              ? "sent a message larger than " + std::to_string(limit) + " bytes (max_request_size); disconnected"
              : "sent more than " + std::to_string(limit) + " bytes without registering; disconnected");
    if (connection.reader.buffered() == 0) connection.reader.release_memory();
    count_input(connection);
  }

  void serve_backlog() {
    std::vector<int> turn;
    turn.swap(backlogged);
    for (int fd : turn) {
      const auto it = connections.find(fd);
      if (it == connections.end() || it->second->doomed || !it->second->backlogged) continue;
      Connection& connection = *it->second;
      connection.backlogged = false;
      handle_turn(connection);
    }
  }

  // Keeps total_input (partly received requests of all connections) within
  // max_total_input: beyond, the connection holding the most goes.
  void count_input(Connection& connection) {
    total_input += connection.reader.buffered();
    total_input -= connection.counted_input;
    connection.counted_input = connection.reader.buffered();
    if (total_input <= options.limits.max_total_input) return;
    Connection* largest = &connection;
    for (auto& [fd, other] : connections)
      if (!other->doomed && other->counted_input > largest->counted_input) largest = other.get();
    doom(*largest, LogLevel::Warning,
         "holds " + byte_text(largest->counted_input) +
             " of partly received requests, the most while all connections "
             "together hold more than " +
             byte_text(options.limits.max_total_input) + " (max_total_input); disconnected");
  }

  void handle(Connection& connection, const protocol::Message& message) {
    if (message.kind() == protocol::Kind::Notification) {
      dispatcher.handle_notification(connection.session, message, options.log);
      return;
    }
    if (message.kind() != protocol::Kind::Request) {
      // The manager asks clients nothing, so responses are dropped: a newer
      // client's additions do not break the conversation.
      log(LogLevel::Debug, describe(connection) + ": ignored a message that is not a request ('" +
                               message.get_string_or("method", "") + "')");
      return;
    }
    const std::optional<Id> before = connection.session.client;
    Outbox out;
    const protocol::Message response = dispatcher.handle(connection.session, message, out, options.log);
    if (Dispatcher::is_deferred(response)) return deliver(out);  // answered through post() later
    if (response.is_error())
      log(LogLevel::Debug,
          describe(connection) + ": '" + message.get_string_or("method", "") + "' refused: " + response.error_text());
    if (connection.session.client != before) {
      if (before) by_client.erase(*before);
      if (connection.session.client) {
        by_client[*connection.session.client] = &connection;
        leave_pending(connection);
        log(LogLevel::Info, describe(connection) + " registered");
      }
    }
    send_response(connection, message, response);
    deliver(out);
    if (connection.session.close_after_response && connection.unsent() == 0)
      doom(connection, LogLevel::Info, "said goodbye");
  }

  // ------------------------------------------------------------ writing

  void send_response(Connection& connection, const protocol::Message& request, const protocol::Message& response) {
    std::string frame;
    try {
      frame = protocol::encode(response);
    } catch (const protocol::ProtocolError& e) {
      frame = protocol::encode(protocol::Message::error_response_to(
          request, LNE_INTERNAL_ERROR, "the response cannot be sent: " + std::string(e.what())));
    }
    queue(connection, frame);
  }

  void deliver(const Outbox& out) {
    for (const Outgoing& outgoing : out) {
      const auto it = by_client.find(outgoing.client);
      if (it == by_client.end()) continue;
      try {
        queue(*it->second, protocol::encode(outgoing.message));
      } catch (const protocol::ProtocolError& e) {
        log(LogLevel::Error, "cannot send a notification: " + std::string(e.what()));
      }
    }
  }

  void queue(Connection& connection, const std::string& frame) {
    if (connection.doomed) return;
    if (connection.unsent() + frame.size() > options.limits.max_output_queue)
      return doom(connection, LogLevel::Warning,
                  "does not read what the manager sends (more than " + std::to_string(options.limits.max_output_queue) +
                      " bytes pending, max_output_queue); disconnected");
    if (connection.written > 0 && connection.written * 2 >= connection.outgoing.size()) {
      connection.outgoing.erase(0, connection.written);
      connection.written = 0;
    }
    connection.outgoing += frame;
    total_output += frame.size();
    flush(connection);
    if (total_output > options.limits.max_total_output) shed_largest_output();
  }

  // All clients together may not hold more than max_total_output unsent:
  // the one that holds the most goes.
  void shed_largest_output() {
    Connection* largest = nullptr;
    for (auto& [fd, other] : connections)
      if (!other->doomed && (!largest || other->unsent() > largest->unsent())) largest = other.get();
    if (largest == nullptr) return;
    doom(*largest, LogLevel::Warning,
         "does not read what the manager sends (" + byte_text(largest->unsent()) +
             " pending, the most while all clients "
             "together have more than " +
             byte_text(options.limits.max_total_output) +
             " pending, max_total_output); "
             "disconnected");
  }

  void flush(Connection& connection) {
    while (connection.unsent() > 0) {
      const ssize_t count = ::send(connection.fd, connection.outgoing.data() + connection.written, connection.unsent(),
                                   MSG_NOSIGNAL | MSG_DONTWAIT);
      if (count < 0) {
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) break;
        return doom(connection, LogLevel::Info, errno_text("connection failed"));
      }
      connection.written += static_cast<std::size_t>(count);
      total_output -= static_cast<std::size_t>(count);
    }
    if (connection.unsent() == 0) {
      // A large answer went out: give its memory back.
      if (connection.outgoing.capacity() > 1024 * 1024) std::string().swap(connection.outgoing);
      connection.outgoing.clear();
      connection.written = 0;
      if (connection.session.close_after_response) return doom(connection, LogLevel::Info, "said goodbye");
    }
    const bool want_writable = connection.unsent() > 0;
    if (want_writable != connection.waiting_for_writable) {
      epoll_event event{};
      event.events = EPOLLIN | (want_writable ? EPOLLOUT : 0u);
      event.data.fd = connection.fd;
      ::epoll_ctl(epoll_fd, EPOLL_CTL_MOD, connection.fd, &event);
      connection.waiting_for_writable = want_writable;
    }
  }

  // ------------------------------------------------------------ closing

  std::string describe(const Connection& connection) const {
    if (connection.session.client) {
      const Client& client = registry.client(*connection.session.client);
      return "client '" + client.name + "' (id " + std::to_string(client.id) + ", pid " +
             std::to_string(client.hello.pid) + ", " + connection.peer + ")";
    }
    return "connection from " + connection.peer;
  }

  // Connections are closed between events, never in the middle of handling
  // one: releasing a client notifies others, which may doom them in turn.
  void doom(Connection& connection, LogLevel level, const std::string& reason) {
    if (connection.doomed) return;
    connection.doomed = true;
    log(level, describe(connection) + " " + reason);
    doomed.push_back(connection.fd);
    leave_pending(connection);
  }

  void close_doomed_connections() {
    while (!doomed.empty()) {
      const int fd = doomed.back();
      doomed.pop_back();
      const auto it = connections.find(fd);
      if (it == connections.end()) continue;
      Connection& connection = *it->second;
      if (connection.session.client) {
        const Id client = *connection.session.client;
        Outbox out;
        registry.remove_client(client, out);
        by_client.erase(client);
        deliver(out);
      }
      total_output -= connection.unsent();
      total_input -= connection.counted_input;
      ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
      ::close(fd);
      connections.erase(it);
    }
  }

  ManagerOptions options;
  DefinitionStore definitions;
  Registry registry;
  Dispatcher dispatcher;
  std::mutex posted_mutex;
  std::vector<Loggers::Task> posted;
  bool wake_fd_closing = false;
  Loggers loggers;  // after everything it uses: destroyed (its threads stopped) first

  int epoll_fd = -1;
  int listen_fd = -1;
  int wake_fd = -1;
  int spare_fd = -1;
  bool listening_paused = false;
  std::uint16_t bound_port = 0;
  std::atomic<int> stop_requests{0};
  std::unique_ptr<ProcessControl> processes;
  bool shutdown_begun = false;
  bool killed_all = false;
  std::thread thread;
  std::mutex join_mutex;  ///< two threads calling stop() must not both join
  std::atomic<std::thread::id> loop_thread{};

  std::map<int, std::unique_ptr<Connection>> connections;
  std::map<Id, Connection*> by_client;
  std::vector<int> doomed;
  std::list<int> pending;                               ///< unregistered connections, oldest first
  std::map<std::string, std::size_t> pending_per_peer;  ///< by IP address
  Clock::time_point next_pending_check{};
  std::vector<int> backlogged;   ///< connections with requests left for the next round
  std::size_t total_input = 0;   ///< partly received requests, all connections
  std::size_t total_output = 0;  ///< unsent messages, all connections
  std::array<char, 64 * 1024> receive_buffer{};
};

Manager::Manager(ManagerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

Manager::~Manager() { stop(); }

void Manager::start() { impl_->start(); }

std::uint16_t Manager::port() const { return impl_->bound_port; }

void Manager::run() { impl_->run(); }

void Manager::run_in_thread() {
  if (impl_->thread.joinable()) throw std::runtime_error("the manager already runs in a thread");
  if (impl_->listen_fd < 0) throw std::runtime_error("Manager::run_in_thread() needs start() first");
  impl_->thread = std::thread([this] { impl_->run(); });
}

void Manager::stop() {
  impl_->stop();
  if (impl_->loop_thread.load() == std::this_thread::get_id()) return;  // cannot join itself
  std::lock_guard<std::mutex> lock(impl_->join_mutex);
  if (impl_->thread.joinable()) impl_->thread.join();
}

}  // namespace ln::manager
