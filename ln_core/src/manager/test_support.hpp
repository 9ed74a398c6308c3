// Test support for the manager tests: a raw protocol client over TCP with
// deadlines, an in-process manager on an ephemeral port that records its log,
// and a throw-away directory of message definitions.
#pragma once

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <deque>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "manager/manager.hpp"
#include "protocol/wire.hpp"
#include "testing/in_process_manager.hpp"
#include "testing/temp_dir.hpp"

namespace ln::manager::testing {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using protocol::Message;

constexpr auto default_timeout = 5s;

using ln::test::TempDir;

/// A client that speaks the wire protocol by hand, every wait bounded.
class TestClient {
 public:
  explicit TestClient(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw std::runtime_error("socket failed");
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
      throw std::runtime_error("connect failed");
    const int on = 1;  // small requests go out at once, as a real client's do
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  }
  ~TestClient() { close(); }
  TestClient(const TestClient&) = delete;
  TestClient& operator=(const TestClient&) = delete;

  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int fd() const { return fd_; }

  /// Bytes exactly as given; false when the manager already closed.
  bool send_raw(const std::string& bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  }

  /// A request for `method` with the next id; `fill` sets its fields.
  Message make_request(const std::string& method, const std::function<void(Message&)>& fill = {}) {
    Message m = Message::request(next_id_++, method);
    if (fill) fill(m);
    return m;
  }

  /// Sends `request` and waits for its response (notifications that
  /// arrive meanwhile are kept for next_notification()).
  Message call(const Message& request, Clock::duration timeout = default_timeout) {
    if (!send_raw(protocol::encode(request))) throw std::runtime_error("send failed: connection closed");
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      auto message = read_message(deadline);
      if (!message) throw std::runtime_error("no response to '" + request.method() + "' (closed or timed out)");
      if (message->kind() == protocol::Kind::Response && message->id() == request.id()) return *message;
      notifications_.push_back(std::move(*message));
    }
  }
  Message call(const std::string& method, const std::function<void(Message&)>& fill = {}) {
    return call(make_request(method, fill));
  }

  /// The client's hello; returns the response.
  Message hello(const std::string& name, const std::function<void(Message&)>& fill = {}) {
    return call("hello", [&](Message& m) {
      m.set("program_name", name).set("exact", false).set("pid", 1234).set("host_name", "testhost");
      m.set("host_id", "host-a").set("uid", 1000).set("library_version", 32);
      m.set("peer_socket", "@ln-test-" + name).set("peer_address", "127.0.0.1:1");
      if (fill) fill(m);
    });
  }

  /// The next notification, within `timeout`.
  std::optional<Message> next_notification(Clock::duration timeout = default_timeout) {
    if (!notifications_.empty()) {
      Message m = std::move(notifications_.front());
      notifications_.pop_front();
      return m;
    }
    return read_message(Clock::now() + timeout);
  }

  /// The next notification of `method`, skipping others.
  Message wait_notification(const std::string& method, Clock::duration timeout = default_timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      auto m = next_notification(std::max(Clock::duration::zero(), deadline - Clock::now()));
      if (!m) throw std::runtime_error("no '" + method + "' notification arrived");
      if (m->method() == method) return *m;
    }
  }

  /// True if nothing arrives within `quiet` (reads pending ones first).
  bool no_notification_within(Clock::duration quiet) {
    return notifications_.empty() && !read_message(Clock::now() + quiet);
  }

  /// True when the manager closes the connection within `timeout`
  /// (whatever arrives before is discarded).
  bool wait_closed(Clock::duration timeout = default_timeout) {
    const auto deadline = Clock::now() + timeout;
    char buffer[65536];
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) <= 0) continue;
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n == 0 || (n < 0 && errno != EINTR && errno != EAGAIN)) return true;
    }
  }

 private:
  std::optional<Message> read_message(Clock::time_point deadline) {
    for (;;) {
      if (auto m = reader_.next()) return m;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return std::nullopt;
      pollfd p{fd_, POLLIN, 0};
      const int ready = ::poll(&p, 1, static_cast<int>(left));
      if (ready <= 0) continue;
      char buffer[65536];
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n <= 0) return std::nullopt;
      reader_.append(buffer, static_cast<std::size_t>(n));
    }
  }

  int fd_ = -1;
  std::uint32_t next_id_ = 1;
  protocol::FrameReader reader_;
  std::deque<Message> notifications_;
};

/// Whether process `pid` runs (zombies do not count: the init of a
/// container may never reap the orphans a test leaves).
inline bool process_running(long pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  if (pid <= 0 || !std::getline(in, stat)) return false;
  const auto close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] != 'Z';
}

/// Waits (bounded) until process `pid` no longer runs.
inline bool wait_process_gone(long pid, Clock::duration timeout = default_timeout) {
  const auto deadline = Clock::now() + timeout;
  while (process_running(pid) && Clock::now() < deadline) std::this_thread::sleep_for(5ms);
  return !process_running(pid);
}

/// The message definitions the tests use, under "mt/".
inline void write_test_definitions(const TempDir& dir) {
  dir.write("md/mt/point", "double x\ndouble y\ndouble z\n");
  dir.write("md/mt/other", "int32_t a\n");
  dir.write("md/mt/with_import", "define point_t as \"point\"\npoint_t p\nuint8_t flag\n");
  dir.write("md/mt/dyn", "uint32_t n\ndouble* values\n");
  dir.write("md/mt/str", "char* text\n");
  dir.write("md/mt/nested_dyn", "define str_t as \"mt/str\"\nstr_t label\n");
  dir.write("md/mt/add", "service\nrequest\nint32_t a\nint32_t b\nresponse\nint32_t sum\n");
  dir.write("md/mt/echo", "service\nrequest\nchar* text\nresponse\nchar* text\n");
}

/// The in-process manager (testing/in_process_manager.hpp) on the
/// definitions of `dir`/md, generating into `dir`/gen.
class RunningManager : public ln::test::InProcessManager {
 public:
  explicit RunningManager(const TempDir& dir, const std::function<void(ManagerOptions&)>& adjust = {})
      : InProcessManager({dir.path() + "/md"}, [&dir, adjust](ManagerOptions& options) {
          options.generated_definition_dir = dir.path() + "/gen";
          if (adjust) adjust(options);
        }) {}
};

/// A test with its own manager on the test definitions (write_test_definitions) in `dir`.
class ManagerWithClientsTest : public ::testing::Test {
 protected:
  /// A new connection to the manager that said hello as `name`.
  std::unique_ptr<TestClient> client(const std::string& name) {
    auto c = std::make_unique<TestClient>(manager.port());
    const Message response = c->hello(name);
    EXPECT_FALSE(response.is_error()) << response.error_text();
    return c;
  }

  TempDir dir;
  const bool definitions_written = (write_test_definitions(dir), true);  // before the manager starts
  RunningManager manager{dir};
};

}  // namespace ln::manager::testing
