#include "client/net.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "client/c_api.hpp"
#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

using Clock = std::chrono::steady_clock;

sockaddr_un abstract_address(const std::string& name, socklen_t& length) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (name.size() + 1 > sizeof(address.sun_path))
    throw Failure(LNE_INVALID_PARAMETER, "peer socket name is too long: " + name);
  // Abstract namespace: a leading NUL byte, then the name (not terminated).
  std::memcpy(address.sun_path + 1, name.data(), name.size());
  length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  return address;
}

int poll_one(int fd, short events, Clock::time_point deadline) {
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left < 0) return 0;
    pollfd p{fd, events, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::min<long long>(left + 1, 60'000)));
    if (n < 0 && errno == EINTR) continue;
    if (n != 0 || Clock::now() >= deadline) return n;
  }
}

}  // namespace

ManagerAddress parse_manager_address(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw Failure(LNE_INVALID_MANAGER_ADDRESS, "manager address '" + text + "' is not HOST:PORT");
  ManagerAddress address;
  address.host = text.substr(0, colon);
  const std::string port = text.substr(colon + 1);
  if (address.host.empty())
    throw Failure(LNE_INVALID_HOSTNAME, "manager address '" + text + "' has no host before the ':'");
  char* end = nullptr;
  errno = 0;
  const unsigned long number = port.empty() ? 0 : std::strtoul(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || errno != 0 || number == 0 || number > 65535 || port[0] == '-' || port[0] == '+')
    throw Failure(LNE_INVALID_MANAGER_ADDRESS,
                  "manager address '" + text + "' has no valid port number (1..65535) after the ':'");
  address.port = static_cast<std::uint16_t>(number);
  return address;
}

sockaddr_in resolve_ipv4(const ManagerAddress& address) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int status = ::getaddrinfo(address.host.c_str(), nullptr, &hints, &found);
  if (status == 0 && found != nullptr) {
    sockaddr_in result{};
    std::memcpy(&result, found->ai_addr, sizeof result);
    ::freeaddrinfo(found);
    result.sin_port = htons(address.port);
    return result;
  }
  if (found != nullptr) ::freeaddrinfo(found);
  // Tell "resolves, but only to IPv6" apart from "does not resolve".
  hints.ai_family = AF_UNSPEC;
  if (::getaddrinfo(address.host.c_str(), nullptr, &hints, &found) == 0) {
    ::freeaddrinfo(found);
    throw Failure(LNE_HOST_WRONG_NET, "manager host '" + address.host + "' has no IPv4 address");
  }
  throw Failure(LNE_UNKNOWN_HOSTNAME,
                "manager host '" + address.host + "' does not resolve: " + ::gai_strerror(status));
}

UniqueFd start_tcp_connect(const sockaddr_in& address) {
  UniqueFd fd(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw errno_failure(errno, "creating the manager socket");
  const int one = 1;
  ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // Notice a manager host that vanished without closing the connection.
  const int idle = 5;
  ::setsockopt(fd.get(), SOL_SOCKET, SO_KEEPALIVE, &one, sizeof one);
  ::setsockopt(fd.get(), IPPROTO_TCP, TCP_KEEPIDLE, &idle, sizeof idle);
  ::setsockopt(fd.get(), IPPROTO_TCP, TCP_KEEPINTVL, &idle, sizeof idle);
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 && errno != EINPROGRESS) {
    const int err = errno;
    char ip[INET_ADDRSTRLEN] = "?";
    ::inet_ntop(AF_INET, &address.sin_addr, ip, sizeof ip);
    throw errno_failure(
        err, std::string("connecting to the ln_manager at ") + ip + ":" + std::to_string(ntohs(address.sin_port)));
  }
  return fd;
}

int finish_connect(int fd) noexcept {
  int error = 0;
  socklen_t length = sizeof error;
  if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length) != 0) return errno;
  return error;
}

UniqueFd connect_tcp(const sockaddr_in& address, std::chrono::milliseconds timeout) {
  UniqueFd fd = start_tcp_connect(address);
  const int ready = poll_one(fd.get(), POLLOUT, Clock::now() + timeout);
  char ip[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &address.sin_addr, ip, sizeof ip);
  const std::string where =
      std::string("connecting to the ln_manager at ") + ip + ":" + std::to_string(ntohs(address.sin_port));
  if (ready <= 0) throw errno_failure(ETIMEDOUT, where);
  if (const int error = finish_connect(fd.get()); error != 0) throw errno_failure(error, where);
  return fd;
}

UniqueFd listen_abstract_unix(const std::string& name) {
  socklen_t length = 0;
  const sockaddr_un address = abstract_address(name, length);
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw errno_failure(errno, "creating the peer server socket");
  if (::bind(fd.get(), reinterpret_cast<const sockaddr*>(&address), length) != 0)
    throw errno_failure(errno, "binding the peer server socket '" + name + "'");
  if (::listen(fd.get(), 64) != 0) throw errno_failure(errno, "listening on the peer server socket");
  return fd;
}

UniqueFd connect_abstract_unix(const std::string& name) {
  socklen_t length = 0;
  const sockaddr_un address = abstract_address(name, length);
  UniqueFd fd(::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
  if (!fd.valid()) throw errno_failure(errno, "creating a peer socket");
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&address), length) != 0 && errno != EINPROGRESS)
    throw errno_failure(errno, "connecting to peer '" + name + "'");
  return fd;
}

long peer_uid(int unix_socket) noexcept {
  ucred credentials{};
  socklen_t length = sizeof credentials;
  if (::getsockopt(unix_socket, SOL_SOCKET, SO_PEERCRED, &credentials, &length) != 0) return -1;
  return static_cast<long>(credentials.uid);
}

std::string host_identity() {
  std::string boot_id;
  std::ifstream in("/proc/sys/kernel/random/boot_id");
  std::getline(in, boot_id);
  if (boot_id.empty()) boot_id = host_name();
  struct stat net_namespace {};
  const unsigned long long namespace_inode =
      ::stat("/proc/self/ns/net", &net_namespace) == 0 ? static_cast<unsigned long long>(net_namespace.st_ino) : 0;
  return boot_id + "/" + std::to_string(namespace_inode);
}

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

int send_all(int fd, const std::string& bytes, int fd_to_pass, std::chrono::milliseconds timeout) noexcept {
  const Clock::time_point deadline = Clock::now() + timeout;
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    iovec part{const_cast<char*>(bytes.data() + sent), bytes.size() - sent};
    msghdr message{};
    message.msg_iov = &part;
    message.msg_iovlen = 1;
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
    if (fd_to_pass >= 0 && sent == 0) {
      message.msg_control = control;
      message.msg_controllen = sizeof control;
      cmsghdr* header = CMSG_FIRSTHDR(&message);
      header->cmsg_level = SOL_SOCKET;
      header->cmsg_type = SCM_RIGHTS;
      header->cmsg_len = CMSG_LEN(sizeof(int));
      std::memcpy(CMSG_DATA(header), &fd_to_pass, sizeof(int));
    }
    const ssize_t n = ::sendmsg(fd, &message, MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (poll_one(fd, POLLOUT, deadline) <= 0) return ETIMEDOUT;
      continue;
    }
    return n < 0 ? errno : EPIPE;
  }
  return 0;
}

long receive_some(int fd, std::string& out, std::vector<UniqueFd>& fds) noexcept {
  char buffer[64 * 1024];
  iovec part{buffer, sizeof buffer};
  msghdr message{};
  message.msg_iov = &part;
  message.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 8)];
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  ssize_t n;
  do {
    n = ::recvmsg(fd, &message, MSG_CMSG_CLOEXEC);
  } while (n < 0 && errno == EINTR);
  if (n < 0) return -1;
  for (cmsghdr* header = CMSG_FIRSTHDR(&message); header != nullptr; header = CMSG_NXTHDR(&message, header)) {
    if (header->cmsg_level != SOL_SOCKET || header->cmsg_type != SCM_RIGHTS) continue;
    const std::size_t count = (header->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (std::size_t i = 0; i < count; ++i) {
      int received = -1;
      std::memcpy(&received, CMSG_DATA(header) + i * sizeof(int), sizeof(int));
      fds.emplace_back(received);
    }
  }
  try {
    out.append(buffer, static_cast<std::size_t>(n));
  } catch (...) {
    errno = ENOMEM;
    return -1;
  }
  return static_cast<long>(n);
}

}  // namespace ln::clientlib
