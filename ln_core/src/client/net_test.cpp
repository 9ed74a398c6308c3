#include "client/net.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>

#include "client/c_api.hpp"
#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

int code_of(const std::function<void()>& action) {
  try {
    action();
  } catch (const Failure& failure) {
    return failure.code();
  }
  return 0;
}

TEST(ManagerAddressParsing, SplitsAtTheFirstColon) {
  const ManagerAddress address = parse_manager_address("localhost:54414");
  EXPECT_EQ(address.host, "localhost");
  EXPECT_EQ(address.port, 54414);
  EXPECT_EQ(address.text(), "localhost:54414");
}

TEST(ManagerAddressParsing, RefusesWhatIsNotHostColonPort) {
  EXPECT_EQ(code_of([] { parse_manager_address("localhost"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address("localhost:"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address("localhost:abc"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address("localhost:0"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address("localhost:65536"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address("localhost:-1"); }), LNE_INVALID_MANAGER_ADDRESS);
  EXPECT_EQ(code_of([] { parse_manager_address(":54414"); }), LNE_INVALID_HOSTNAME);
}

TEST(ManagerAddressParsing, ResolvesIpv4AndRefusesUnknownHosts) {
  const sockaddr_in loopback = resolve_ipv4(parse_manager_address("127.0.0.1:5"));
  EXPECT_EQ(ntohl(loopback.sin_addr.s_addr), 0x7f000001u);
  EXPECT_EQ(ntohs(loopback.sin_port), 5);
  EXPECT_EQ(code_of([] { resolve_ipv4(parse_manager_address("no-such-host.invalid:5")); }), LNE_UNKNOWN_HOSTNAME);
}

TEST(HostIdentity, IsStableAndNamesTheNetworkNamespace) {
  const std::string id = host_identity();
  EXPECT_EQ(id, host_identity());
  EXPECT_NE(id.find('/'), std::string::npos);
}

TEST(FdPassing, SendAllPassesADescriptorWithTheBytes) {
  int pair[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK, 0, pair), 0);
  UniqueFd a(pair[0]), b(pair[1]);
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  UniqueFd pipe_read(pipe_fds[0]), pipe_write(pipe_fds[1]);
  ASSERT_EQ(send_all(a.get(), "hello", pipe_write.get(), std::chrono::milliseconds(1000)), 0);
  std::string received;
  std::vector<UniqueFd> fds;
  ASSERT_EQ(receive_some(b.get(), received, fds), 5);
  EXPECT_EQ(received, "hello");
  ASSERT_EQ(fds.size(), 1u);
  ASSERT_EQ(::write(fds[0].get(), "x", 1), 1);  // the passed descriptor is the pipe's write end
  char byte = 0;
  ASSERT_EQ(::read(pipe_read.get(), &byte, 1), 1);
  EXPECT_EQ(byte, 'x');
}

}  // namespace
}  // namespace ln::clientlib
