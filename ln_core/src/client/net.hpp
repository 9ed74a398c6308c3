// Socket plumbing of the client: the manager's TCP address, the abstract
// Unix sockets of peer servers, and sending and receiving bytes together
// with file descriptors.
#pragma once

#include <netinet/in.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "transport/shm_segment.hpp"

namespace ln::clientlib {

using transport::UniqueFd;

struct ManagerAddress {
  std::string host;
  std::uint16_t port = 0;
  std::string text() const { return host + ":" + std::to_string(port); }
};

/// Splits "HOST:PORT" at the first ':' (LN's rule). Throws Failure:
/// LNE_INVALID_MANAGER_ADDRESS (no ':' or no valid port number),
/// LNE_INVALID_HOSTNAME (empty host).
ManagerAddress parse_manager_address(const std::string& text);

/// The IPv4 address of `host`. Throws Failure: LNE_UNKNOWN_HOSTNAME,
/// LNE_HOST_WRONG_NET (resolves, but not to IPv4).
sockaddr_in resolve_ipv4(const ManagerAddress& address);

/// Starts a non-blocking TCP connect. Returns the socket (connect may still be
/// in progress: wait for POLLOUT, then check with finish_connect). Throws
/// Failure (LNE_CHECK_ERRNO) when it fails at once.
UniqueFd start_tcp_connect(const sockaddr_in& address);
/// 0 when the connect of `fd` completed, else the errno it failed with.
int finish_connect(int fd) noexcept;
/// A connected, non-blocking TCP socket, or Failure (LNE_CHECK_ERRNO, e.g.
/// "errno 111 - Connection refused") after at most `timeout`.
UniqueFd connect_tcp(const sockaddr_in& address, std::chrono::milliseconds timeout);

/// A non-blocking listening socket on the abstract Unix address `name`
/// (no file system entry, gone with the process). Throws Failure.
UniqueFd listen_abstract_unix(const std::string& name);
/// A non-blocking socket connected to the abstract Unix address `name`.
/// Throws Failure (LNE_CHECK_ERRNO, e.g. ECONNREFUSED when nobody listens).
UniqueFd connect_abstract_unix(const std::string& name);
/// The uid of the process at the other end of a Unix socket, or -1.
long peer_uid(int unix_socket) noexcept;

/// "boot id/network namespace": processes with equal ids can share memory
/// and reach each other's abstract Unix sockets.
std::string host_identity();
/// The host name, for display.
std::string host_name();

/// Sends all of `bytes`, attaching `fd_to_pass` (if >= 0) to the first byte.
/// Waits for the socket to drain when it is full (non-blocking sockets), at
/// most `timeout`. Returns 0 or an errno (EPIPE, ETIMEDOUT, ...).
int send_all(int fd, const std::string& bytes, int fd_to_pass, std::chrono::milliseconds timeout) noexcept;

/// Reads what is available (non-blocking) into `out`, collecting passed file
/// descriptors into `fds`. Returns the number of bytes read, 0 at EOF, -1 on
/// error (errno set; EAGAIN when nothing is there).
long receive_some(int fd, std::string& out, std::vector<UniqueFd>& fds) noexcept;

}  // namespace ln::clientlib
