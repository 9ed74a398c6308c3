// Fuzz target: service frames sent to a provider (services/dispatch.hpp)
// after the handshake: mutated request frames for a fixed-size and a
// dynamic-size service, raw bytes, callers that never read their answers.
// The provider must keep serving, and a normal caller must get right
// answers after.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>

#include "fuzz.hpp"
#include "services/call_frames.hpp"
#include "services/test_harness.hpp"
#include "services_test_messages.h"

namespace ln::fuzz {
namespace {

using services::Request;
using services::Status;
using services::testing::GroupServer;
using services::testing::HandlerBox;
using services::testing::Harness;
using services::testing::signature;

std::string request_frame(std::uint32_t service_id, std::uint32_t request_id, const std::string& body) {
  std::string frame(services::frames::request_overhead + body.size(), '\0');
  services::frames::write_request_head(frame.data(), {service_id, request_id}, body.size());
  std::memcpy(frame.data() + services::frames::request_overhead, body.data(), body.size());
  return frame;
}

// Reads what is there, without waiting longer than `ms`.
void drain(int fd, int ms) {
  char sink[65536];
  pollfd p{fd, POLLIN, 0};
  while (::poll(&p, 1, ms) > 0 && ::recv(fd, sink, sizeof sink, MSG_DONTWAIT) > 0) {
  }
}

TEST(FuzzServiceFrames, TheProviderSurvivesAndServes) {
  Harness h;
  HandlerBox add{[](Request& r) {
    svc_test_add_t d;
    Status s = r.set_data(&d, svc_test_add_signature);
    if (!s.ok()) return s.code();
    // Fuzzed requests carry any numbers: add without overflowing.
    d.resp.sum = static_cast<std::int32_t>(static_cast<std::uint32_t>(d.req.a) + static_cast<std::uint32_t>(d.req.b));
    return r.respond().code();
  }};
  HandlerBox echo{[](Request& r) {
    svc_test_echo_t d;
    Status s = r.set_data(&d, svc_test_echo_signature);
    if (!s.ok()) return s.code();
    d.resp.data = d.req.data;
    d.resp.data_len = d.req.data_len;
    return r.respond().code();
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &add, nullptr));
  ASSERT_OK(h.dispatcher.add_provider(2, "echo", signature(svc_test_echo_signature), &HandlerBox::call, &echo, "echo"));
  GroupServer add_server(h.dispatcher, nullptr);
  ASSERT_OK(h.dispatcher.handle_in_pool("echo", "fuzz_pool"));
  ASSERT_OK(h.dispatcher.set_max_threads("fuzz_pool", 2));

  // Valid requests: two int32 for add, a length and bytes for echo.
  const std::string add_body("\x01\x00\x00\x00\x02\x00\x00\x00", 8);
  const std::string echo_body = std::string("\x05\x00\x00\x00", 4) + "hello";
  const std::vector<std::string> corpus = {request_frame(1, 1, add_body), request_frame(2, 1, echo_body),
                                           request_frame(1, 7, add_body) + request_frame(1, 8, add_body)};
  Mutator mutator(seed());
  std::vector<int> kept;  // callers that never read, kept open for a while
  Budget budget(15000);
  while (budget.next()) {
    const std::uint32_t service = 1 + static_cast<std::uint32_t>(mutator.below(2));
    int fds[2];
    ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds), 0);
    ASSERT_OK(h.dispatcher.adopt_connection(fds[1], service));
    std::string bytes;
    switch (mutator.below(4)) {
      case 0:
        bytes = mutator.random_bytes(512);
        break;
      case 1: {  // many valid requests, answers never read
        const std::string one = request_frame(service, 1, service == 1 ? add_body : echo_body);
        for (int i = 0; i < 2000; ++i) bytes += one;
        break;
      }
      default:
        bytes = mutator.mutate(corpus[mutator.below(corpus.size())], corpus);
    }
    const ssize_t sent = ::send(fds[0], bytes.data(), bytes.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    (void)sent;  // whatever the socket took
    if (mutator.chance(3) && kept.size() < 32) {
      kept.push_back(fds[0]);
    } else {
      drain(fds[0], mutator.chance(4) ? 1 : 0);
      ::close(fds[0]);
    }
    if (kept.size() == 32) {
      for (int fd : kept) ::close(fd);
      kept.clear();
    }
  }
  std::printf("[fuzz] service frames: %d rounds, seed %llu\n", budget.done(), static_cast<unsigned long long>(seed()));
  // The callers that did not read still hold connections: normal callers
  // of both services are served regardless.
  auto add_caller = h.caller(1, signature(svc_test_add_signature));
  svc_test_add_t d{};
  d.req.a = 40;
  d.req.b = 2;
  ASSERT_EQ(add_caller->call(&d, 10), 0) << add_caller->last_error() << " (seed " << seed() << ")";
  EXPECT_EQ(d.resp.sum, 42);
  auto echo_caller = h.caller(2, signature(svc_test_echo_signature));
  svc_test_echo_t e{};
  std::uint8_t payload[3] = {7, 8, 9};
  e.req.data = payload;
  e.req.data_len = 3;
  ASSERT_EQ(echo_caller->call(&e, 10), 0) << echo_caller->last_error();
  ASSERT_EQ(e.resp.data_len, 3u);
  EXPECT_EQ(e.resp.data[2], 9);
  for (int fd : kept) ::close(fd);
}

}  // namespace
}  // namespace ln::fuzz
