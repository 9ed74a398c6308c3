// The rest of the service API, each test against its own manager: the
// vector variants (callv / respondv), the provider's descriptor and
// connection observer, thread pool scheduling, signature and interface
// introspection, service name mapping, and the explanations failed calls
// leave in ln_get_error_message() and ln::exception.
#include <linux/capability.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "service_process_fixture.hpp"

namespace {

using namespace ln::servicetest;

std::string text_of(const char* text, std::uint32_t length) { return std::string(text, length); }

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Takes a malloc()ed string and frees it.
std::string take(char* text) {
  std::string copy = text != nullptr ? text : "(null)";
  std::free(text);
  return copy;
}

// ------------------------------------------------ flat data, field by field

/// Service data in LN's flat form as a list of fields (an iovec each, with
/// its element size), the way language bindings call ln_service_callv().
class FlatFields {
 public:
  FlatFields& u32(std::uint32_t value) { return add(&value, sizeof value, sizeof value); }
  FlatFields& i32(std::int32_t value) { return add(&value, sizeof value, sizeof value); }
  FlatFields& f64(double value) { return add(&value, sizeof value, sizeof value); }
  /// A dynamic field: its element count, then its elements.
  FlatFields& chars(const std::string& text) {
    u32(static_cast<std::uint32_t>(text.size()));
    return add(text.data(), text.size(), 1);
  }
  FlatFields& bytes(const std::vector<std::uint8_t>& data) {
    u32(static_cast<std::uint32_t>(data.size()));
    return add(data.data(), data.size(), 1);
  }

  /// iovecs into this object (valid while it lives unchanged).
  std::vector<iovec> iov() {
    std::vector<iovec> list;
    for (std::string& field : fields_) list.push_back({field.data(), field.size()});
    return list;
  }
  std::uint8_t* element_sizes() { return element_sizes_.data(); }
  unsigned count() const { return static_cast<unsigned>(fields_.size()); }
  std::string joined() const {
    std::string all;
    for (const std::string& field : fields_) all += field;
    return all;
  }

 private:
  FlatFields& add(const void* data, std::size_t size, std::size_t element_size) {
    fields_.emplace_back(static_cast<const char*>(data), size);
    element_sizes_.push_back(static_cast<std::uint8_t>(element_size));
    return *this;
  }
  std::vector<std::string> fields_;
  std::vector<std::uint8_t> element_sizes_;
};

/// The flat svc/test request: `text`, `blob` and one item.
FlatFields flat_request(int mode, unsigned delay_ms, const std::string& text, const std::vector<std::uint8_t>& blob,
                        int error = 0) {
  FlatFields f;
  f.i32(mode).u32(delay_ms).i32(error).chars(text).bytes(blob);
  f.u32(1).i32(5).chars("lbl").u32(1).f64(0.5);  // items: {id 5, label "lbl", values {0.5}}
  return f;
}

/// What ln_svc_provider answers to flat_request(ECHO, ...).
std::string flat_echo_response(const std::string& text, const std::vector<std::uint8_t>& blob) {
  FlatFields f;
  f.chars(text).bytes(blob);
  f.u32(1).i32(5).chars("lbl").u32(1).f64(0.5);
  f.u32(1);  // count = number of items
  return f.joined();
}

// ------------------------------------------------- a provider in this process

/// A second client of this process providing one svc/test service with a
/// C handler. serve_in_thread() handles its group until destruction.
class InProcessProvider {
 public:
  InProcessProvider(const std::string& manager, const char* service_name, ln_service_handler handler, void* user_data,
                    const char* group = nullptr)
      : group_(group != nullptr ? group : ""), has_group_(group != nullptr) {
    EXPECT_EQ(ln_init_to_manager(&client, "in_process_provider", manager.c_str()), 0);
    EXPECT_EQ(ln_service_init(client, &service, service_name, "svc/test", svc_test_signature), 0);
    EXPECT_EQ(ln_service_provider_set_handler(service, handler, user_data), 0);
  }
  ~InProcessProvider() {
    stop_ = true;
    if (serving_.joinable()) {
      ln_unblock_service_group(client, group());
      serving_.join();
    }
    ln_service_deinit(&service);
    ln_deinit(&client);
  }
  InProcessProvider(const InProcessProvider&) = delete;
  InProcessProvider& operator=(const InProcessProvider&) = delete;

  int do_register() { return ln_service_provider_register_in_group(client, service, group()); }
  void serve_in_thread() {
    serving_ = std::thread([this] {
      serving_thread_id = pthread_self();
      serving_started_ = true;
      while (!stop_) ln_wait_and_handle_service_group_requests(client, group(), 0.05);
    });
    wait_until([this] { return serving_started_.load(); });
  }
  const char* group() const { return has_group_ ? group_.c_str() : nullptr; }

  ln_client client = nullptr;
  ln_service service = nullptr;
  pthread_t serving_thread_id{};

 private:
  std::string group_;
  bool has_group_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> serving_started_{false};
  std::thread serving_;
};

/// Handler: echoes the request's text.
int echo_text(ln_client, ln_service_request req, void*) {
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  if (ln_service_request_set_data(req, &data, svc_test_signature) != 0) return -LNE_SVC_REQ_SET_DATA_WRONG;
  data.resp.text_len = data.req.text_len;
  data.resp.text = data.req.text;
  return ln_service_request_respond(req);
}

using ServiceApiTest = ServiceProcessTest;

// ------------------------------------------------------------ vector calls

TEST_F(ServiceApiTest, CallvSendsFlatFieldsAndReturnsTheFlatResponse) {
  auto child = provider({"pool", "2"});
  ln_service svc = caller();
  const std::vector<std::uint8_t> blob = {1, 2, 3};
  FlatFields request = flat_request(ECHO, 0, "vector", blob);
  std::vector<iovec> iov = request.iov();
  char* response = nullptr;
  std::uint32_t response_len = 0;
  std::uint8_t need_swap = 7;
  ASSERT_EQ(
      ln_service_callv(svc, iov.data(), request.count(), request.element_sizes(), &response, &response_len, &need_swap),
      0)
      << error_message();
  EXPECT_EQ(std::string(response, response_len), flat_echo_response("vector", blob));
  EXPECT_EQ(need_swap, 0);

  // A timeout, then the handle works again.
  FlatFields slow = flat_request(SLOW, 3000, "", {});
  iov = slow.iov();
  EXPECT_EQ(ln_service_callv_with_timeout(svc, iov.data(), slow.count(), slow.element_sizes(), &response, &response_len,
                                          &need_swap, 0.2),
            -LNE_SVC_TIMEOUT);
  EXPECT_TRUE(contains(error_message(), "no response within 0.2 s")) << error_message();

  // Fields that do not make a request of the signature never leave.
  FlatFields lying;
  lying.i32(ECHO).u32(0).i32(0).u32(100).chars("abc");  // text count 100, 3 characters follow
  iov = lying.iov();
  EXPECT_EQ(
      ln_service_callv(svc, iov.data(), lying.count(), lying.element_sizes(), &response, &response_len, &need_swap),
      -LNE_INVALID_PARAMETER);
  EXPECT_TRUE(contains(error_message(), "invalid request")) << error_message();

  iov = request.iov();
  ASSERT_EQ(ln_service_callv_with_timeout(svc, iov.data(), request.count(), request.element_sizes(), &response,
                                          &response_len, &need_swap, 5),
            0)
      << error_message();
  EXPECT_EQ(std::string(response, response_len), flat_echo_response("vector", blob));
}

TEST_F(ServiceApiTest, CallvAsyncGivesTheFlatResponseAndTheStruct) {
  auto child = provider();
  ln_service svc = caller();
  char* response = nullptr;
  std::uint32_t response_len = 0;
  EXPECT_EQ(ln_service_callv_async_get_response(svc, &response, &response_len), -LNE_SVC_REQ_NOT_RUNNING);
  const std::vector<std::uint8_t> blob(1000, 0xab);
  FlatFields request = flat_request(SLOW, 50, "later", blob);
  std::vector<iovec> iov = request.iov();
  ln_service_request req = nullptr;
  ASSERT_EQ(ln_service_callv_async(svc, iov.data(), request.count(), request.element_sizes(), &req), 0)
      << error_message();
  EXPECT_EQ(ln_service_callv_async_get_response(svc, &response, &response_len), -LNE_SVC_REQ_RUNNING);
  int retval = -1;
  ASSERT_EQ(ln_service_request_wait(req, 5, &retval), 1);
  EXPECT_EQ(retval, 0);
  ASSERT_EQ(ln_service_callv_async_get_response(svc, &response, &response_len), 0);
  EXPECT_EQ(std::string(response, response_len), flat_echo_response("later", blob));
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  ASSERT_EQ(ln_service_callv_async_get_response_data(svc, &data), 0);
  EXPECT_EQ(text_of(data.resp.text, data.resp.text_len), "later");
  ASSERT_EQ(data.resp.blob_len, blob.size());
  EXPECT_EQ(data.resp.blob[999], 0xab);
  ASSERT_EQ(data.resp.items_len, 1u);
  EXPECT_EQ(data.resp.items[0].id, 5);
  EXPECT_EQ(text_of(data.resp.items[0].label, data.resp.items[0].label_len), "lbl");
  EXPECT_EQ(data.resp.count, 1u);
}

TEST_F(ServiceApiTest, RespondvAnswersWithFlatFields) {
  auto child = provider();
  ln_service svc = caller();
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  std::string text = "abcdef";
  data.req.mode = RESPONDV;
  data.req.text_len = static_cast<std::uint32_t>(text.size());
  data.req.text = text.data();
  ASSERT_EQ(ln_service_call(svc, &data), 0) << error_message();
  EXPECT_EQ(text_of(data.resp.text, data.resp.text_len), "fedcba");
  EXPECT_EQ(data.resp.blob_len, 0u);
  EXPECT_EQ(data.resp.items_len, 0u);
  EXPECT_EQ(data.resp.count, 77u);

  // The same response seen flat.
  FlatFields request;
  request.i32(RESPONDV).u32(0).i32(0).chars("xy").u32(0).u32(0);
  std::vector<iovec> iov = request.iov();
  char* response = nullptr;
  std::uint32_t response_len = 0;
  ASSERT_EQ(
      ln_service_callv(svc, iov.data(), request.count(), request.element_sizes(), &response, &response_len, nullptr), 0)
      << error_message();
  FlatFields expected;
  expected.chars("yx").u32(0).u32(0).u32(77);
  EXPECT_EQ(std::string(response, response_len), expected.joined());

  // A flat response that does not fit the signature fails the call, with
  // the reason, instead of leaving the caller waiting.
  data.req.mode = RESPONDV_INVALID;
  EXPECT_EQ(ln_service_call_with_timeout(svc, &data, 5), -LNE_INVALID_PARAMETER);
  EXPECT_TRUE(contains(error_message(), "failed to send its response")) << error_message();
  EXPECT_EQ(call(svc, ECHO), 0) << error_message();
}

TEST_F(ServiceApiTest, CppCallvAndItsFailures) {
  auto child = provider();
  ln::client clnt("cpp_callv", manager_.address());
  ln::service* svc = clnt.get_service("svc", "svc/test", svc_test_signature);
  const std::vector<std::uint8_t> blob = {9};
  FlatFields request = flat_request(ECHO, 0, "c++", blob);
  std::vector<iovec> iov = request.iov();
  char* response = nullptr;
  std::uint32_t response_len = 0;
  std::uint8_t need_swap = 1;
  svc->callv(iov.data(), request.count(), request.element_sizes(), &response, &response_len, &need_swap);
  EXPECT_EQ(std::string(response, response_len), flat_echo_response("c++", blob));

  ln::service_request* async = svc->callv_async(iov.data(), request.count(), request.element_sizes());
  EXPECT_TRUE(async->wait(5));
  svc->callv_async_get_response(&response, &response_len);
  EXPECT_EQ(std::string(response, response_len), flat_echo_response("c++", blob));

  FlatFields failing = flat_request(ERROR_TEXT, 0, "", {}, 7);
  std::vector<iovec> failing_iov = failing.iov();
  try {
    svc->callv(failing_iov.data(), failing.count(), failing.element_sizes(), &response, &response_len, &need_swap);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error, LNE_USER_DEFINED_ERROR) << e.what();
    EXPECT_EQ(e.error_code, 7);
    EXPECT_TRUE(contains(e.what(), "the provider refuses")) << e.what();
  }
}

// ------------------------------------------- the provider's descriptors

TEST_F(ServiceApiTest, ProviderFdSignalsRequestsForAnExternalLoop) {
  InProcessProvider provider(manager_.address(), "fdsvc", echo_text, nullptr);
  EXPECT_EQ(ln_service_provider_get_fd(provider.service), -LNE_SVC_NOT_REGISTERED);
  ASSERT_EQ(provider.do_register(), 0) << ln_get_error_message(provider.client);
  const int fd = ln_service_provider_get_fd(provider.service);
  ASSERT_GE(fd, 0);
  pollfd idle{fd, POLLIN, 0};
  EXPECT_EQ(::poll(&idle, 1, 0), 0) << "work signalled before any caller came";

  ln_service svc = caller("fdsvc");
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  std::string text = "polled";
  data.req.text_len = static_cast<std::uint32_t>(text.size());
  data.req.text = text.data();
  ln_service_request req = nullptr;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0) << error_message();
  // The program's own loop: sleep in poll() on the descriptor, handle what is there.
  int retval = -1;
  int finished = 0;
  const auto deadline = Clock::now() + 5s;
  while (finished == 0 && Clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) == 1) {
      ASSERT_GE(ln_wait_and_handle_service_group_requests(provider.client, nullptr, 0), 0);
    }
    finished = ln_service_request_finished(req, &retval);
  }
  ASSERT_EQ(finished, 1);
  EXPECT_EQ(retval, 0);
  EXPECT_EQ(text_of(data.resp.text, data.resp.text_len), "polled");
  pollfd after{fd, POLLIN, 0};
  EXPECT_EQ(::poll(&after, 1, 0), 0) << "work still signalled after everything was handled";
}

struct FdEvent {
  ln_svc_client_event_t event;
  int fd;
  pthread_t thread;
};

struct FdEvents {
  std::mutex mutex;
  std::vector<FdEvent> list;
  std::vector<FdEvent> get() {
    std::lock_guard<std::mutex> lock(mutex);
    return list;
  }
  void add(ln_svc_client_event_t event, int fd) {
    std::lock_guard<std::mutex> lock(mutex);
    list.push_back({event, fd, pthread_self()});
  }
};

void record_fd_event(ln_client, ln_svc_client_event_t event, int fd, void* user_data) {
  static_cast<FdEvents*>(user_data)->add(event, fd);
}

TEST_F(ServiceApiTest, ClientFdHandlerSeesCallersConnectAndLeave) {
  InProcessProvider provider(manager_.address(), "fdsvc", echo_text, nullptr);
  FdEvents events;
  // Installed before registering, as LN 2.9 programs do.
  ASSERT_EQ(ln_service_provider_set_client_fd_handler(provider.service, record_fd_event, &events), 0);
  ASSERT_EQ(provider.do_register(), 0) << ln_get_error_message(provider.client);
  provider.serve_in_thread();

  ln_service first = caller("fdsvc");
  ASSERT_EQ(call(first, ECHO), 0) << error_message();
  ASSERT_TRUE(wait_until([&] { return events.get().size() == 1; }));
  const FdEvent connected = events.get()[0];
  EXPECT_EQ(connected.event, LN_NEW_SVC_CLIENT);
  EXPECT_GE(connected.fd, 0);
  EXPECT_TRUE(pthread_equal(connected.thread, provider.serving_thread_id)) << "not in the group's thread";

  services_.pop_back();
  ASSERT_EQ(ln_service_deinit(&first), 0);  // closes its connection
  ASSERT_TRUE(wait_until([&] { return events.get().size() == 2; }));
  const FdEvent left = events.get()[1];
  EXPECT_EQ(left.event, LN_REMOVE_SVC_CLIENT);
  EXPECT_EQ(left.fd, connected.fd);
  EXPECT_TRUE(pthread_equal(left.thread, provider.serving_thread_id));

  // Removed: the next caller goes unobserved.
  ASSERT_EQ(ln_service_provider_set_client_fd_handler(provider.service, nullptr, nullptr), 0);
  ln_service second = caller("fdsvc");
  ASSERT_EQ(call(second, ECHO), 0) << error_message();
  ASSERT_EQ(call(second, ECHO), 0) << error_message();
  EXPECT_EQ(events.get().size(), 2u);
}

struct CppFdObserver {
  std::atomic<int> connected{0};
  std::atomic<int> fd{-1};
  static void on_event(ln::client&, ln_svc_client_event_t event, int fd, void* self) {
    auto* observer = static_cast<CppFdObserver*>(self);
    if (event == LN_NEW_SVC_CLIENT) {
      observer->fd = fd;
      ++observer->connected;
    }
  }
};

int cpp_echo(ln::client&, ln::service_request& req, void*) {
  svc_test_t data;
  req.set_data(&data, svc_test_signature);
  std::memset(&data.resp, 0, sizeof data.resp);
  return req.respond();
}

TEST_F(ServiceApiTest, CppProviderFdAndClientFdHandler) {
  ln::client providing("cpp_fd_provider", manager_.address());
  ln::service* provider = providing.get_service_provider("cppfd", "svc/test", svc_test_signature);
  provider->set_handler(cpp_echo);
  provider->do_register();
  CppFdObserver observer;
  provider->set_client_fd_handler(&CppFdObserver::on_event, &observer);  // after registering, this time
  const int fd = provider->get_fd();
  EXPECT_GE(fd, 0);

  ln_service svc = caller("cppfd");
  std::atomic<int> result{1};
  std::thread calling([&] { result = call(svc, ECHO); });
  const auto deadline = Clock::now() + 5s;
  while (result == 1 && Clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) == 1) providing.wait_and_handle_service_group_requests(nullptr, 0);
  }
  calling.join();
  EXPECT_EQ(result.load(), 0) << error_message();
  EXPECT_EQ(observer.connected.load(), 1);
  EXPECT_GE(observer.fd.load(), 0);

  ln::client calling_client("cpp_fd_caller", manager_.address());
  ln::service* calling_handle = calling_client.get_service("cppfd", "svc/test", svc_test_signature);
  try {
    calling_handle->set_client_fd_handler(&CppFdObserver::on_event, &observer);
    ADD_FAILURE() << "a calling handle took a client fd handler";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error, LNE_SVC_IS_CLIENT) << e.what();
  }
}

// --------------------------------------------------- thread pool scheduling

/// Handler: answers where it runs - text "cpus=<allowed CPU mask> cpu=<current>
/// policy=<SCHED_*>" - and remembers its thread (count = threads seen so far).
struct WhereHandlersRun {
  std::mutex mutex;
  std::set<pthread_t> threads;
  std::atomic<unsigned> delay_ms{0};

  static int handle(ln_client, ln_service_request req, void* self) {
    auto* where = static_cast<WhereHandlersRun*>(self);
    svc_test_t data;
    std::memset(&data, 0, sizeof data);
    if (ln_service_request_set_data(req, &data, svc_test_signature) != 0) return -LNE_SVC_REQ_SET_DATA_WRONG;
    if (data.req.delay_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(data.req.delay_ms));
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    unsigned mask = 0;
    if (::sched_getaffinity(0, sizeof cpus, &cpus) == 0)
      for (unsigned cpu = 0; cpu < 32; ++cpu)
        if (CPU_ISSET(cpu, &cpus)) mask |= 1u << cpu;
    int policy = -1;
    sched_param param{};
    ::pthread_getschedparam(pthread_self(), &policy, &param);
    char text[128];
    const int n = std::snprintf(text, sizeof text, "cpus=%x cpu=%d policy=%d", mask, ::sched_getcpu(), policy);
    {
      std::lock_guard<std::mutex> lock(where->mutex);
      where->threads.insert(pthread_self());
      data.resp.count = static_cast<std::uint32_t>(where->threads.size());
    }
    data.resp.text_len = static_cast<std::uint32_t>(n);
    data.resp.text = text;
    return ln_service_request_respond(req);
  }
  std::size_t thread_count() {
    std::lock_guard<std::mutex> lock(mutex);
    return threads.size();
  }
  void forget_threads() {
    std::lock_guard<std::mutex> lock(mutex);
    threads.clear();
  }
};

class ThreadPoolSchedTest : public ServiceProcessTest {
 protected:
  void SetUp() override {
    ServiceProcessTest::SetUp();
    provider_ =
        std::make_unique<InProcessProvider>(manager_.address(), "sched", &WhereHandlersRun::handle, &where_, "g");
    ASSERT_EQ(provider_->do_register(), 0);
    ASSERT_EQ(ln_set_max_threads(provider_->client, "pool", 2), 0);
    ASSERT_EQ(ln_handle_service_group_in_thread_pool(provider_->client, "g", "pool"), 0);
  }
  void TearDown() override {
    ServiceProcessTest::TearDown();
    provider_.reset();
  }
  /// Calls "sched" from `n` handles at once (each handler waiting
  /// `delay_ms`, so that n pool threads must serve them); their texts.
  std::vector<std::string> where_calls_run(unsigned n, unsigned delay_ms = 0) {
    while (handles_.size() < n) handles_.push_back(caller("sched"));
    std::vector<std::string> texts(n);
    std::vector<std::thread> threads;
    for (unsigned i = 0; i < n; ++i)
      threads.emplace_back([&, i] {
        svc_test_t data;
        std::memset(&data, 0, sizeof data);
        data.req.delay_ms = delay_ms;
        const int ret = ln_service_call_with_timeout(handles_[i], &data, 10);
        texts[i] = ret == 0 ? text_of(data.resp.text, data.resp.text_len) : "error " + std::to_string(ret);
      });
    for (auto& t : threads) t.join();
    return texts;
  }
  int pool_schedparam(int policy, int priority, unsigned mask) {
    return ln_thread_pool_setschedparam(provider_->client, "pool", policy, priority, mask);
  }
  std::string provider_error() const { return ln_get_error_message(provider_->client); }

  WhereHandlersRun where_;
  std::unique_ptr<InProcessProvider> provider_;
  std::vector<ln_service> handles_;
};

bool cpu_allowed(int cpu) {
  cpu_set_t cpus;
  CPU_ZERO(&cpus);
  return ::sched_getaffinity(0, sizeof cpus, &cpus) == 0 && CPU_ISSET(cpu, &cpus);
}

TEST_F(ThreadPoolSchedTest, AffinityMaskPinsPoolThreadsAlsoThoseStartedLater) {
  if (!cpu_allowed(0)) GTEST_SKIP() << "this process may not run on CPU 0";
  ASSERT_EQ(pool_schedparam(SCHED_OTHER, 0, 0x1), 0) << provider_error();
  for (const std::string& text : where_calls_run(2, 100)) EXPECT_EQ(text, "cpus=1 cpu=0 policy=0");
  // Threads the pool starts afterwards are pinned as well.
  ASSERT_EQ(ln_set_max_threads(provider_->client, "pool", 4), 0);
  where_.forget_threads();
  for (const std::string& text : where_calls_run(4, 300)) EXPECT_EQ(text, "cpus=1 cpu=0 policy=0");
  EXPECT_EQ(where_.thread_count(), 4u);
  if (cpu_allowed(1)) {
    // policy and priority -1 keep them; a new mask moves every thread.
    ASSERT_EQ(pool_schedparam(-1, -1, 0x2), 0) << provider_error();
    for (const std::string& text : where_calls_run(4, 100)) EXPECT_EQ(text, "cpus=2 cpu=1 policy=0");
  }
  // C++ defaults change nothing.
  ln::client wrapper(provider_->client);
  wrapper.thread_pool_setschedparam("pool");
  for (const std::string& text : where_calls_run(1)) EXPECT_TRUE(contains(text, "policy=0")) << text;
}

TEST_F(ThreadPoolSchedTest, InvalidParametersFailClearlyAndChangeNothing) {
  if (!cpu_allowed(0)) GTEST_SKIP() << "this process may not run on CPU 0";
  ASSERT_EQ(pool_schedparam(-1, -1, 0x1), 0) << provider_error();
  EXPECT_EQ(pool_schedparam(SCHED_OTHER, 5, 0), -LNE_CHECK_ERRNO);  // SCHED_OTHER has priority 0 only
  EXPECT_TRUE(contains(provider_error(), "thread pool 'pool'")) << provider_error();
  EXPECT_TRUE(contains(provider_error(), std::strerror(EINVAL))) << provider_error();
  EXPECT_EQ(pool_schedparam(12345, 0, 0), -LNE_CHECK_ERRNO);
  EXPECT_TRUE(contains(provider_error(), std::strerror(EINVAL))) << provider_error();
  EXPECT_LT(pool_schedparam(-1, -1, 0x80000000u), 0) << "a mask of CPUs that do not exist";
  EXPECT_TRUE(contains(provider_error(), "thread pool 'pool'")) << provider_error();
  // The pool kept serving, with its earlier settings, also in new threads.
  ASSERT_EQ(ln_set_max_threads(provider_->client, "pool", 3), 0);
  for (const std::string& text : where_calls_run(3, 100)) EXPECT_EQ(text, "cpus=1 cpu=0 policy=0");
}

/// Runs `body` in a thread without capabilities (Linux keeps them per
/// thread), with RLIMIT_RTPRIO 0: what an unprivileged program may do.
/// False if the capabilities could not be dropped.
template <typename Body>
bool run_unprivileged(const Body& body) {
  rlimit old{};
  ::getrlimit(RLIMIT_RTPRIO, &old);
  rlimit none = old;
  none.rlim_cur = 0;
  ::setrlimit(RLIMIT_RTPRIO, &none);
  bool dropped = false;
  std::thread unprivileged([&] {
    __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
    __user_cap_data_struct nothing[_LINUX_CAPABILITY_U32S_3] = {};
    dropped = ::syscall(SYS_capset, &header, nothing) == 0;
    if (dropped) body();
  });
  unprivileged.join();
  ::setrlimit(RLIMIT_RTPRIO, &old);
  return dropped;
}

TEST_F(ThreadPoolSchedTest, RealTimePolicyWithoutPrivilegeIsRefusedWithTheReason) {
  int ret = 0;
  std::string cpp_failure;
  const bool ran = run_unprivileged([&] {
    ret = pool_schedparam(SCHED_FIFO, 10, 0);
    ln::client wrapper(provider_->client);
    try {
      wrapper.thread_pool_setschedparam("pool", SCHED_RR, 1);
    } catch (const ln::exception& e) {
      cpp_failure = e.what();
    }
  });
  if (!ran) GTEST_SKIP() << "cannot drop capabilities in a thread here";
  EXPECT_EQ(ret, -LNE_CHECK_ERRNO);
  EXPECT_TRUE(contains(provider_error(), std::strerror(EPERM))) << provider_error();
  EXPECT_TRUE(contains(cpp_failure, "thread_pool_setschedparam('pool')")) << cpp_failure;
  EXPECT_TRUE(contains(cpp_failure, std::strerror(EPERM))) << cpp_failure;
  for (const std::string& text : where_calls_run(2, 50)) EXPECT_TRUE(contains(text, "policy=0")) << text;
}

// ----------------------------------------------------------- introspection

TEST_F(ServiceApiTest, SignaturesAndServicesByInterface) {
  InProcessProvider first(manager_.address(), "calc.first", echo_text, nullptr);
  InProcessProvider second(manager_.address(), "calc.second", echo_text, nullptr);
  ASSERT_EQ(first.do_register(), 0);
  ASSERT_EQ(second.do_register(), 0);

  char* definition = nullptr;
  char* signature = nullptr;
  ASSERT_EQ(ln_get_service_signature(client_, "svc/test", &definition, &signature), 0) << error_message();
  const std::string interface_definition = take(definition);
  EXPECT_EQ(take(signature), svc_test_signature);
  EXPECT_TRUE(contains(interface_definition, "define item as \"svc/item\"")) << interface_definition;
  EXPECT_TRUE(contains(interface_definition, "response")) << interface_definition;
  EXPECT_LT(ln_get_service_signature(client_, "svc/none", &definition, &signature), 0);
  EXPECT_TRUE(contains(error_message(), "svc/none")) << error_message();

  char* interface = nullptr;
  ASSERT_EQ(ln_get_service_signature_for_service(client_, "calc.first", &interface, &definition, &signature), 0)
      << error_message();
  EXPECT_EQ(take(interface), "svc/test");
  EXPECT_EQ(take(definition), interface_definition);
  EXPECT_EQ(take(signature), svc_test_signature);
  signature = nullptr;
  EXPECT_EQ(ln_get_service_signature_for_service(client_, "calc.second", nullptr, nullptr, &signature), 0);
  EXPECT_EQ(take(signature), svc_test_signature);
  EXPECT_LT(ln_get_service_signature_for_service(client_, "calc.none", &interface, &definition, &signature), 0);
  EXPECT_TRUE(contains(error_message(), "calc.none")) << error_message();

  char* services = nullptr;
  ASSERT_EQ(ln_client_find_services_with_interface(client_, "svc/test", &services), 0) << error_message();
  EXPECT_EQ(take(services), "calc.first\ncalc.second");
  ASSERT_EQ(ln_client_find_services_with_interface(client_, SVC_TEST_MD_NAME, &services), 0);  // with its hash
  EXPECT_EQ(take(services), "calc.first\ncalc.second");
  ASSERT_EQ(ln_client_find_services_with_interface(client_, "svc/item", &services), 0);
  EXPECT_EQ(take(services), "");

  ln::client cpp("cpp_introspection", manager_.address());
  std::string cpp_definition, cpp_signature, cpp_interface;
  cpp.get_service_signature("svc/test", cpp_definition, cpp_signature);
  EXPECT_EQ(cpp_definition, interface_definition);
  EXPECT_EQ(cpp_signature, svc_test_signature);
  cpp.get_service_signature_for_service("calc.second", cpp_interface, cpp_definition, cpp_signature);
  EXPECT_EQ(cpp_interface, "svc/test");
  EXPECT_EQ(cpp_signature, svc_test_signature);
  EXPECT_EQ(cpp.find_services_with_interface("svc/test"), "calc.first\ncalc.second");
  try {
    cpp.get_service_signature_for_service("calc.none", cpp_interface, cpp_definition, cpp_signature);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_TRUE(contains(e.what(), "calc.none")) << e.what();
  }
}

// ------------------------------------------------------------ name mapping

TEST_F(ServiceApiTest, ServiceNamesAreMappedFromArgumentsAndEnvironment) {
  // Providers: one mapped by its arguments, one by LN_MAP_SERVICES.
  auto by_argument = provider({"--ln-map-service", "^svc$", "mapped.svc"});
  ChildProcess by_environment({LN_SVC_PROVIDER, "other"}, manager_.address(),
                              {"LN_MAP_SERVICES=^nothing$|x|^other$|env.svc"});
  ASSERT_NE(by_environment.wait_for_line("ready"), "");
  EXPECT_EQ(ln_wait_for_service(client_, "mapped.svc", 0), 1);
  EXPECT_EQ(ln_wait_for_service(client_, "env.svc", 0), 1);
  EXPECT_EQ(ln_wait_for_service(client_, "svc", 0), 0);
  EXPECT_EQ(ln_wait_for_service(client_, "other", 0), 0);
  EXPECT_EQ(call(caller("mapped.svc"), ECHO), 0) << error_message();

  // A caller with both: the arguments' rules first, then the environment's
  // (LN 2.9's order), each applied to the result of the one before.
  ScopedEnv rules("LN_MAP_SERVICES", std::string(".old$|.svc|^over.svc$|env.svc"));
  std::string address = manager_.address();
  std::vector<std::string> args = {"prog",
                                   "--ln-manager",
                                   address,
                                   "--ln-map-service",
                                   "^alias$",
                                   "mapped.old",
                                   "-ln_map_service",
                                   "^pre.",
                                   "mapped.",
                                   "--ln-map-service",
                                   "_tmp",
                                   ""};
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  ln_client mapped = nullptr;
  ASSERT_EQ(ln_init(&mapped, "mapped_caller", static_cast<int>(argv.size()), argv.data()), 0);
  unsigned n_args = 0;
  char* remaining = nullptr;
  ASSERT_EQ(ln_get_remaining_args(mapped, &n_args, &remaining), 0);
  EXPECT_EQ(n_args, 1u) << "the mapping options are consumed";
  // Each name reaches a provider only through the mapping shown.
  const char* const names[] = {
      "alias",           // ^alias$ -> mapped.old, then .old$ -> mapped.svc
      "mapped.old",      // suffix -> mapped.svc
      "pre.svc",         // prefix -> mapped.svc
      "mapped_tmp.svc",  // first occurrence: "_tmp" -> "", mapped.svc
      "over_tmp.svc",    // "_tmp" -> "", then ^over.svc$ -> env.svc
      "env.svc",         // unchanged
  };
  for (const char* name : names) {
    ln_service svc = nullptr;
    ASSERT_EQ(ln_service_init(mapped, &svc, name, "svc/test", svc_test_signature), 0);
    svc_test_t data;
    std::memset(&data, 0, sizeof data);
    EXPECT_EQ(ln_service_call_with_timeout(svc, &data, 5), 0) << name << ": " << ln_get_error_message(mapped);
    ln_service_deinit(&svc);
    char* interface = nullptr;
    char* signature = nullptr;
    EXPECT_EQ(ln_get_service_signature_for_service(mapped, name, &interface, nullptr, &signature), 0) << name;
    EXPECT_EQ(take(interface), "svc/test") << name;
    std::free(signature);
    EXPECT_EQ(ln_wait_for_service(mapped, name, 0), 1) << name;
  }
  // ^alias$ is the whole name only (LN 2.9 also maps names that merely
  // start with "alias": a documented difference).
  EXPECT_EQ(ln_wait_for_service(mapped, "alias2", 0), 0);
  // The mapping is per client: the driver's names stay as they are.
  EXPECT_EQ(ln_wait_for_service(client_, "alias", 0), 0);
  // Interface searches report the names as registered.
  char* services = nullptr;
  ASSERT_EQ(ln_client_find_services_with_interface(mapped, "svc/test", &services), 0);
  EXPECT_EQ(take(services), "env.svc\nmapped.svc");
  // A provider registers under its mapped name.
  ln_service mapped_provider = nullptr;
  ASSERT_EQ(ln_service_init(mapped, &mapped_provider, "pre.local", "svc/test", svc_test_signature), 0);
  ASSERT_EQ(ln_service_provider_set_handler(mapped_provider, echo_text, nullptr), 0);
  ASSERT_EQ(ln_service_provider_register(mapped, mapped_provider), 0) << ln_get_error_message(mapped);
  EXPECT_EQ(ln_wait_for_service(client_, "mapped.local", 0), 1);
  ln_service_deinit(&mapped_provider);
  ln_deinit(&mapped);
}

// ------------------------------------------- providers that went and came

TEST_F(ServiceApiTest, IdleCallerReachesAProviderThatRestarted) {
  ln_service svc = caller();
  for (int round = 0; round < 3; ++round) {
    auto child = provider();
    EXPECT_EQ(call(svc, ECHO), 0) << "round " << round << ": " << error_message();
    child->kill(SIGKILL);
    ASSERT_EQ(child->wait(), 128 + SIGKILL);
    // Until the manager has noticed, the old registration may still be found.
    ASSERT_TRUE(wait_until([&] { return ln_wait_for_service(client_, "svc", 0) == 0; }));
  }
  // The provider withdraws the service but lives on; then offers it again.
  InProcessProvider first(manager_.address(), "svc", echo_text, nullptr);
  ASSERT_EQ(first.do_register(), 0);
  first.serve_in_thread();
  EXPECT_EQ(call(svc, ECHO), 0) << error_message();
  ASSERT_EQ(ln_service_deinit(&first.service), 0);
  ASSERT_EQ(ln_service_init(first.client, &first.service, "svc", "svc/test", svc_test_signature), 0);
  ASSERT_EQ(ln_service_provider_set_handler(first.service, echo_text, nullptr), 0);
  ASSERT_EQ(first.do_register(), 0) << ln_get_error_message(first.client);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(call(svc, ECHO), 0) << error_message();
}

// --------------------------------------------- why a call failed, in words

TEST_F(ServiceApiTest, FailedSyncCallsLeaveTheirReasonInTheErrorMessage) {
  auto child = provider({"pool", "2"});
  ln_service svc = caller();
  EXPECT_EQ(call(svc, ERROR_TEXT, 0, 0, 7), 7);
  EXPECT_TRUE(contains(error_message(), "service 'svc'")) << error_message();
  EXPECT_TRUE(contains(error_message(), "the provider refuses")) << error_message();

  EXPECT_EQ(call(svc, USER_ERROR, 0, 0, 42), 42);
  EXPECT_TRUE(contains(error_message(), "service 'svc'")) << error_message();
  EXPECT_TRUE(contains(error_message(), "error 42")) << error_message();

  EXPECT_EQ(call(svc, NO_RESPONSE), -LNE_SVC_HANDLER_NO_RESP);
  EXPECT_TRUE(contains(error_message(), "without responding")) << error_message();

  EXPECT_EQ(call(svc, SLOW, 3000, 0.25), -LNE_SVC_TIMEOUT);
  EXPECT_TRUE(contains(error_message(), "service 'svc': no response within 0.25 s")) << error_message();
  // Its handler's "slow" line, read now so that it cannot stand for the next slow call's below.
  EXPECT_NE(child->wait_for_line("slow"), "");

  ln_service wrong = caller("svc", "int32_t 4 1|");
  EXPECT_LT(call(wrong, ECHO), 0);
  EXPECT_TRUE(contains(error_message(), "service 'svc'")) << error_message();
  EXPECT_TRUE(contains(error_message(), "signature")) << error_message();

  // A provider that dies while it handles the call.
  ASSERT_EQ(call(svc, ECHO), 0);
  std::atomic<int> result{1};
  std::thread calling([&] { result = call(svc, SLOW, 10000); });
  EXPECT_NE(child->wait_for_line("slow"), "");  // the provider handles the call
  child->kill(SIGKILL);
  calling.join();
  EXPECT_EQ(result.load(), -LNE_SVC_RECV_RESP);
  EXPECT_TRUE(contains(error_message(), "service 'svc'")) << error_message();
  EXPECT_TRUE(contains(error_message(), "closed the connection")) << error_message();
}

TEST_F(ServiceApiTest, AsyncCallsGiveTheSameReasons) {
  auto child = provider();
  ln_service svc = caller();
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  data.req.mode = ERROR_TEXT;
  data.req.error = 7;
  ln_service_request req = nullptr;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0);
  int retval = 0;
  ASSERT_EQ(ln_service_request_wait(req, 5, &retval), 1);
  EXPECT_EQ(retval, 7);
  const std::string async_reason = ln_service_request_get_error_message(req);
  EXPECT_EQ(call(svc, ERROR_TEXT, 0, 0, 7), 7);
  EXPECT_EQ(async_reason, error_message());

  data.req.mode = USER_ERROR;
  data.req.error = 42;
  ASSERT_EQ(ln_service_call_async(svc, &data, &req), 0);
  ASSERT_EQ(ln_service_request_wait(req, 5, &retval), 1);
  EXPECT_EQ(retval, 42);
  ASSERT_NE(ln_service_request_get_error_message(req), nullptr);
  EXPECT_TRUE(contains(ln_service_request_get_error_message(req), "error 42"));
}

TEST_F(ServiceApiTest, CppExceptionsCarryTheReason) {
  auto child = provider({"pool", "2"});
  ln::client clnt("cpp_errors", manager_.address());
  ln::service* svc = clnt.get_service("svc", "svc/test", svc_test_signature);
  svc_test_t data;
  std::memset(&data, 0, sizeof data);
  data.req.mode = ERROR_TEXT;
  data.req.error = 7;
  try {
    svc->call(&data);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error, LNE_USER_DEFINED_ERROR);
    EXPECT_EQ(e.error_code, 7);
    EXPECT_TRUE(contains(e.what(), "ln::service('svc')::call")) << e.what();
    EXPECT_TRUE(contains(e.what(), "the provider refuses")) << e.what();
  }
  data.req.mode = SLOW;
  data.req.delay_ms = 3000;
  try {
    svc->call(&data, 0.2);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error, LNE_SVC_TIMEOUT);
    EXPECT_TRUE(contains(e.what(), "no response within 0.2 s")) << e.what();
  }
  data.req.mode = ERROR_TEXT;
  data.req.delay_ms = 0;
  ln::service_future future = svc->call_future(&data);
  try {
    future.get();
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    EXPECT_EQ(e.error_code, 7);
    EXPECT_TRUE(contains(e.what(), "the provider refuses")) << e.what();
  }
  child->kill(SIGKILL);
  ASSERT_EQ(child->wait(), 128 + SIGKILL);
  data.req.mode = ECHO;
  try {
    svc->call(&data, 5);
    ADD_FAILURE() << "no exception";
  } catch (const ln::exception& e) {
    // Whether or not the manager has noticed yet: nobody provides it now.
    EXPECT_EQ(e.error, LNE_NO_PROVIDER_FOUND) << e.what();
    EXPECT_TRUE(contains(e.what(), "ln::service('svc')::call")) << e.what();
    EXPECT_TRUE(contains(e.what(), "service 'svc': ")) << e.what();
  }
}

}  // namespace
