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
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "manager/definitions.hpp"
#include "manager/dispatch.hpp"
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
  if (status != 0 || !found)
    throw std::runtime_error("cannot listen on '" + host + "': " + ::gai_strerror(status));
  address = reinterpret_cast<sockaddr_in*>(found->ai_addr)->sin_addr;
  ::freeaddrinfo(found);
  return address;
}

std::string endpoint_text(const sockaddr_in& address) {
  char text[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &address.sin_addr, text, sizeof text);
  return std::string(text) + ":" + std::to_string(ntohs(address.sin_port));
}

struct Connection {
  int fd = -1;
  std::string peer;
  protocol::FrameReader reader;
  std::string outgoing;  ///< encoded frames not yet written ...
  std::size_t written = 0;  ///< ... of which this many bytes are out
  bool waiting_for_writable = false;
  Session session;
  bool doomed = false;

  std::size_t unsent() const { return outgoing.size() - written; }
};

}  // namespace

struct Manager::Impl {
  explicit Impl(ManagerOptions o)
      : options(std::move(o)),
        definitions(options.message_definition_dirs, options.generated_definition_dir.empty()
                                                         ? default_generated_dir()
                                                         : options.generated_definition_dir),
        registry(definitions),
        dispatcher(registry, definitions, std::string("ln_core ") + LN_MANAGER_VERSION),
        loggers(registry, definitions, [this](Loggers::Task task) { post(std::move(task)); }, options.log) {
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
    log(LogLevel::Info, "message-definition search path: " + (dirs.empty() ? std::string("(no existing directory)") : dirs));
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
      // While listening is paused (out of descriptors), look again soon.
      const int timeout_ms = listening_paused ? 100 : -1;
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
      close_doomed_connections();
    }
    log(LogLevel::Info, "stopping; " + std::to_string(connections.size()) + " connection(s) closed");
    for (auto& entry : connections) ::close(entry.first);
    connections.clear();
    by_client.clear();
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
      const int fd =
          ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&address), &size, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR || errno == ECONNABORTED) continue;
        if (errno == EMFILE || errno == ENFILE) shed_connection_without_descriptor();
        else if (errno != EAGAIN && errno != EWOULDBLOCK) log(LogLevel::Warning, errno_text("accept failed"));
        return;
      }
      const std::string peer = endpoint_text(address);
      if (connections.size() >= options.max_clients) {
        log(LogLevel::Warning, "refused the connection from " + peer + ": already " +
                                   std::to_string(connections.size()) + " connections (the limit)");
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
      auto connection = std::make_unique<Connection>();
      connection->fd = fd;
      connection->peer = peer;
      connections[fd] = std::move(connection);
      log(LogLevel::Debug, "connection from " + peer);
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
      log(LogLevel::Warning, "out of file descriptors (" + std::to_string(connections.size()) +
                                 " connections): refused a new connection");
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
    const ssize_t count = ::recv(connection.fd, receive_buffer.data(), receive_buffer.size(), 0);
    if (count == 0) return doom(connection, LogLevel::Info, "closed the connection");
    if (count < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
      return doom(connection, LogLevel::Info, errno_text("connection failed"));
    }
    try {
      connection.reader.append(receive_buffer.data(), static_cast<std::size_t>(count));
      while (!connection.doomed && !connection.session.close_after_response) {
        auto message = connection.reader.next();
        if (!message) break;
        handle(connection, *message);
      }
      // What is left is one incomplete message.
      if (connection.reader.buffered() > options.max_request_size)
        doom(connection, LogLevel::Warning,
             "sent a message larger than " + std::to_string(options.max_request_size) + " bytes; disconnected");
    } catch (const protocol::ProtocolError& e) {
      doom(connection, LogLevel::Warning, "sent a malformed message (" + std::string(e.what()) + "); disconnected");
    }
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
      log(LogLevel::Debug, describe(connection) + ": '" + message.get_string_or("method", "") +
                               "' refused: " + response.error_text());
    if (connection.session.client != before) {
      if (before) by_client.erase(*before);
      if (connection.session.client) {
        by_client[*connection.session.client] = &connection;
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
    if (connection.unsent() + frame.size() > options.max_output_queue)
      return doom(connection, LogLevel::Warning,
                  "does not read what the manager sends (more than " + std::to_string(options.max_output_queue) +
                      " bytes pending); disconnected");
    if (connection.written > 0 && connection.written * 2 >= connection.outgoing.size()) {
      connection.outgoing.erase(0, connection.written);
      connection.written = 0;
    }
    connection.outgoing += frame;
    flush(connection);
  }

  void flush(Connection& connection) {
    while (connection.unsent() > 0) {
      const ssize_t count = ::send(connection.fd, connection.outgoing.data() + connection.written,
                                   connection.unsent(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (count < 0) {
        if (errno == EINTR) continue;
        if (errno == EAGAIN || errno == EWOULDBLOCK) break;
        return doom(connection, LogLevel::Info, errno_text("connection failed"));
      }
      connection.written += static_cast<std::size_t>(count);
    }
    if (connection.unsent() == 0) {
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
