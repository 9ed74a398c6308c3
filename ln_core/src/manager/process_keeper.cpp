#include "manager/process_keeper.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "manager/child_process.hpp"
#include "manager/process_output.hpp"
#include "protocol/wire.hpp"

namespace ln::manager {
namespace {

using protocol::Message;

// One hand-over message must fit one SOCK_SEQPACKET packet.
constexpr std::size_t max_packet = 200 * 1024;
constexpr std::size_t kept_output_bytes = 128 * 1024;
constexpr std::size_t kept_output_lines = 1000;

sockaddr_un abstract_address(const std::string& name, socklen_t& length) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::size_t size = std::min(name.size(), sizeof address.sun_path - 1);
  std::memcpy(address.sun_path + 1, name.data(), size);  // sun_path[0] == '\0': abstract
  length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + size);
  return address;
}

// Sends `message` with up to two descriptors (-1: none) as one packet.
bool send_packet(int fd, const Message& message, int fd1, int fd2) {
  const std::string frame = protocol::encode(message);
  iovec io{const_cast<char*>(frame.data()), frame.size()};
  msghdr header{};
  header.msg_iov = &io;
  header.msg_iovlen = 1;
  int fds[2];
  int count = 0;
  for (int f : {fd1, fd2})
    if (f >= 0) fds[count++] = f;
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof fds)];
  if (count > 0) {
    header.msg_control = control;
    header.msg_controllen = CMSG_SPACE(sizeof(int) * static_cast<std::size_t>(count));
    cmsghdr* cmsg = CMSG_FIRSTHDR(&header);
    cmsg->cmsg_level = SOL_SOCKET;
    cmsg->cmsg_type = SCM_RIGHTS;
    cmsg->cmsg_len = CMSG_LEN(sizeof(int) * static_cast<std::size_t>(count));
    std::memcpy(CMSG_DATA(cmsg), fds, sizeof(int) * static_cast<std::size_t>(count));
  }
  for (;;) {
    const ssize_t n = ::sendmsg(fd, &header, MSG_NOSIGNAL);
    if (n >= 0) return true;
    if (errno != EINTR) return false;
  }
}

// Receives one packet: the message and its descriptors. nullopt at the end.
std::optional<Message> receive_packet(int fd, std::vector<int>& fds) {
  std::string buffer(max_packet + 64, '\0');
  iovec io{buffer.data(), buffer.size()};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 4)];
  msghdr header{};
  header.msg_iov = &io;
  header.msg_iovlen = 1;
  header.msg_control = control;
  header.msg_controllen = sizeof control;
  ssize_t n;
  do n = ::recvmsg(fd, &header, MSG_CMSG_CLOEXEC);
  while (n < 0 && errno == EINTR);
  fds.clear();
  for (cmsghdr* cmsg = CMSG_FIRSTHDR(&header); cmsg != nullptr; cmsg = CMSG_NXTHDR(&header, cmsg))
    if (cmsg->cmsg_level == SOL_SOCKET && cmsg->cmsg_type == SCM_RIGHTS) {
      const std::size_t count = (cmsg->cmsg_len - CMSG_LEN(0)) / sizeof(int);
      for (std::size_t i = 0; i < count; ++i) {
        int received;
        std::memcpy(&received, CMSG_DATA(cmsg) + i * sizeof(int), sizeof received);
        fds.push_back(received);
      }
    }
  if (n <= 0) {
    for (int f : fds) ::close(f);
    fds.clear();
    return std::nullopt;
  }
  protocol::FrameReader reader;
  reader.append(buffer.data(), static_cast<std::size_t>(n));
  return reader.next();
}

Message describe(const KeptProcess& process) {
  Message m = Message::notification("kept_process");
  m.set("name", process.name)
      .set("pid", static_cast<std::int64_t>(process.pid))
      .set("start_ticks", static_cast<std::int64_t>(process.start_ticks))
      .set("ready", process.ready)
      .set("ended", process.ended)
      .set("has_output", process.output_fd >= 0)
      .set("has_pidfd", process.pidfd >= 0)
      .set("output", process.output);
  return m;
}

KeptProcess from_message(const Message& m, const std::vector<int>& fds) {
  KeptProcess process;
  process.name = m.get_string("name");
  process.pid = static_cast<pid_t>(m.get_int("pid"));
  process.start_ticks = static_cast<std::uint64_t>(m.get_int("start_ticks"));
  process.ready = m.get_bool("ready");
  process.ended = m.get_bool_or("ended", false);
  process.output = m.get_list("output");
  std::size_t next = 0;
  if (m.get_bool("has_output") && next < fds.size()) process.output_fd = fds[next++];
  if (m.get_bool("has_pidfd") && next < fds.size()) process.pidfd = fds[next++];
  for (; next < fds.size(); ++next) ::close(fds[next]);
  return process;
}

void close_fds(KeptProcess& process) {
  if (process.output_fd >= 0) ::close(process.output_fd);
  if (process.pidfd >= 0) ::close(process.pidfd);
  process.output_fd = process.pidfd = -1;
}

}  // namespace

std::uint64_t process_start_ticks(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  if (!std::getline(in, stat)) return 0;
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(stat.substr(close + 2));
  std::string field;
  // starttime is field 22; after the command (field 2) that is the 20th
  for (int i = 0; i < 20 && fields >> field; ++i) {
  }
  try {
    return std::stoull(field);
  } catch (const std::exception&) {
    return 0;
  }
}

std::string keeper_socket_name(const std::string& instance) {
  return "ln_core_process_keeper/" + std::to_string(::getuid()) + "/" + instance;
}

// ------------------------------------------------------------ manager side

KeeperLink::~KeeperLink() {
  if (fd_ >= 0) ::close(fd_);
}

std::string KeeperLink::start(const std::vector<std::string>& argv) {
  if (argv.empty()) return "no keeper command";
  int pair[2];
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, pair) != 0)
    return std::string("socketpair: ") + std::strerror(errno);
  SpawnRequest request;
  request.argv = argv;
  request.pty = false;
  request.discard_output = true;
  request.extra_fd = pair[1];
  for (char** entry = environ; *entry != nullptr; ++entry) request.environment.emplace_back(*entry);
  try {
    SpawnedChild child = spawn_child(request);
    ::close(child.pidfd);  // it outlives this manager: nothing here waits for it
    pid_ = child.pid;
  } catch (const SpawnError& e) {
    ::close(pair[0]);
    ::close(pair[1]);
    return e.what();
  }
  ::close(pair[1]);
  fd_ = pair[0];
  return "";
}

void KeeperLink::add(const KeptProcess& process) {
  if (fd_ < 0) return;
  KeptProcess meta = process;
  meta.output.clear();
  send_packet(fd_, describe(meta), process.output_fd, process.pidfd);
}

void KeeperLink::remove(const std::string& name) {
  if (fd_ < 0) return;
  Message m = Message::notification("forget");
  m.set("name", name);
  send_packet(fd_, m, -1, -1);
}

std::vector<KeptProcess> adopt_from_keeper(const std::string& instance, double timeout_seconds) {
  std::vector<KeptProcess> adopted;
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd < 0) return adopted;
  socklen_t length = 0;
  const sockaddr_un address = abstract_address(keeper_socket_name(instance), length);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), length) != 0) {
    ::close(fd);
    return adopted;  // no keeper of this instance
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_seconds);
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) {
      for (auto& process : adopted) close_fds(process);
      ::close(fd);
      throw std::runtime_error("the process keeper of instance '" + instance + "' did not hand over in time");
    }
    std::vector<int> fds;
    std::optional<Message> message;
    try {
      message = receive_packet(fd, fds);
    } catch (const protocol::ProtocolError& e) {
      for (int f : fds) ::close(f);
      message.reset();
    }
    if (message && message->method() == "busy") {
      ::close(fd);
      throw std::runtime_error("another manager of instance '" + instance + "' runs (" +
                               message->get_string_or("reason", "") + ")");
    }
    if (!message || message->method() == "done") break;
    if (message->method() == "kept_process")
      adopted.push_back(from_message(*message, fds));
    else
      for (int f : fds) ::close(f);
  }
  ::close(fd);
  return adopted;
}

// -------------------------------------------------------------- the keeper

namespace {

struct Held {
  KeptProcess process;
  OutputRing ring{kept_output_lines};
};

void read_held(Held& held) {
  std::array<char, 16384> buffer;
  for (int round = 0; round < 64; ++round) {
    const ssize_t n = ::read(held.process.output_fd, buffer.data(), buffer.size());
    if (n > 0) {
      held.ring.append(std::string_view(buffer.data(), static_cast<std::size_t>(n)), {});
      continue;
    }
    if (n < 0 && (errno == EINTR)) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    ::close(held.process.output_fd);  // ended (EIO of a pty whose other side closed)
    held.process.output_fd = -1;
    return;
  }
}

std::vector<std::string> bounded_output(const OutputRing& ring) {
  std::vector<std::string> lines = ring.tail(kept_output_lines).lines;
  if (!ring.partial().empty()) lines.push_back(ring.partial());
  std::size_t bytes = 0, keep = lines.size();
  while (keep > 0 && bytes + lines[keep - 1].size() < kept_output_bytes) bytes += lines[--keep].size();
  lines.erase(lines.begin(), lines.begin() + static_cast<long>(keep));
  return lines;
}

// Listens on the instance's abstract socket; a keeper that is just
// handing over may still hold the name for a moment.
int listen_for_adopter(const std::string& instance) {
  socklen_t length = 0;
  const sockaddr_un address = abstract_address(keeper_socket_name(instance), length);
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (fd < 0) return -1;
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), length) == 0 && ::listen(fd, 4) == 0) return fd;
    ::close(fd);
    if (errno != EADDRINUSE) return -1;
    ::usleep(20000);  // the other keeper closes its socket once it handed over
  }
  return -1;
}

bool same_user(int peer) {
  ucred credentials{};
  socklen_t size = sizeof credentials;
  return ::getsockopt(peer, SOL_SOCKET, SO_PEERCRED, &credentials, &size) == 0 && credentials.uid == ::getuid();
}

// Phase 1, while the manager lives: take what it hands over. A manager of
// the same instance that asks meanwhile is told that one runs. Returns
// once the manager is gone.
void serve_manager(int link_fd, int listen_fd, std::map<std::string, Held>& held) {
  for (;;) {
    pollfd fds[2] = {{link_fd, POLLIN, 0}, {listen_fd, POLLIN, 0}};
    if (::poll(fds, listen_fd >= 0 ? 2 : 1, -1) < 0) {
      if (errno == EINTR) continue;
      return;
    }
    if (fds[0].revents != 0) {
      std::vector<int> received;
      std::optional<Message> message;
      try {
        message = receive_packet(link_fd, received);
      } catch (const protocol::ProtocolError&) {
        for (int f : received) ::close(f);
        continue;
      }
      if (!message) return;  // the manager is gone
      const std::string method = message->method();
      if (method == "kept_process") {
        KeptProcess process = from_message(*message, received);
        if (auto it = held.find(process.name); it != held.end()) close_fds(it->second.process);
        held[process.name].process = std::move(process);
      } else if (method == "forget") {
        if (auto it = held.find(message->get_string("name")); it != held.end()) {
          close_fds(it->second.process);
          held.erase(it);
        }
      } else {
        for (int f : received) ::close(f);
      }
      continue;  // the link first: a manager that died must be noticed before its successor is answered
    }
    if (fds[1].revents != 0) {
      const int peer = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
      if (peer < 0) continue;
      pollfd link{link_fd, POLLIN, 0};
      if (::poll(&link, 1, 0) == 1) {
        // the manager may just have died: read the link first, then ask again
        ::close(peer);
        continue;
      }
      Message busy = Message::notification("busy");
      busy.set("reason", "a manager of this instance runs and holds its processes");
      send_packet(peer, busy, -1, -1);
      ::close(peer);
    }
  }
}

// Sends everything held to the adopting manager on `peer`.
void hand_over(int peer, std::map<std::string, Held>& held) {
  for (auto& [name, h] : held) {
    if (h.process.output_fd >= 0) read_held(h);
    h.process.output = bounded_output(h.ring);
    if (h.process.ended || process_start_ticks(h.process.pid) != h.process.start_ticks) h.process.ended = true;
    send_packet(peer, describe(h.process), h.process.output_fd, h.process.pidfd);
  }
  send_packet(peer, Message::notification("done"), -1, -1);
}

}  // namespace

int run_process_keeper(int link_fd, const std::string& instance) {
  std::map<std::string, Held> held;
  const int listen_fd = listen_for_adopter(instance);
  serve_manager(link_fd, listen_fd, held);
  ::close(link_fd);
  if (held.empty() || listen_fd < 0) return held.empty() ? 0 : 1;

  // The manager is gone: keep the output flowing and wait for the next one.
  const int epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  auto watch = [&](int fd) {
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.fd = fd;
    ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, fd, &event);
  };
  watch(listen_fd);
  for (auto& [name, h] : held) {
    if (h.process.output_fd >= 0) {
      ::fcntl(h.process.output_fd, F_SETFL, ::fcntl(h.process.output_fd, F_GETFL) | O_NONBLOCK);
      watch(h.process.output_fd);
    }
    if (h.process.pidfd >= 0) watch(h.process.pidfd);
  }
  for (;;) {
    bool all_ended = true;
    for (const auto& [name, h] : held) all_ended = all_ended && h.process.ended && h.process.output_fd < 0;
    if (all_ended) return 0;  // nothing left to hand over
    std::array<epoll_event, 32> events;
    const int count = ::epoll_wait(epoll_fd, events.data(), static_cast<int>(events.size()), -1);
    if (count < 0 && errno != EINTR) return 1;
    for (int i = 0; i < count; ++i) {
      const int fd = events[static_cast<std::size_t>(i)].data.fd;
      if (fd == listen_fd) {
        const int peer = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
        if (peer < 0) continue;
        if (!same_user(peer)) {
          ::close(peer);
          continue;
        }
        hand_over(peer, held);
        ::close(peer);
        return 0;
      }
      for (auto& [name, h] : held) {
        if (fd == h.process.output_fd) {
          read_held(h);
        } else if (fd == h.process.pidfd) {
          h.process.ended = true;
          ::epoll_ctl(epoll_fd, EPOLL_CTL_DEL, fd, nullptr);
        }
      }
    }
  }
}

}  // namespace ln::manager
