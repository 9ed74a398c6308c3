// Provider-side semantics with real threads and sockets: groups, pools,
// the handler return protocol, aborts and misbehaving connections.
#include "services/dispatch.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <sched.h>

#include <algorithm>
#include <cstring>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "services/socket_io.hpp"
#include "services/test_harness.hpp"
#include "services_test_messages.h"

namespace ln::services {
namespace {

using namespace testing;  // test_harness.hpp

// Counts handlers running at once.
struct Concurrency {
  Flag inside;
  std::atomic<int> highest{0};

  void note() {
    const int now = inside.get();
    int seen = highest.load();
    while (now > seen && !highest.compare_exchange_weak(seen, now)) {
    }
  }
  Flag arrived;  // only grows: a barrier nobody can miss

  // Stays up to `window` seconds, giving a second handler the chance to
  // come in (which a serial group must not allow).
  void linger(double window) {
    inside.add(1);
    note();
    inside.wait_for_at_least(2, window);
    note();
    inside.add(-1);
  }

  // Enters, then waits up to `window` seconds until `target` handlers have
  // entered; true if they did while this one was still inside.
  bool enter_and_wait(int target, double window) {
    inside.add(1);
    arrived.add(1);
    note();
    const bool reached = arrived.wait_for_at_least(target, window);
    note();
    inside.add(-1);
    return reached;
  }
};

// Calls `n` times from `threads` threads at once, each with its own handle.
void call_from_threads(Harness& h, std::uint32_t id, int threads, int n_each, std::vector<int>& results) {
  const auto sig = signature(svc_test_add_signature);
  std::vector<std::unique_ptr<ServiceCaller>> callers;
  for (int t = 0; t < threads; ++t) callers.push_back(h.caller(id, sig));
  std::vector<std::thread> workers;
  std::mutex mutex;
  for (int t = 0; t < threads; ++t)
    workers.emplace_back([&, t] {
      for (int i = 0; i < n_each; ++i) {
        int sum = 0;
        int rc = call_add(*callers[static_cast<std::size_t>(t)], t, i, &sum);
        if (rc == 0 && sum != t + i) rc = -9999;
        std::lock_guard<std::mutex> lock(mutex);
        results.push_back(rc);
      }
    });
  for (auto& w : workers) w.join();
}

TEST(Dispatch, CallsAreHandledByWaitAndHandle) {
  AddProvider p;
  Harness& h = p.h;
  GroupServer server(h.dispatcher, nullptr);
  auto caller = p.caller();
  for (int i = 0; i < 100; ++i) {
    int sum = 0;
    ASSERT_EQ(call_add(*caller, i, 1000, &sum), 0) << caller->last_error();
    EXPECT_EQ(sum, i + 1000);
  }
  EXPECT_EQ(h.connects.get(), 1);  // one connection, reused
}

TEST(Dispatch, GroupHandlersRunOneAtATimeEvenWithSeveralWaiters) {
  Harness h;
  Concurrency meter;
  HandlerBox slow{[&](Request& r) {
    meter.linger(0.05);
    return add_numbers(r);
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "slow", signature(svc_test_add_signature), &HandlerBox::call, &slow, "g"));
  GroupServer a(h.dispatcher, "g");
  GroupServer b(h.dispatcher, "g");
  std::vector<int> results;
  call_from_threads(h, 1, 3, 4, results);
  EXPECT_EQ(std::count(results.begin(), results.end(), 0), 12);
  EXPECT_EQ(meter.highest.load(), 1);
}

TEST(Dispatch, PoolRunsUpToMaxThreadsConcurrently) {
  Harness h;
  Concurrency meter;
  std::atomic<int> reached{0};
  HandlerBox parallel{[&](Request& r) {
    if (meter.enter_and_wait(3, 10)) ++reached;
    return add_numbers(r);
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "p", signature(svc_test_add_signature), &HandlerBox::call, &parallel, "g"));
  ASSERT_OK(h.dispatcher.set_max_threads("pool", 3));
  ASSERT_OK(h.dispatcher.handle_in_pool("g", "pool"));
  std::vector<int> results;
  call_from_threads(h, 1, 3, 1, results);
  EXPECT_EQ(std::count(results.begin(), results.end(), 0), 3);
  EXPECT_EQ(reached.load(), 3);
  EXPECT_EQ(meter.highest.load(), 3);

  // Shrunk to 1 (and 0, LN's "strictly one at a time"): serial again.
  for (unsigned n : {1u, 0u}) {
    ASSERT_OK(h.dispatcher.set_max_threads("pool", n));
    Concurrency serial;
    HandlerBox one{[&](Request& r) {
      serial.linger(0.05);
      return add_numbers(r);
    }};
    ASSERT_OK(h.dispatcher.add_provider(2 + n, "one", signature(svc_test_add_signature), &HandlerBox::call, &one, "g"));
    results.clear();
    call_from_threads(h, 2 + n, 3, 2, results);
    EXPECT_EQ(std::count(results.begin(), results.end(), 0), 6);
    EXPECT_EQ(serial.highest.load(), 1);
    ASSERT_OK(h.dispatcher.remove_provider(2 + n));
  }
}

TEST(Dispatch, ResponseLaterFromAnotherThread) {
  Harness h;
  std::mutex mutex;
  Request* pending = nullptr;
  svc_test_add_t pending_data{};
  Flag deferred;
  HandlerBox later{[&](Request& r) {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_OK(r.set_data(&pending_data, svc_test_add_signature));
    pending = &r;
    deferred.set();
    return -LNE_SVC_RESP_LATER;
  }};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "later", signature(svc_test_add_signature), &HandlerBox::call, &later, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  std::thread responder([&] {
    ASSERT_TRUE(deferred.wait_for_at_least(1));
    std::lock_guard<std::mutex> lock(mutex);
    pending_data.resp.sum = pending_data.req.a * pending_data.req.b;
    EXPECT_OK(pending->respond());
  });
  auto caller = h.caller(1, signature(svc_test_add_signature));
  int product = 0;
  EXPECT_EQ(call_add(*caller, 6, 7, &product), 0) << caller->last_error();
  EXPECT_EQ(product, 42);
  responder.join();
}

TEST(Dispatch, HandlerReturnProtocol) {
  Harness h;
  std::atomic<int> mode{0};
  Status second_answer;
  Flag answered_twice;
  HandlerBox handler{[&](Request& r) -> int {
    svc_test_add_t d;
    switch (mode.load()) {
      case 0:
        return 0;  // no response
      case 1:
        return 42;  // the application's error code
      case 2:
        EXPECT_OK(r.set_data(&d, svc_test_add_signature));
        d.resp.sum = 1;
        EXPECT_OK(r.respond());
        d.resp.sum = 2;
        second_answer = r.respond();
        answered_twice.set();
        return 0;
      case 3:
        throw std::runtime_error("boom");
      case 4:
        EXPECT_OK(r.respond_error(7, "no such floor"));
        return 0;
      case 5:
        return r.set_data(&d, "int32_t 4 1|int32_t 4 1").code();
      case 6:
        EXPECT_EQ(r.respond_error(0, "").code(), -LNE_INVALID_PARAMETER);
        return -LNE_SVC_REQ_ABORTED;
      default:
        return 0;
    }
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "h", signature(svc_test_add_signature), &HandlerBox::call, &handler, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_add_signature));
  int sum = 0;

  mode = 0;
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_HANDLER_NO_RESP);
  EXPECT_NE(caller->last_error().find("without responding"), std::string::npos) << caller->last_error();
  mode = 1;
  EXPECT_EQ(call_add(*caller, 1, 2), 42);
  mode = 2;
  EXPECT_EQ(call_add(*caller, 1, 2, &sum), 0);
  EXPECT_EQ(sum, 1);
  ASSERT_TRUE(answered_twice.wait_for_at_least(1));
  EXPECT_EQ(second_answer.code(), -LNE_SVC_HANDLER_MULTI_RESP);
  mode = 3;
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_HANDLER_EXC);
  EXPECT_NE(caller->last_error().find("boom"), std::string::npos) << caller->last_error();
  mode = 4;
  EXPECT_EQ(call_add(*caller, 1, 2), 7);
  EXPECT_EQ(caller->last_error(), "no such floor");
  mode = 5;
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_REQ_SET_DATA_WRONG);
  mode = 6;
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_REQ_ABORTED);
  mode = 7;  // still serving after all that
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_HANDLER_NO_RESP);
}

TEST(Dispatch, EmptyRequestAndResponseSides) {
  Harness h;
  HandlerBox now{[](Request& r) {
    svc_test_now_t d;
    EXPECT_OK(r.set_data(&d, svc_test_now_signature));
    d.resp.time = 12.5;
    return r.respond().code();
  }};
  std::atomic<int> fired{0};
  HandlerBox fire{[&](Request& r) {
    svc_test_fire_t d;
    EXPECT_OK(r.set_data(&d, svc_test_fire_signature));
    fired = d.req.x;
    return r.respond().code();
  }};
  HandlerBox ping{[](Request& r) { return r.respond().code(); }};  // no set_data needed
  ASSERT_OK(h.dispatcher.add_provider(1, "now", signature(svc_test_now_signature), &HandlerBox::call, &now, nullptr));
  ASSERT_OK(
      h.dispatcher.add_provider(2, "fire", signature(svc_test_fire_signature), &HandlerBox::call, &fire, nullptr));
  ASSERT_OK(
      h.dispatcher.add_provider(3, "ping", signature(svc_test_ping_signature), &HandlerBox::call, &ping, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  svc_test_now_t n{};
  EXPECT_EQ(h.caller(1, signature(svc_test_now_signature))->call(&n, 10), 0);
  EXPECT_EQ(n.resp.time, 12.5);
  svc_test_fire_t f{};
  f.req.x = 77;
  EXPECT_EQ(h.caller(2, signature(svc_test_fire_signature))->call(&f, 10), 0);
  EXPECT_EQ(fired.load(), 77);
  EXPECT_EQ(h.caller(3, signature(svc_test_ping_signature))->call(nullptr, 10), 0);
}

TEST(Dispatch, AbortedCallerIsVisibleToTheHandler) {
  Harness h;
  Flag finished;
  std::atomic<bool> saw_abort{false};
  Status late_answer = Status::failure(LNE_UNKNOWN, "not answered");
  HandlerBox patient{[&](Request& r) {
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!r.is_aborted() && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a long-running handler polling
    saw_abort = r.is_aborted();
    late_answer = r.respond_error(1, "too late");  // dropped, still fine
    finished.set();
    return 0;
  }};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "patient", signature(svc_test_add_signature), &HandlerBox::call, &patient, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_add_signature));
  EXPECT_EQ(call_add(*caller, 1, 2, nullptr, 0.2), -LNE_SVC_TIMEOUT);
  ASSERT_TRUE(finished.wait_for_at_least(1));
  EXPECT_TRUE(saw_abort.load());
  EXPECT_TRUE(late_answer.ok()) << late_answer.detail();
}

// Sends raw bytes on a connection adopted for service `id`; returns our end.
int raw_connection(Harness& h, std::uint32_t id) {
  int fds[2];
  EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds), 0);
  EXPECT_OK(h.dispatcher.adopt_connection(fds[1], id));
  return fds[0];
}

bool closed_by_peer(int fd, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char sink[256];
  while (std::chrono::steady_clock::now() < until) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    const ssize_t n = ::recv(fd, sink, sizeof sink, 0);
    if (n <= 0) return true;
  }
  return false;
}

TEST(Dispatch, GarbageOnOneConnectionDoesNotDisturbOthers) {
  AddProvider p;
  Harness& h = p.h;
  GroupServer server(h.dispatcher, nullptr);
  auto caller = p.caller();
  ASSERT_EQ(call_add(*caller, 1, 1), 0);

  const int garbage = raw_connection(h, 1);
  const char junk[] = "\x05\x00\x00\x00hello";
  ASSERT_EQ(::send(garbage, junk, 9, 0), 9);
  EXPECT_TRUE(closed_by_peer(garbage, 10));
  ::close(garbage);

  const int huge = raw_connection(h, 1);
  const char announce[] = "\xff\xff\xff\x7f\x10\x01";
  ASSERT_EQ(::send(huge, announce, 6, 0), 6);
  EXPECT_TRUE(closed_by_peer(huge, 10));
  ::close(huge);

  int sum = 0;
  EXPECT_EQ(call_add(*caller, 20, 22, &sum), 0);
  EXPECT_EQ(sum, 42);
}

// True once the provider closed its end (without reading what it sent).
bool peer_hung_up(int fd, double seconds) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < until) {
    pollfd p{fd, POLLRDHUP, 0};
    if (::poll(&p, 1, 100) > 0 && (p.revents & (POLLRDHUP | POLLHUP)) != 0) return true;
  }
  return false;
}

TEST(Dispatch, ACallerThatDoesNotReadLosesOnlyItsOwnConnection) {
  Limits limits;
  limits.response_timeout_ms = 300;
  AddProvider p(limits);
  Harness& h = p.h;
  GroupServer server(h.dispatcher, nullptr);
  auto caller = p.caller();
  ASSERT_EQ(call_add(*caller, 1, 1), 0);

  // Requests as long as the socket takes them; the answers are never read.
  const int stalled = raw_connection(h, 1);
  std::string request(frames::request_overhead + 8, '\0');
  frames::write_request_head(request.data(), {1, 7}, 8);
  std::string requests;
  for (int i = 0; i < 4096; ++i) requests += request;
  std::size_t sent = 0;
  for (int round = 0; round < 200; ++round) {
    const ssize_t n = ::send(stalled, requests.data(), requests.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<std::size_t>(n);
  }
  EXPECT_GT(sent, 100000u);
  // Everyone else is served meanwhile (before, the provider blocked on the
  // stalled caller's full socket and the others timed out one after another).
  for (int i = 0; i < 20; ++i) {
    int sum = 0;
    ASSERT_EQ(call_add(*caller, i, 1, &sum, 5), 0) << caller->last_error();
    EXPECT_EQ(sum, i + 1);
  }
  EXPECT_TRUE(peer_hung_up(stalled, 10)) << "the caller that does not read loses its connection";
  ::close(stalled);
  EXPECT_EQ(call_add(*caller, 2, 3), 0);
}

TEST(Dispatch, AFloodingCallerDelaysOthersByAFewRequestsOnly) {
  Harness h;
  std::atomic<int> flood_handled{0};
  std::atomic<int> flood_handled_when_normal_came{-1};
  HandlerBox add{[&](Request& r) {
    svc_test_add_t d;
    Status s = r.set_data(&d, svc_test_add_signature);
    if (!s.ok()) return s.code();
    if (d.req.a == -1)
      flood_handled_when_normal_came = flood_handled.load();
    else
      ++flood_handled;
    d.resp.sum = d.req.a + d.req.b;
    return r.respond().code();
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &add, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_add_signature));
  ASSERT_EQ(call_add(*caller, 1, 1), 0);

  // A caller that sends requests as fast as the provider takes them (and
  // reads the answers, so only the volume is wrong).
  const int flooder = raw_connection(h, 1);
  std::atomic<bool> stop{false};
  std::thread sender([&] {
    std::string request(frames::request_overhead + 8, '\0');
    frames::write_request_head(request.data(), {1, 7}, 8);
    std::string batch;
    for (int i = 0; i < 512; ++i) batch += request;
    while (!stop && ::send(flooder, batch.data(), batch.size(), MSG_NOSIGNAL) > 0) {
    }
  });
  std::thread reader([&] {
    char sink[65536];
    while (!stop && ::recv(flooder, sink, sizeof sink, 0) > 0) {
    }
  });
  const auto flooding = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (flood_handled.load() < 10000 && std::chrono::steady_clock::now() < flooding) std::this_thread::yield();
  ASSERT_GE(flood_handled.load(), 10000);
  const int before = flood_handled.load();
  int sum = 0;
  ASSERT_EQ(call_add(*caller, -1, 43, &sum, 10), 0) << caller->last_error();
  EXPECT_EQ(sum, 42);
  // The normal request waited for a turn of the flooder's at most (plus
  // what the provider had read before it came), not for its whole backlog.
  EXPECT_LT(flood_handled_when_normal_came.load() - before, 1000);
  stop = true;
  ::shutdown(flooder, SHUT_RDWR);
  sender.join();
  reader.join();
  ::close(flooder);
}

TEST(Dispatch, MalformedRequestDataIsAnsweredNotHandled) {
  Harness h;
  std::atomic<int> handled{0};
  HandlerBox add{[&](Request& r) {
    ++handled;
    return add_numbers(r);
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &add, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  const int fd = raw_connection(h, 1);
  frames::FrameAssembler assembler(1 << 20);
  const auto round_trip = [&](const std::string& body, std::uint32_t id, frames::ResponseHead& head,
                              std::string& text) {
    std::string frame(frames::request_overhead + body.size(), '\0');
    frames::write_request_head(frame.data(), {1, id}, body.size());
    std::memcpy(frame.data() + frames::request_overhead, body.data(), body.size());
    ASSERT_EQ(::send(fd, frame.data(), frame.size(), 0), static_cast<ssize_t>(frame.size()));
    frames::Payload payload;
    Status malformed;
    ASSERT_EQ(io::receive_frame(fd, assembler, io::Deadline::after_seconds(10), payload, malformed).outcome,
              io::Outcome::Done);
    std::string_view t;
    std::size_t body_offset = 0;
    ASSERT_OK(frames::parse_response(payload, head, t, body_offset));
    text = std::string(t);
  };
  frames::ResponseHead head;
  std::string text;
  round_trip("abc", 1, head, text);  // 3 bytes for two int32_t
  EXPECT_EQ(head.request_id, 1u);
  EXPECT_EQ(head.result, -LNE_SVC_RECV_REQ);
  EXPECT_NE(text.find("malformed request"), std::string::npos) << text;
  EXPECT_EQ(handled.load(), 0);
  round_trip(std::string("\x01\x00\x00\x00\x02\x00\x00\x00", 8), 2, head, text);  // the connection still works
  EXPECT_EQ(head.request_id, 2u);
  EXPECT_EQ(head.result, 0);
  EXPECT_EQ(handled.load(), 1);
  ::close(fd);
}

TEST(Dispatch, WaitAndHandleTimeoutsAndUnblock) {
  Harness h;
  int handled = -1;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_OK(h.dispatcher.wait_and_handle(nullptr, 0, &handled));
  EXPECT_EQ(handled, 0);
  EXPECT_OK(h.dispatcher.wait_and_handle("g", 0.05, &handled));
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(waited, 0.045);
  EXPECT_LT(waited, 5);

  auto blocked = std::async(std::launch::async, [&] { return h.dispatcher.wait_and_handle("g", -1).code(); });
  EXPECT_EQ(blocked.wait_for(std::chrono::milliseconds(20)), std::future_status::timeout);
  EXPECT_OK(h.dispatcher.unblock("g"));
  ASSERT_EQ(blocked.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_EQ(blocked.get(), 0);

  // An unblock with nobody waiting is kept for the next wait.
  EXPECT_OK(h.dispatcher.unblock("g"));
  EXPECT_OK(h.dispatcher.wait_and_handle("g", -1));
}

TEST(Dispatch, GroupMovesToAPoolAndBack) {
  Harness h;
  std::atomic<std::thread::id> handler_thread{};
  HandlerBox add{[&](Request& r) {
    handler_thread = std::this_thread::get_id();
    return add_numbers(r);
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &add, "g"));
  auto caller = h.caller(1, signature(svc_test_add_signature));

  auto waiting = std::async(std::launch::async, [&] { return h.dispatcher.wait_and_handle("g", -1).code(); });
  EXPECT_EQ(waiting.wait_for(std::chrono::milliseconds(20)), std::future_status::timeout);
  ASSERT_OK(h.dispatcher.handle_in_pool("g", "pool"));
  ASSERT_EQ(waiting.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_EQ(waiting.get(), -LNE_SVC_GRP_HANDLED_IN_POOL);
  EXPECT_EQ(h.dispatcher.wait_and_handle("g", 0).code(), -LNE_SVC_GRP_HANDLED_IN_POOL);

  EXPECT_EQ(call_add(*caller, 1, 2), 0);  // served by the pool
  EXPECT_NE(handler_thread.load(), std::this_thread::get_id());

  ASSERT_OK(h.dispatcher.remove_from_pool("g"));
  auto call = std::async(std::launch::async, [&] { return call_add(*caller, 3, 4); });
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  int handled = 0;
  while (handled == 0 && std::chrono::steady_clock::now() < until)
    EXPECT_OK(h.dispatcher.wait_and_handle("g", 0.1, &handled));
  EXPECT_EQ(handled, 1);
  EXPECT_EQ(call.get(), 0);
  EXPECT_EQ(handler_thread.load(), std::this_thread::get_id());
  EXPECT_EQ(h.dispatcher.remove_from_pool("nonexistent").code(), -LNE_SVC_GRP_UNKNOWN);
}

TEST(Dispatch, PoolSchedulingParameters) {
  Harness h;
  std::atomic<int> cpu{-1};
  HandlerBox where{[&](Request& r) {
    cpu = ::sched_getcpu();
    return add_numbers(r);
  }};
  ASSERT_OK(h.dispatcher.add_provider(1, "where", signature(svc_test_add_signature), &HandlerBox::call, &where, "g"));
  ASSERT_OK(h.dispatcher.handle_in_pool("g", "rt"));
  ASSERT_OK(h.dispatcher.set_pool_schedparam("rt", -1, -1, 1u));  // CPU 0 only
  auto caller = h.caller(1, signature(svc_test_add_signature));
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(call_add(*caller, 1, 2), 0);
    EXPECT_EQ(cpu.load(), 0);
  }
  // Real-time scheduling needs privileges: either it works or the errno
  // comes back; the pool keeps serving either way.
  const Status fifo = h.dispatcher.set_pool_schedparam("rt", SCHED_FIFO, 1, 0);
  if (!fifo.ok()) {
    EXPECT_EQ(fifo.code(), -LNE_CHECK_ERRNO);
    EXPECT_EQ(fifo.sys_errno(), EPERM);
  }
  EXPECT_OK(h.dispatcher.set_pool_schedparam("rt", SCHED_OTHER, 0, 3u));
  EXPECT_EQ(call_add(*caller, 1, 2), 0);
  EXPECT_EQ(h.dispatcher.set_pool_schedparam("rt", 12345, -1, 0).code(), -LNE_CHECK_ERRNO);
}

TEST(Dispatch, RemoveProviderWaitsForRunningHandlers) {
  Harness h;
  Flag entered;
  Flag release;
  std::atomic<bool> handler_done{false};
  HandlerBox blocking{[&](Request& r) {
    entered.set();
    release.wait_for_at_least(1);
    handler_done = true;
    return add_numbers(r);
  }};
  ASSERT_OK(
      h.dispatcher.add_provider(1, "b", signature(svc_test_add_signature), &HandlerBox::call, &blocking, nullptr));
  GroupServer server(h.dispatcher, nullptr);
  auto caller = h.caller(1, signature(svc_test_add_signature));
  auto call = std::async(std::launch::async, [&] { return call_add(*caller, 1, 2); });
  ASSERT_TRUE(entered.wait_for_at_least(1));
  auto removal = std::async(std::launch::async, [&] {
    const Status s = h.dispatcher.remove_provider(1);
    return s.ok() && handler_done.load();
  });
  // Widen the window in which a removal that did not wait would return.
  EXPECT_EQ(removal.wait_for(std::chrono::milliseconds(30)), std::future_status::timeout);
  release.set();
  EXPECT_TRUE(removal.get());
  EXPECT_NE(call.get(), 0);  // its connection was closed before the response
  EXPECT_FALSE(h.dispatcher.has_provider(1));
  EXPECT_EQ(call_add(*caller, 1, 2), -LNE_SVC_NOT_REGISTERED);  // the connector is refused now
}

TEST(Dispatch, ConnectionObserverAndProviderFd) {
  AddProvider provider;
  Harness& h = provider.h;
  struct Seen {
    Flag connected, disconnected;
    std::atomic<std::thread::id> thread{};
  } seen;
  ASSERT_OK(h.dispatcher.set_connection_observer(
      1,
      [](void*, int event, int, void* self) {
        auto* s = static_cast<Seen*>(self);
        s->thread = std::this_thread::get_id();
        (event == LN_NEW_SVC_CLIENT ? s->connected : s->disconnected).add(1);
      },
      &seen));
  const int fd = h.dispatcher.provider_fd(1);
  ASSERT_GE(fd, 0);

  auto caller = h.caller(1, signature(svc_test_add_signature));
  AsyncCall* call = nullptr;
  svc_test_add_t d{};
  d.req.a = 5;
  d.req.b = 6;
  ASSERT_EQ(caller->call_async(&d, call), 0);
  pollfd p{fd, POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 10000), 1);  // the group has work
  int handled = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (handled == 0 && std::chrono::steady_clock::now() < until)
    EXPECT_OK(h.dispatcher.wait_and_handle(nullptr, 0.1, &handled));
  int retval = -1;
  ASSERT_EQ(call->wait(10, &retval), 1);
  EXPECT_EQ(retval, 0);
  EXPECT_EQ(d.resp.sum, 11);
  EXPECT_EQ(seen.connected.get(), 1);
  EXPECT_EQ(seen.thread.load(), std::this_thread::get_id());  // the group's handling thread

  caller.reset();  // the caller goes away
  const auto until2 = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (seen.disconnected.get() == 0 && std::chrono::steady_clock::now() < until2)
    EXPECT_OK(h.dispatcher.wait_and_handle(nullptr, 0.1));
  EXPECT_EQ(seen.disconnected.get(), 1);
}

TEST(Dispatch, RegistrationErrors) {
  Harness h;
  HandlerBox add{add_numbers};
  const auto sig = signature(svc_test_add_signature);
  EXPECT_EQ(h.dispatcher.add_provider(1, "x", sig, nullptr, nullptr, nullptr).code(), -LNE_SVC_NO_HANDLER);
  ASSERT_OK(h.dispatcher.add_provider(1, "x", sig, &HandlerBox::call, &add, nullptr));
  EXPECT_EQ(h.dispatcher.add_provider(1, "x", sig, &HandlerBox::call, &add, nullptr).code(),
            -LNE_SVC_ALREADY_REGISTERED);
  EXPECT_EQ(h.dispatcher.remove_provider(2).code(), -LNE_SVC_NOT_REGISTERED);
  int fds[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM, 0, fds), 0);
  EXPECT_EQ(h.dispatcher.adopt_connection(fds[1], 2).code(), -LNE_SVC_NOT_REGISTERED);
  EXPECT_TRUE(closed_by_peer(fds[0], 5));  // the refused socket was closed
  ::close(fds[0]);
  EXPECT_EQ(h.dispatcher.provider_fd(2), -LNE_SVC_NOT_REGISTERED);
  EXPECT_EQ(h.dispatcher.handle_in_pool(nullptr, nullptr).code(), -LNE_INVALID_PARAMETER);
}

}  // namespace
}  // namespace ln::services
