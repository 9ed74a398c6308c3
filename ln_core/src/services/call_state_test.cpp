// Caller-side semantics: timeouts, aborts, asynchronous calls, a provider
// that dies mid-call, reconnection, large data and limits.
#include "services/call_state.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstring>
#include <future>
#include <string>
#include <vector>

#include "services/test_harness.hpp"
#include "services_test_messages.h"

namespace ln::services {
namespace {

using namespace testing;  // test_harness.hpp

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

int echo_bytes(Request& r) {
  svc_test_echo_t d;
  Status s = r.set_data(&d, svc_test_echo_signature);
  if (!s.ok()) return s.code();
  d.resp.data_len = d.req.data_len;
  d.resp.data = d.req.data;  // request memory lives until the handler ends
  return r.respond().code();
}

/// A svc_test/add request of a + b; its response's sum preset to `sum` (to see whether an answer
/// was written).
svc_test_add_t add_request(int a, int b, int sum = 0) {
  svc_test_add_t d{};
  d.req.a = a;
  d.req.b = b;
  d.resp.sum = sum;
  return d;
}

TEST(CallState, TimeoutThenReconnect) {
  AddProvider p;  // nobody handles the group yet
  auto caller = p.caller();
  const auto start = Clock::now();
  EXPECT_EQ(call_add(*caller, 1, 2, nullptr, 0.2), -LNE_SVC_TIMEOUT);
  const double took = seconds_since(start);
  EXPECT_GE(took, 0.19);
  EXPECT_LT(took, 5);
  EXPECT_NE(caller->last_error().find("no response"), std::string::npos);

  GroupServer server(p.h.dispatcher, nullptr);
  int sum = 0;
  EXPECT_EQ(call_add(*caller, 1, 2, &sum, 10), 0) << caller->last_error();
  EXPECT_EQ(sum, 3);
  EXPECT_EQ(p.h.connects.get(), 2);  // the timed-out connection was given up
}

TEST(CallState, AbortFromAnotherThread) {
  AddProvider p;
  Flag connected;
  auto caller = std::make_unique<ServiceCaller>(
      signature(svc_test_add_signature),
      [&, inner = p.h.connector(1)](ProviderLink& link) {
        Status s = inner(link);
        connected.set();
        return s;
      },
      p.h.reactor);
  EXPECT_EQ(caller->abort(), -LNE_SVC_REQ_NOT_RUNNING);
  auto call = std::async(std::launch::async, [&] { return call_add(*caller, 1, 2, nullptr, 0); });  // no time limit
  ASSERT_TRUE(connected.wait_for_at_least(1));
  EXPECT_EQ(caller->abort(), 0);
  ASSERT_EQ(call.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_EQ(call.get(), -LNE_SVC_REQ_ABORTED);
}

TEST(CallState, AsyncCallWithNotificationFd) {
  AddProvider p;
  GroupServer server(p.h.dispatcher, nullptr);
  auto caller = p.caller();
  for (int round = 0; round < 3; ++round) {
    svc_test_add_t d = add_request(40, round);
    AsyncCall* call = nullptr;
    ASSERT_EQ(caller->call_async(&d, call), 0) << caller->last_error();
    EXPECT_EQ(caller_request(to_handle(call)), call);
    EXPECT_EQ(provider_request(to_handle(call)), nullptr);  // not a provider's request
    pollfd fd{call->notification_fd(), POLLIN, 0};
    ASSERT_EQ(::poll(&fd, 1, 10000), 1);
    int retval = -1;
    EXPECT_EQ(call->finished(&retval), 1);
    EXPECT_EQ(retval, 0);
    EXPECT_EQ(d.resp.sum, 40 + round);
    EXPECT_EQ(call->error_message(), nullptr);
  }
}

TEST(CallState, OneCallAtATimePerHandle) {
  AddProvider p;  // not handled: calls stay pending
  auto caller = p.caller();
  svc_test_add_t d = add_request(1, 0, -12345);
  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  int retval = 0;
  EXPECT_EQ(call->finished(&retval), 0);
  AsyncCall* second = nullptr;
  EXPECT_EQ(caller->call_async(&d, second), -LNE_SVC_REQ_RUNNING);
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_REQ_RUNNING);
  EXPECT_EQ(call->wait(0.05, &retval), 0);

  EXPECT_EQ(call->abort(), 0);
  EXPECT_EQ(call->finished(&retval), 1);
  EXPECT_EQ(retval, -LNE_SVC_REQ_ABORTED);
  EXPECT_EQ(d.resp.sum, -12345);  // never written

  // Answered only now, the aborted request's response goes nowhere; the
  // next call works.
  GroupServer server(p.h.dispatcher, nullptr);
  ASSERT_EQ(caller->call_async(&d, call), 0);
  EXPECT_EQ(call->wait(10, &retval), 1);
  EXPECT_EQ(retval, 0);
  EXPECT_EQ(d.resp.sum, 1);
}

TEST(CallState, AsyncCallFailsWhenTheProviderGoes) {
  AddProvider p;  // not handled: the call stays pending
  auto caller = p.caller();
  svc_test_add_t d{};
  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  ASSERT_OK(p.h.dispatcher.remove_provider(1));  // closes its connections
  int retval = 0;
  ASSERT_EQ(call->wait(10, &retval), 1);
  EXPECT_EQ(retval, -LNE_SVC_RECV_RESP);
  ASSERT_NE(call->error_message(), nullptr);
  EXPECT_NE(std::string(call->error_message()).find("closed the connection"), std::string::npos);
}

TEST(CallState, BlockingCallsOnOneHandleAreSerialised) {
  AddProvider p;
  GroupServer server(p.h.dispatcher, nullptr);
  auto caller = p.caller();
  std::atomic<int> good{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 50; ++i) {
        int sum = 0;
        if (call_add(*caller, t * 1000, i, &sum, 10) == 0 && sum == t * 1000 + i) ++good;
      }
    });
  for (auto& t : threads) t.join();
  EXPECT_EQ(good.load(), 150);
  EXPECT_EQ(p.h.connects.get(), 1);
}

TEST(CallState, AbortAfterArrivalButBeforeLookingDropsTheResponse) {
  AddProvider p;
  GroupServer server(p.h.dispatcher, nullptr);
  auto caller = p.caller();
  svc_test_add_t d = add_request(5, 0, -1);
  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  pollfd fd{call->notification_fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&fd, 1, 10000), 1);  // arrived
  EXPECT_EQ(call->abort(), 0);
  int retval = 0;
  EXPECT_EQ(call->finished(&retval), 1);
  EXPECT_EQ(retval, -LNE_SVC_REQ_ABORTED);
  EXPECT_EQ(d.resp.sum, -1);
}

TEST(CallState, FutureStyleWaitCarriesTheProvidersText) {
  Harness h;
  HandlerBox refuse{[](Request& r) { return r.respond_error(3, "no such floor").code(); }};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "refuse", signature(svc_test_add_signature), &HandlerBox::call, &refuse, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_add_signature));
  svc_test_add_t d{};
  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  int retval = 0;
  ASSERT_EQ(call->wait(-1, &retval), 1);
  EXPECT_EQ(retval, 3);
  ASSERT_NE(call->error_message(), nullptr);
  EXPECT_STREQ(call->error_message(), "no such floor");
}

TEST(CallState, ProviderRestartIsTransparentToTheNextCall) {
  AddProvider p;
  GroupServer server(p.h.dispatcher, nullptr);
  auto caller = p.caller();
  EXPECT_EQ(call_add(*caller, 1, 1), 0);
  ASSERT_OK(p.h.dispatcher.remove_provider(1));
  ASSERT_OK(
      p.h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &p.add, nullptr));
  int sum = 0;
  EXPECT_EQ(call_add(*caller, 2, 2, &sum, 10), 0) << caller->last_error();
  EXPECT_EQ(sum, 4);
  EXPECT_EQ(p.h.connects.get(), 2);
}

// A provider in another process is killed while handling the call: the
// caller learns it at once, long before its timeout.
TEST(CallState, ProviderKilledMidCall) {
  int link[2];
  int in_handler[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, link), 0);
  ASSERT_EQ(::pipe(in_handler), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(link[0]);
    ::close(in_handler[0]);
    static int tell_fd = in_handler[1];
    Dispatcher provider(nullptr);
    provider.add_provider(
        1, "dies", signature(svc_test_add_signature),
        [](void*, void*, void*) {
          const char byte = 1;
          [[maybe_unused]] ssize_t n = ::write(tell_fd, &byte, 1);
          for (;;) ::pause();
          return 0;
        },
        nullptr, nullptr);
    provider.adopt_connection(link[1], 1);
    for (;;) provider.wait_and_handle(nullptr, -1);
  }
  ::close(link[1]);
  ::close(in_handler[1]);
  bool handed_out = false;
  ServiceCaller caller(
      signature(svc_test_add_signature),
      [&](ProviderLink& l) {
        if (handed_out) return Status::failure(LNE_NO_PROVIDER_FOUND, "gone");
        handed_out = true;
        l.fd = link[0];
        l.service_id = 1;
        return Status();
      },
      nullptr);
  std::thread killer([&] {
    pollfd p{in_handler[0], POLLIN, 0};
    if (::poll(&p, 1, 10000) == 1) ::kill(child, SIGKILL);
  });
  const auto start = Clock::now();
  EXPECT_EQ(call_add(caller, 1, 2, nullptr, 30), -LNE_SVC_RECV_RESP);
  EXPECT_LT(seconds_since(start), 10);
  EXPECT_NE(caller.last_error().find("closed the connection"), std::string::npos) << caller.last_error();
  killer.join();
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ::close(in_handler[0]);
  EXPECT_EQ(call_add(caller, 1, 2), -LNE_NO_PROVIDER_FOUND);
}

TEST(CallState, SixteenMegabytesEachWay) {
  Harness h;
  HandlerBox echo{echo_bytes};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "echo", signature(svc_test_echo_signature), &HandlerBox::call, &echo, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_echo_signature));
  std::vector<uint8_t> blob(16u << 20);
  for (std::size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i ^ (i >> 9));
  for (int round = 0; round < 2; ++round) {
    svc_test_echo_t d{};
    d.req.data_len = static_cast<uint32_t>(blob.size());
    d.req.data = blob.data();
    const auto start = Clock::now();
    ASSERT_EQ(caller->call(&d, 30), 0) << caller->last_error();
    EXPECT_LT(seconds_since(start), 10);
    ASSERT_EQ(d.resp.data_len, blob.size());
    EXPECT_EQ(std::memcmp(d.resp.data, blob.data(), blob.size()), 0);
  }
  // And asynchronously (the reactor sends the request piece by piece).
  svc_test_echo_t d{};
  d.req.data_len = static_cast<uint32_t>(blob.size());
  d.req.data = blob.data();
  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  int retval = -1;
  ASSERT_EQ(call->wait(30, &retval), 1);
  ASSERT_EQ(retval, 0) << (call->error_message() ? call->error_message() : "");
  ASSERT_EQ(d.resp.data_len, blob.size());
  EXPECT_EQ(std::memcmp(d.resp.data, blob.data(), blob.size()), 0);
}

TEST(CallState, FlatCalls) {
  AddProvider p;
  GroupServer server(p.h.dispatcher, nullptr);
  auto caller = p.caller();
  const std::string request("\x02\x00\x00\x00\x03\x00\x00\x00", 8);
  ASSERT_EQ(caller->call_flat(request, 10), 0) << caller->last_error();
  EXPECT_EQ(caller->last_response(), std::string("\x05\x00\x00\x00", 4));
  EXPECT_EQ(caller->call_flat("abc", 10), -LNE_INVALID_PARAMETER);  // not a flat add request

  AsyncCall* call = nullptr;
  ASSERT_EQ(caller->call_flat_async(request, call), 0);
  int retval = -1;
  ASSERT_EQ(call->wait(10, &retval), 1);
  EXPECT_EQ(retval, 0);
  EXPECT_EQ(call->response(), std::string("\x05\x00\x00\x00", 4));
  svc_test_add_t d{};
  EXPECT_EQ(call->response_into(&d), 0);
  EXPECT_EQ(d.resp.sum, 5);
}

TEST(CallState, SizeLimitsOnBothSides) {
  Harness h;
  std::vector<uint8_t> big(5000, 7);
  HandlerBox bigger{[&](Request& r) {
    svc_test_echo_t d;
    EXPECT_OK(r.set_data(&d, svc_test_echo_signature));
    d.resp.data_len = static_cast<uint32_t>(big.size());
    d.resp.data = big.data();
    return r.respond().code();
  }};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "bigger", signature(svc_test_echo_signature), &HandlerBox::call, &bigger, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  Limits small;
  small.max_data_size = 1000;
  auto caller = h.caller(1, signature(svc_test_echo_signature), small);
  svc_test_echo_t d{};
  d.req.data_len = 2000;
  d.req.data = big.data();
  EXPECT_EQ(caller->call(&d, 10), -LNE_PACKET_TOO_LARGE);
  d.req.data_len = 10;
  EXPECT_EQ(caller->call(&d, 10), -LNE_SVC_RECV_RESP);  // the response exceeds our limit
  EXPECT_NE(caller->last_error().find("limit"), std::string::npos) << caller->last_error();
}

TEST(CallState, ConnectorFailureIsReported) {
  ServiceCaller caller(
      signature(svc_test_add_signature),
      [](ProviderLink&) { return Status::failure(LNE_NO_PROVIDER_FOUND, "no provider registered for service 'x'"); },
      nullptr);
  EXPECT_EQ(call_add(caller, 1, 2), -LNE_NO_PROVIDER_FOUND);
  EXPECT_EQ(caller.last_error(), "no provider registered for service 'x'");
  AsyncCall* call = nullptr;
  svc_test_add_t d{};
  EXPECT_EQ(caller.call_async(&d, call), -LNE_NOT_YET_IMPLEMENTED);  // no reactor given
}

}  // namespace
}  // namespace ln::services
