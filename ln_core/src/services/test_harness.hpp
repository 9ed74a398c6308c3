// Test support: callers and providers of one process wired together by
// socketpairs, standing in for the client core (lookup at the manager,
// connect, `call` handshake, adopt_connection on the peer server).
#pragma once

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>

#include "services/call_state.hpp"
#include "services/dispatch.hpp"

#include "ln/ln.h"
#include "services_test_messages.h"

namespace ln::services::testing {

#define EXPECT_OK(expr)                                \
  do {                                                 \
    const ::ln::services::Status s_ = (expr);          \
    EXPECT_TRUE(s_.ok()) << #expr ": " << s_.detail(); \
  } while (0)
#define ASSERT_OK(expr)                                \
  do {                                                 \
    const ::ln::services::Status s_ = (expr);          \
    ASSERT_TRUE(s_.ok()) << #expr ": " << s_.detail(); \
  } while (0)

inline std::shared_ptr<const ServiceSignature> signature(const char* text) {
  std::shared_ptr<const ServiceSignature> s;
  const Status status = ServiceSignature::compile_shared(text, s);
  EXPECT_TRUE(status.ok()) << status.detail();
  return s;
}

/// The svc_test/add handler: answers a + b.
inline int add_numbers(Request& r) {
  svc_test_add_t d;
  const Status s = r.set_data(&d, svc_test_add_signature);
  if (!s.ok()) return s.code();
  d.resp.sum = d.req.a + d.req.b;
  return r.respond().code();
}

/// Calls svc/test_add with `a` and `b` through `caller`; the answer's sum into *sum when given.
inline int call_add(ServiceCaller& caller, int a, int b, int* sum = nullptr, double timeout = 10) {
  svc_test_add_t d{};
  d.req.a = a;
  d.req.b = b;
  const int rc = caller.call(&d, timeout);
  if (sum) *sum = d.resp.sum;
  return rc;
}

/// A handler written as a lambda.
struct HandlerBox {
  std::function<int(Request&)> fn;
  static int call(void*, void* request, void* self) {
    Request* r = provider_request(request);
    EXPECT_NE(r, nullptr);
    return static_cast<HandlerBox*>(self)->fn(*r);
  }
};

/// A condition to wait for with a deadline (never a fixed sleep).
class Flag {
 public:
  void set(int value = 1) {
    std::lock_guard<std::mutex> lock(mutex_);
    value_ = value;
    changed_.notify_all();
  }
  void add(int delta) {
    std::lock_guard<std::mutex> lock(mutex_);
    value_ += delta;
    changed_.notify_all();
  }
  int get() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return value_;
  }
  /// Waits until the value is at least `wanted`; false after `seconds`.
  bool wait_for_at_least(int wanted, double seconds = 10) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, std::chrono::duration<double>(seconds), [&] { return value_ >= wanted; });
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  int value_ = 0;
};

struct Harness {
  explicit Harness(Limits limits = {}) : dispatcher(nullptr, limits) {}
  Dispatcher dispatcher;
  std::shared_ptr<AsyncReactor> reactor = std::make_shared<AsyncReactor>();
  Flag connects;

  Connector connector(std::uint32_t service_id) {
    return [this, service_id](ProviderLink& link) -> Status {
      int fds[2];
      if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0)
        return Status::failure(LNE_CHECK_ERRNO, "socketpair", errno);
      Status s = dispatcher.adopt_connection(fds[1], service_id);
      if (!s.ok()) {
        ::close(fds[0]);
        return s;
      }
      link.fd = fds[0];
      link.service_id = service_id;
      connects.add(1);
      return {};
    };
  }

  std::unique_ptr<ServiceCaller> caller(std::uint32_t service_id, std::shared_ptr<const ServiceSignature> sig,
                                        Limits limits = {}) {
    return std::make_unique<ServiceCaller>(std::move(sig), connector(service_id), reactor, limits);
  }
};

/// Runs wait_and_handle() for a group in a thread of its own.
class GroupServer {
 public:
  GroupServer(Dispatcher& dispatcher, const char* group) : dispatcher_(dispatcher), group_(group) {
    thread_ = std::thread([this] {
      while (!stop_) dispatcher_.wait_and_handle(group_, -1);
      done_.set();
    });
  }
  ~GroupServer() {
    stop_ = true;
    // An unblock wakes one waiter; with several servers on one group it may
    // be another server's thread, so repeat until ours has left.
    do {
      dispatcher_.unblock(group_);
    } while (!done_.wait_for_at_least(1, 0.01));
    thread_.join();
  }

 private:
  Dispatcher& dispatcher_;
  const char* group_;
  std::atomic<bool> stop_{false};
  Flag done_;
  std::thread thread_;
};

/// A harness whose dispatcher provides svc_test/add (add_numbers) as service 1, in the
/// default group (nobody handles it until a GroupServer does).
struct AddProvider {
  Harness h;
  HandlerBox add{add_numbers};
  explicit AddProvider(Limits limits = {}) : h(limits) {
    EXPECT_OK(h.dispatcher.add_provider(1, "add", signature(svc_test_add_signature), &HandlerBox::call, &add, nullptr));
  }
  std::unique_ptr<ServiceCaller> caller() { return h.caller(1, signature(svc_test_add_signature)); }
};

}  // namespace ln::services::testing
