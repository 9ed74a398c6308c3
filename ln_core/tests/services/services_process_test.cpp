// Services across processes: LN 2.9-style providers (C, and C++ on the
// generated test_base) started with posix_spawn, called through the C and
// C++ APIs against a manager in this process.
#include <arpa/inet.h>
#include <dirent.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "ln_messages.h"
#include "protocol/methods.hpp"
#include "protocol/wire.hpp"
#include "service_process_fixture.hpp"

extern char** environ;

namespace {

using namespace ln::servicetest;
namespace method = ln::protocol::method;
using ln::protocol::Message;

/// A request with the dynamic fields filled (pointers into the arguments, which outlive the call).
svc_test_t dynamic_request(std::string& text, std::vector<uint8_t>& blob, svc_item_t* items, uint32_t items_len) {
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  data.req.text_len = static_cast<uint32_t>(text.size());
  data.req.text = text.data();
  data.req.blob_len = static_cast<uint32_t>(blob.size());
  data.req.blob = blob.data();
  data.req.items_len = items_len;
  data.req.items = items;
  return data;
}

/// An item pointing into `label` and `values` (which outlive the call).
svc_item_t item(int32_t id, std::string& label, std::vector<double>& values) {
  svc_item_t result;
  result.id = id;
  result.label_len = static_cast<uint32_t>(label.size());
  result.label = label.data();
  result.values_len = static_cast<uint32_t>(values.size());
  result.values = values.empty() ? nullptr : values.data();
  return result;
}

/// The provider echoed text and blob of the request.
void expect_text_and_blob_echoed(const svc_test_t& data, const std::string& text, const std::vector<uint8_t>& blob) {
  EXPECT_EQ(std::string(data.resp.text, data.resp.text_len), text);
  ASSERT_EQ(data.resp.blob_len, blob.size());
  EXPECT_EQ(std::memcmp(data.resp.blob, blob.data(), blob.size()), 0);
}

/// Makes one CONCURRENCY call (the provider answers after `delay_ms` with how many calls it handled
/// at once) on each handle, each in its own thread, and hands each result and answer to `on_answer`.
template <class OnAnswer>
void call_concurrently(const std::vector<ln_service>& handles, unsigned delay_ms, OnAnswer on_answer) {
  std::vector<std::thread> threads;
  for (ln_service svc : handles) {
    threads.emplace_back([&, svc] {
      svc_test_t data;
      std::memset(&data, 0, sizeof data);
      data.req.mode = CONCURRENCY;
      data.req.delay_ms = delay_ms;
      const int result = ln_service_call(svc, &data);
      on_answer(result, data);
    });
  }
  for (auto& t : threads) t.join();
}

/// `slow_call` makes a 10 s call; the provider is killed while it handles it: the call fails,
/// long before the 10 s answer would have come (even on a loaded machine).
template <class SlowCall>
void expect_call_fails_when_provider_killed(ChildProcess& child, SlowCall slow_call) {
  std::atomic<int> result{1};
  const auto start = Clock::now();
  std::thread calling([&] { result = slow_call(); });
  EXPECT_NE(child.wait_for_line("slow"), "");  // the provider handles the call
  child.kill(SIGKILL);
  calling.join();
  EXPECT_LT(result.load(), 0);
  EXPECT_LT(Clock::now() - start, 9s);
}

TEST_F(ServiceProcessTest, SyncCallWithDynamicFieldsAnd16MB) {
  auto child = provider();
  ln_service svc = caller();
  std::string text = "hello, provider";
  std::vector<uint8_t> blob(16u << 20);
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 7);
  std::vector<double> values = {1.5, -2.5, 3.25}, no_values;
  std::string labels[2] = {"first", "second item"};
  svc_item_t items[2] = {item(10, labels[0], values), item(11, labels[1], no_values)};
  svc_test_t data = dynamic_request(text, blob, items, 2);
  ASSERT_EQ(ln_service_call(svc, &data), 0) << ln_get_error_message(client_);
  expect_text_and_blob_echoed(data, text, blob);
  ASSERT_EQ(data.resp.items_len, 2u);
  EXPECT_EQ(data.resp.items[1].id, 11);
  EXPECT_EQ(std::string(data.resp.items[1].label, data.resp.items[1].label_len), "second item");
  ASSERT_EQ(data.resp.items[0].values_len, 3u);
  EXPECT_EQ(data.resp.items[0].values[2], 3.25);
  EXPECT_EQ(data.resp.count, 2u);
  // Small calls on the same connection afterwards.
  for (int i = 0; i < 100; ++i) ASSERT_EQ(call(svc, ECHO), 0);
}

TEST_F(ServiceProcessTest, TimeoutThenNextCallWorks) {
  auto child = provider({"pool", "2"});
  ln_service svc = caller();
  const auto start = Clock::now();
  EXPECT_EQ(call(svc, SLOW, 10000, 0.2), -LNE_SVC_TIMEOUT);
  EXPECT_LT(Clock::now() - start, 8s);  // long before the 10 s answer, even on a loaded machine
  EXPECT_EQ(call(svc, ECHO), 0) << ln_get_error_message(client_);
}

TEST_F(ServiceProcessTest, AbortFromAnotherThread) {
  auto child = provider({"pool", "2"});
  ln_service svc = caller();
  ASSERT_EQ(call(svc, ECHO), 0);
  std::atomic<int> result{1};
  std::thread calling([&] { result = call(svc, SLOW, 5000); });
  EXPECT_NE(child->wait_for_line("slow"), "");  // the call is with the provider
  EXPECT_EQ(ln_service_call_abort(svc), 0);
  calling.join();
  EXPECT_EQ(result.load(), -LNE_SVC_REQ_ABORTED);
  EXPECT_EQ(call(svc, ECHO), 0);
}

TEST_F(ServiceProcessTest, AsyncWithFinishedFd) {
  auto child = provider();
  ln_service svc = caller();
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  std::string text = "async";
  data.req.mode = SLOW;
  data.req.delay_ms = 100;
  data.req.text_len = 5;
  data.req.text = text.data();
  ln_service_request req = nullptr;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0);
  int retval = -1;
  EXPECT_EQ(ln_service_request_finished(req, &retval), 0);
  int fd = -1;
  ASSERT_EQ(ln_service_request_get_finished_notification_fd(req, &fd), 0);
  pollfd p{fd, POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 5000), 1);
  ASSERT_EQ(ln_service_request_finished(req, &retval), 1);
  EXPECT_EQ(retval, 0);
  EXPECT_EQ(std::string(data.resp.text, data.resp.text_len), "async");
  // ln_service_request_wait, and an aborted asynchronous call.
  data.req.delay_ms = 50;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0);
  EXPECT_EQ(ln_service_request_wait(req, 5, &retval), 1);
  EXPECT_EQ(retval, 0);
  data.req.delay_ms = 2000;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0);
  EXPECT_EQ(ln_service_request_abort(req), 0);
  EXPECT_EQ(ln_service_request_finished(req, &retval), 1);
  EXPECT_EQ(retval, -LNE_SVC_REQ_ABORTED);
}

TEST_F(ServiceProcessTest, ErrorsFromTheProvider) {
  auto child = provider();
  ln_service svc = caller();
  EXPECT_EQ(call(svc, USER_ERROR, 0, 0, 42), 42);
  EXPECT_EQ(call(svc, ERROR_TEXT, 0, 0, 7), 7);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("the provider refuses"), std::string::npos)
      << ln_get_error_message(client_);
  EXPECT_EQ(call(svc, NO_RESPONSE), -LNE_SVC_HANDLER_NO_RESP);
  EXPECT_EQ(call(svc, LATER, 50), 0) << ln_get_error_message(client_);
  EXPECT_EQ(call(svc, ECHO), 0);
}

TEST_F(ServiceProcessTest, CppCallerAndGeneratedCppProvider) {
  auto child = provider({}, LN_SVC_PROVIDER_CPP, "cppsvc");
  ln::client clnt("cpp_driver", manager_.address());
  ln::service* svc = clnt.get_service("cppsvc", "svc/test", svc_test_signature);
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  std::string text = "from c++";
  data.req.text_len = static_cast<uint32_t>(text.size());
  data.req.text = text.data();
  svc->call(&data);
  EXPECT_EQ(std::string(data.resp.text, data.resp.text_len), text);
  data.req.error = 42;
  try {
    svc->call(&data);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error_code, 42) << e.what();
  }
  clnt.release_service(svc);
}

TEST_F(ServiceProcessTest, ThreadPoolServesEightCallersConcurrently) {
  auto child = provider({"pool", "8"});
  std::vector<ln_service> handles;
  for (int i = 0; i < 8; ++i) handles.push_back(caller());
  for (ln_service svc : handles) ASSERT_EQ(call(svc, ECHO), 0);  // connect first
  std::atomic<uint32_t> most{0};
  std::atomic<int> failures{0};
  call_concurrently(handles, 300, [&](int result, const svc_test_t& data) {
    if (result != 0) ++failures;
    uint32_t seen = most.load();
    while (data.resp.count > seen && !most.compare_exchange_weak(seen, data.resp.count)) {
    }
  });
  EXPECT_EQ(failures.load(), 0);
  EXPECT_GE(most.load(), 4u);  // handled at the same time (a count, not a time: machines get loaded)
}

TEST_F(ServiceProcessTest, GroupHandledByOneThreadIsSerialized) {
  auto child = provider({"group"});
  std::vector<ln_service> handles;
  for (int i = 0; i < 4; ++i) handles.push_back(caller());
  std::atomic<uint32_t> most{0};
  call_concurrently(handles, 30, [&](int result, const svc_test_t& data) {
    EXPECT_EQ(result, 0);
    if (data.resp.count > most.load()) most = data.resp.count;
  });
  EXPECT_EQ(most.load(), 1u);
}

TEST_F(ServiceProcessTest, ProviderKilledMidCall) {
  auto child = provider();
  ln_service svc = caller();
  ASSERT_EQ(call(svc, ECHO), 0);
  expect_call_fails_when_provider_killed(*child, [&] { return call(svc, SLOW, 10000); });
}

TEST_F(ServiceProcessTest, UnknownServiceAndWrongSignature) {
  ln_service unknown = caller("nobody_provides_this");
  EXPECT_EQ(call(unknown, ECHO), -LNE_NO_PROVIDER_FOUND);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("nobody_provides_this"), std::string::npos);
  auto child = provider();
  ln_service wrong = caller("svc", "int32_t 4 1|");
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  EXPECT_LT(ln_service_call(wrong, &data), 0);
  EXPECT_STRNE(ln_get_error_message(client_), "");
}

struct Seen {
  std::mutex mutex;
  std::vector<int> states;
  void add(int state) {
    std::lock_guard<std::mutex> lock(mutex);
    states.push_back(state);
  }
  std::vector<int> get() {
    std::lock_guard<std::mutex> lock(mutex);
    return states;
  }
};

void on_availability(ln_client, const char*, int available, void* user_data) {
  static_cast<Seen*>(user_data)->add(available);
}

TEST_F(ServiceProcessTest, WaitForServiceAndAvailabilityHandler) {
  Seen seen;
  ASSERT_EQ(ln_set_service_availability_handler(client_, "svc", on_availability, &seen), 0);
  EXPECT_TRUE(wait_until([&] { return seen.get() == std::vector<int>{0}; }));
  EXPECT_EQ(ln_wait_for_service(client_, "svc", 0), 0);
  std::unique_ptr<ChildProcess> child;
  const pid_t waiting_thread = ln::test::current_thread_id();
  std::thread starting([&] {
    wait_until([&] { return ln::test::thread_sleeps(waiting_thread); });  // in ln_wait_for_service below
    child = provider();
  });
  EXPECT_EQ(ln_wait_for_service(client_, "svc", 10), 1);
  starting.join();
  EXPECT_TRUE(wait_until([&] { return seen.get() == std::vector<int>{0, 1}; }));
  EXPECT_EQ(ln_needs_provider(client_, "svc", 1), 0);
  child->kill(SIGKILL);  // its disconnect releases the service
  EXPECT_TRUE(wait_until([&] { return seen.get() == std::vector<int>{0, 1, 0}; }));
  ASSERT_EQ(ln_set_service_availability_handler(client_, "svc", nullptr, nullptr), 0);
  EXPECT_EQ(ln_needs_provider(client_, "svc", 0.1), -LNE_NO_PROVIDER_FOUND);
}

TEST_F(ServiceProcessTest, ProviderReRegistersAfterManagerRestart) {
  auto child = provider();
  ln_service svc = caller();
  ASSERT_EQ(call(svc, ECHO), 0);
  manager_.restart();
  // The open connection keeps working; a new handle needs the registration.
  EXPECT_EQ(call(svc, ECHO), 0);
  EXPECT_TRUE(wait_until([&] { return ln_wait_for_service(client_, "svc", 0) == 1; }, 10000ms));
  ln_service fresh = caller();
  EXPECT_EQ(call(fresh, ECHO), 0) << ln_get_error_message(client_);
}

// ---- a raw connection to the provider, sending garbage

Message exchange(int fd, const Message& message) {
  const std::string frame = ln::protocol::encode(message);
  EXPECT_EQ(::send(fd, frame.data(), frame.size(), MSG_NOSIGNAL), static_cast<ssize_t>(frame.size()));
  ln::protocol::FrameReader reader;
  for (;;) {
    if (auto answer = reader.next()) return *answer;
    char chunk[4096];
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 5000) <= 0) throw std::runtime_error("no answer");
    const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
    if (n <= 0) throw std::runtime_error("closed");
    reader.append(chunk, static_cast<size_t>(n));
  }
}

int connect_unix(const std::string& name) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path + 1, name.data(), name.size());
  const auto size = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), size) != 0) throw std::runtime_error("connect");
  return fd;
}

/// Connects to the manager on `port` as `program_name` and looks up "svc"; the manager
/// connection stays open in *manager (the caller closes it).
Message look_up_svc(uint16_t port, const char* program_name, int* manager) {
  *manager = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(*manager, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0)
    throw std::runtime_error("cannot connect to the manager");
  exchange(*manager, Message::request(1, method::hello).set("program_name", program_name));
  return exchange(
      *manager,
      Message::request(2, method::lookup_service).set("name", "svc").set("interface", "").set("signature", ""));
}

TEST_F(ServiceProcessTest, ProviderSurvivesGarbage) {
  auto child = provider();
  int manager = -1;
  const Message found = look_up_svc(manager_.port(), "garbage", &manager);
  const std::string socket_name = found.get_string("peer_socket");
  // Junk straight into the peer server, then junk after a good handshake.
  for (int round = 0; round < 2; ++round) {
    const int fd = connect_unix(socket_name);
    if (round == 1) {
      const Message ok = exchange(fd, Message::request(1, method::call).set("service_id", found.get_int("service_id")));
      EXPECT_FALSE(ok.is_error()) << ok.error_text();
    }
    std::string junk(100000, '\0');
    for (size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<char>(i * 131 + 17);
    ::send(fd, junk.data(), junk.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    // The provider drops the connection over the junk (and lives on: the calls below).
    EXPECT_TRUE(wait_until(
        [&] {
          char reply[4096];
          const ssize_t n = ::recv(fd, reply, sizeof reply, MSG_DONTWAIT);
          return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK);
        },
        10s))
        << "round " << round;
    ::close(fd);
  }
  ::close(manager);
  ln_service svc = caller();
  for (int i = 0; i < 10; ++i) EXPECT_EQ(call(svc, ECHO), 0) << ln_get_error_message(client_);
}

TEST_F(ServiceProcessTest, RoundTripNumbers) {
  auto child = provider({"pool", "8"});
  ln_service svc = caller();
  ASSERT_EQ(call(svc, ECHO), 0);
  const int n = 2000;
  const auto start = Clock::now();
  for (int i = 0; i < n; ++i) ASSERT_EQ(call(svc, ECHO), 0);
  const double rtt_us = std::chrono::duration<double, std::micro>(Clock::now() - start).count() / n;
  std::vector<ln_service> handles;
  for (int i = 0; i < 8; ++i) handles.push_back(caller());
  for (ln_service h : handles) ASSERT_EQ(call(h, ECHO), 0);
  std::atomic<int> total{0};
  const auto t0 = Clock::now();
  std::vector<std::thread> threads;
  for (ln_service h : handles)
    threads.emplace_back([&, h] {
      svc_test_t data;
      for (int i = 0; i < n; ++i) {
        std::memset(&data, 0, sizeof data);
        if (ln_service_call(h, &data) == 0) ++total;
      }
    });
  for (auto& t : threads) t.join();
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf("{\"small_rtt_us\": %.2f, \"eight_caller_calls_per_s\": %.0f}\n", rtt_us, total.load() / seconds);
  EXPECT_EQ(total.load(), 8 * n);
}

TEST_F(ServiceProcessTest, TcpPeerServerServesCallsButRefusesSharedMemory) {
  auto child = provider();
  int manager = -1;
  const Message found = look_up_svc(manager_.port(), "tcp_probe", &manager);
  ::close(manager);
  // The provider reaches the manager over loopback, so that is where its TCP peer server listens.
  const std::string peer = found.get_string("peer_address");
  ASSERT_EQ(peer.compare(0, 10, "127.0.0.1:"), 0) << peer;
  sockaddr_in peer_address{};
  peer_address.sin_family = AF_INET;
  peer_address.sin_port = htons(static_cast<uint16_t>(std::stoi(peer.substr(10))));
  peer_address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  auto connect_peer = [&] {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&peer_address), sizeof peer_address), 0);
    return fd;
  };
  const int segment = connect_peer();
  const Message refused = exchange(
      segment, Message::request(1, method::open_segment).set("topic_id", 1).set("topic", "t").set("buffers", 1));
  EXPECT_TRUE(refused.is_error());
  EXPECT_NE(refused.error_text().find("TCP"), std::string::npos) << refused.error_text();
  ::close(segment);
  const int call_fd = connect_peer();
  const Message ok =
      exchange(call_fd, Message::request(1, method::call).set("service_id", found.get_int("service_id")));
  EXPECT_FALSE(ok.is_error()) << ok.error_text();
  ::close(call_fd);
}

// ------------------------------------------------- calls over TCP (remote)

/// ESTABLISHED TCP sockets owned by this process (its manager included).
int established_tcp_sockets_of_this_process() {
  std::set<std::string> inodes;
  if (DIR* fds = ::opendir("/proc/self/fd")) {
    while (dirent* entry = ::readdir(fds)) {
      char target[64] = {};
      const std::string path = std::string("/proc/self/fd/") + entry->d_name;
      const ssize_t n = ::readlink(path.c_str(), target, sizeof target - 1);
      if (n > 8 && std::strncmp(target, "socket:[", 8) == 0) inodes.insert(std::string(target + 8, n - 9));
    }
    ::closedir(fds);
  }
  int count = 0;
  FILE* table = std::fopen("/proc/self/net/tcp", "r");
  if (table == nullptr) return -1;
  char line[512];
  std::fgets(line, sizeof line, table);  // header
  while (std::fgets(line, sizeof line, table) != nullptr) {
    char state[8] = {}, inode[32] = {};
    if (std::sscanf(line, "%*s %*s %*s %7s %*s %*s %*s %*s %*s %31s", state, inode) == 2 &&
        std::strcmp(state, "01") == 0 && inodes.count(inode) != 0)
      ++count;
  }
  std::fclose(table);
  return count;
}

/// Caller and provider claim different hosts (LN_CORE_HOST_ID), so calls
/// must go over the provider's TCP peer server.
class RemoteServiceProcessTest : public ServiceProcessTest {
 protected:
  void SetUp() override {
    host_ = std::make_unique<ScopedEnv>("LN_CORE_HOST_ID", std::string("caller-host"));
    ServiceProcessTest::SetUp();
  }
  void TearDown() override {
    ServiceProcessTest::TearDown();
    host_.reset();
  }
  std::unique_ptr<ChildProcess> remote_provider(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args = {LN_SVC_PROVIDER, "svc"};
    args.insert(args.end(), extra.begin(), extra.end());
    auto child = std::make_unique<ChildProcess>(args, manager_.address(),
                                                std::vector<std::string>{"LN_CORE_HOST_ID=provider-host"});
    EXPECT_NE(child->wait_for_line("ready"), "");
    return child;
  }
  std::unique_ptr<ScopedEnv> host_;
};

TEST_F(RemoteServiceProcessTest, DynamicFieldsAnd1MBOverTcp) {
  auto child = remote_provider();
  ln_service svc = caller();
  const int tcp_before = established_tcp_sockets_of_this_process();
  std::string text = "over tcp";
  std::vector<uint8_t> blob(1u << 20);
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<uint8_t>(i * 13 + 1);
  std::vector<double> values = {0.5, -1.25};
  std::string label = "remote item";
  svc_item_t one = item(42, label, values);
  svc_test_t data = dynamic_request(text, blob, &one, 1);
  ASSERT_EQ(ln_service_call(svc, &data), 0) << ln_get_error_message(client_);
  expect_text_and_blob_echoed(data, text, blob);
  ASSERT_EQ(data.resp.items_len, 1u);
  EXPECT_EQ(data.resp.items[0].id, 42);
  EXPECT_EQ(std::string(data.resp.items[0].label, data.resp.items[0].label_len), label);
  ASSERT_EQ(data.resp.items[0].values_len, 2u);
  EXPECT_EQ(data.resp.items[0].values[1], -1.25);
  // The call opened a TCP connection of ours (the Unix path makes none).
  EXPECT_EQ(established_tcp_sockets_of_this_process(), tcp_before + 1);
  for (int i = 0; i < 50; ++i) ASSERT_EQ(call(svc, ECHO), 0);
}

TEST_F(RemoteServiceProcessTest, TimeoutThenNextCallWorksOverTcp) {
  auto child = remote_provider({"pool", "2"});
  ln_service svc = caller();
  const int tcp_before = established_tcp_sockets_of_this_process();
  const auto start = Clock::now();
  EXPECT_EQ(call(svc, SLOW, 10000, 0.2), -LNE_SVC_TIMEOUT);
  EXPECT_LT(Clock::now() - start, 8s);  // long before the 10 s answer, even on a loaded machine
  EXPECT_EQ(call(svc, ECHO), 0) << ln_get_error_message(client_);
  EXPECT_GE(established_tcp_sockets_of_this_process(), tcp_before + 1);
}

TEST_F(RemoteServiceProcessTest, IdleCallerReachesARestartedProviderOverTcp) {
  ln_service svc = caller();
  for (int round = 0; round < 2; ++round) {
    auto child = remote_provider();
    EXPECT_EQ(call(svc, ECHO), 0) << "round " << round << ": " << error_message();
    child->kill(SIGKILL);
    ASSERT_EQ(child->wait(), 128 + SIGKILL);
    ASSERT_TRUE(wait_until([&] { return ln_wait_for_service(client_, "svc", 0) == 0; }));
  }
}

TEST_F(RemoteServiceProcessTest, ProviderKilledMidCallOverTcp) {
  auto child = remote_provider();
  ln_service svc = caller();
  const int tcp_before = established_tcp_sockets_of_this_process();
  ASSERT_EQ(call(svc, ECHO), 0) << ln_get_error_message(client_);
  EXPECT_EQ(established_tcp_sockets_of_this_process(), tcp_before + 1);
  expect_call_fails_when_provider_killed(*child, [&] { return call(svc, SLOW, 10000); });
}

// ------------------------------------- across two network namespaces (veth)

/// Runs `command` through the shell, quietly; true when it exited 0.
bool run_quietly(const std::string& command) { return std::system((command + " >/dev/null 2>&1").c_str()) == 0; }

/// Two fresh network namespaces A and B joined by a veth pair (A .1, B .2 on
/// a /24); everything is deleted again at the end.
class NetnsPair {
 public:
  NetnsPair() {
    const std::string id = std::to_string(::getpid());
    a_ = "lncore-svc-a-" + id;
    b_ = "lncore-svc-b-" + id;
    const std::string veth_a = "lnsa" + id, veth_b = "lnsb" + id;  // <= 15 chars
    const std::string net = "10.213." + std::to_string(::getpid() % 250) + ".";
    ip_a_ = net + "1";
    ip_b_ = net + "2";
    ok_ = run_quietly("ip netns add " + a_) && run_quietly("ip netns add " + b_) &&
          run_quietly("ip link add " + veth_a + " netns " + a_ + " type veth peer name " + veth_b + " netns " + b_) &&
          run_quietly("ip -n " + a_ + " addr add " + ip_a_ + "/24 dev " + veth_a) &&
          run_quietly("ip -n " + b_ + " addr add " + ip_b_ + "/24 dev " + veth_b) &&
          run_quietly("ip -n " + a_ + " link set " + veth_a + " up") &&
          run_quietly("ip -n " + b_ + " link set " + veth_b + " up") &&
          run_quietly("ip -n " + a_ + " link set lo up") && run_quietly("ip -n " + b_ + " link set lo up");
  }
  ~NetnsPair() {
    // Deleting a namespace deletes its end of the veth pair, and with it the other.
    run_quietly("ip netns del " + a_);
    run_quietly("ip netns del " + b_);
  }
  NetnsPair(const NetnsPair&) = delete;
  NetnsPair& operator=(const NetnsPair&) = delete;

  bool ok() const { return ok_; }
  /// argv that runs `program` in namespace A or B.
  std::vector<std::string> in_a(std::vector<std::string> program) const { return in(a_, std::move(program)); }
  std::vector<std::string> in_b(std::vector<std::string> program) const { return in(b_, std::move(program)); }
  const std::string& ip_a() const { return ip_a_; }

 private:
  static std::vector<std::string> in(const std::string& ns, std::vector<std::string> program) {
    std::vector<std::string> args = {"/usr/sbin/ip", "netns", "exec", ns};
    args.insert(args.end(), program.begin(), program.end());
    return args;
  }
  std::string a_, b_, ip_a_, ip_b_;
  bool ok_ = false;
};

TEST(ServiceNetnsTest, CallerInAnotherNetworkNamespaceCallsOverVeth) {
  const bool in_ci = std::getenv("CI") != nullptr;
  if (::geteuid() != 0 || ::access("/usr/sbin/ip", X_OK) != 0) {
    if (in_ci) FAIL() << "CI: network namespaces need root and /usr/sbin/ip";
    GTEST_SKIP() << "cannot make network namespaces here (needs root and /usr/sbin/ip)";
  }
  NetnsPair namespaces;
  if (!namespaces.ok()) {
    if (in_ci) FAIL() << "CI: creating two network namespaces with a veth pair failed";
    GTEST_SKIP() << "cannot make network namespaces with a veth pair here";
  }
  // Manager and provider in A, the manager listening on A's veth address only.
  ChildProcess manager(namespaces.in_a({LN_MANAGER_PROGRAM, "--listen", namespaces.ip_a() + ":0", "--without-gui"}),
                       "unused:1");
  const std::string listening = manager.wait_for_line("ln_manager: listening on ");
  ASSERT_NE(listening, "") << "the manager in namespace A did not start";
  const std::string address = listening.substr(std::strlen("ln_manager: listening on "));
  ASSERT_EQ(address.compare(0, namespaces.ip_a().size() + 1, namespaces.ip_a() + ":"), 0) << address;
  // A pool, so the call after the timed-out one need not wait for it.
  ChildProcess provider(namespaces.in_a({LN_SVC_PROVIDER, "svc", "pool", "2"}), address);
  ASSERT_NE(provider.wait_for_line("ready"), "") << "the provider in namespace A did not register";
  // The caller in B reaches A only through the veth pair: over TCP.
  ChildProcess caller(namespaces.in_b({LN_SVC_CALLER, "svc"}), address);
  const std::string result = caller.wait_for_line("", 20s);
  EXPECT_EQ(result, "ok");
  EXPECT_EQ(caller.wait(), 0);
}

}  // namespace
