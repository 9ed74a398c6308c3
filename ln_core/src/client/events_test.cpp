// Events through the public API of libln.so (C and C++), against an
// in-process manager: ln.resource_event from the manager, events other
// programs emit by calling a connection's handler service, errors.
#include <gtest/gtest.h>
#include <ln/ln.h>

#include <atomic>
#include <mutex>
#include <string>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

const char* const kResourceSignature =
    "ln/resource_event: uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1";
const char* const kEventCallSignature = "uint32_t 4 1,uint8_t* 1 1,uint32_t 4 1,char* 1 1|";

// The generated structs of ln/resource_event (connect and call sections
// have the same layout) and of ln/event/call.
#include "ln/packed.h"
typedef struct LN_PACKED {
  uint32_t a_len;
  char* a;
  uint32_t b_len;
  char* b;
  uint32_t c_len;
  char* c;
  uint32_t d_len;
  char* d;
} four_strings_t;
typedef struct LN_PACKED {
  struct LN_PACKED {
    uint32_t data_len;
    uint8_t* data;
    uint32_t signature_len;
    char* signature;
  } req;
} event_call_t;
#include "ln/endpacked.h"

four_strings_t strings(const char* a, const char* b, const char* c, const char* d) {
  auto len = [](const char* s) { return static_cast<uint32_t>(std::strlen(s)); };
  return {len(a), const_cast<char*>(a), len(b), const_cast<char*>(b),
          len(c), const_cast<char*>(c), len(d), const_cast<char*>(d)};
}

// What a handler saw: one line per event, "event name md client".
using Seen = LockedLines;

void record_resource_event(ln_client, ln_event_call call, void* user_data) {
  auto* seen = static_cast<Seen*>(user_data);
  four_strings_t event{};
  const int ret = ln_event_call_set_data(call, kResourceSignature, &event);
  if (ret != 0) return seen->add("set_data " + std::to_string(ret));
  auto text = [](char* s, uint32_t n) { return std::string(s, n); };
  seen->add(text(event.a, event.a_len) + " " + text(event.b, event.b_len) + " " + text(event.c, event.c_len) + " " +
            text(event.d, event.d_len));
}

class EventsTest : public ::testing::Test {
 protected:
  ln_client connect_client(const char* name) {
    ln_client client = connect_to(manager_.address(), name);
    clients_.push_back(client);
    return client;
  }
  void TearDown() override {
    for (ln_client& client : clients_) ln_deinit(&client);
  }
  // Handles `client`'s default group until `done` holds (bounded).
  template <typename Done>
  bool handle_until(ln_client client, Done done, std::chrono::seconds limit = 5s) {
    const auto deadline = Clock::now() + limit;
    while (!done()) {
      if (Clock::now() > deadline) return false;
      ln_wait_and_handle_service_group_requests(client, nullptr, 0.05);
    }
    return true;
  }
  static ln_event_connection connect_resources(ln_client client, Seen& seen, const four_strings_t& patterns) {
    ln_event_connection connection = nullptr;
    four_strings_t connect = patterns;
    EXPECT_EQ(ln_event_connect(client, &connection, "ln.resource_event", kResourceSignature, &connect,
                               record_resource_event, &seen),
              0)
        << ln_get_error_message(client);
    return connection;
  }

  ScopedEnv no_manager_env_{"LN_MANAGER", std::nullopt};
  ScopedEnv no_map_{"LN_MAP_SERVICES", std::nullopt};
  InProcessManager manager_;
  std::vector<ln_client> clients_;
};

TEST_F(EventsTest, ResourceEventsReachTheDefaultGroupInOrder) {
  ln_client watcher = connect_client("watcher");
  Seen seen;
  ln_event_connection connection = connect_resources(watcher, seen, strings("*", "*", "*", "*"));
  EXPECT_EQ(ln_event_connection_get_id(connection), 1u);
  ASSERT_TRUE(handle_until(watcher, [&] { return seen.copy().size() >= 2; })) << seen.copy().size();
  EXPECT_EQ(seen.copy(),
            (std::vector<std::string>{"service_new_provider ln.resource_event.watcher ln/event/call watcher",
                                      "initial_sync_done   "}));

  ln_client other = connect_client("other");
  ln_outport port = nullptr;
  ASSERT_EQ(ln_publish(other, "ev.topic", "test/vec3", &port), 0);
  ln_inport inport = nullptr;
  ASSERT_EQ(ln_subscribe(other, "ev.topic", "test/vec3", &inport, -1, 0), 0);
  ASSERT_EQ(ln_unsubscribe(&inport), 0);
  ASSERT_EQ(ln_unpublish(&port), 0);
  const std::vector<std::string> expected = {
      "topic_new_publisher ev.topic test/vec3 other", "topic_new_subscriber ev.topic test/vec3 other",
      "topic_del_subscriber ev.topic test/vec3 other", "topic_del_publisher ev.topic test/vec3 other"};
  ASSERT_TRUE(handle_until(watcher, [&] { return seen.copy().size() >= 6; })) << seen.copy().size();
  const std::vector<std::string> all = seen.copy();
  EXPECT_EQ(std::vector<std::string>(all.begin() + 2, all.end()), expected);
  EXPECT_EQ(ln_event_connection_deinit(&connection), 0);
  EXPECT_EQ(connection, nullptr);
}

TEST_F(EventsTest, HandlersRunInAThreadPoolWhenTheDefaultGroupIsThere) {
  ln_client watcher = connect_client("watcher");
  ASSERT_EQ(ln_handle_service_group_in_thread_pool(watcher, nullptr, "events"), 0);
  Seen seen;
  ln_event_connection connection = connect_resources(watcher, seen, strings("service_*", "svc.*", "*", "*"));
  ln_client provider = connect_client("provider");
  ln_service service = nullptr;
  ASSERT_EQ(ln_service_init(provider, &service, "svc.one", "ln/string_request", "uint32_t 4 1,char* 1 1|"), 0);
  ASSERT_EQ(ln_service_provider_set_handler(
                service, [](ln_client, ln_service_request, void*) { return 0; }, nullptr),
            0);
  ASSERT_EQ(ln_service_provider_register(provider, service), 0);
  ASSERT_EQ(ln_service_deinit(&service), 0);
  EXPECT_TRUE(wait_until([&] { return seen.copy().size() >= 3; }, 30s)) << seen.copy().size();
  EXPECT_EQ(seen.copy(),
            (std::vector<std::string>{"initial_sync_done   ", "service_new_provider svc.one ln/string_request provider",
                                      "service_del_provider svc.one ln/string_request provider"}));
  EXPECT_EQ(ln_event_connection_deinit(&connection), 0);
}

// Events that are not the manager's: any program emits them by calling the
// connection's handler service "<event>.<client>" (ln/event/call).
TEST_F(EventsTest, OtherProgramsEmitEventsThroughTheHandlerService) {
  ln_client listener = connect_client("listener");
  struct Received {
    std::vector<std::string> buffers;
    std::vector<int> matching, wrong_signature;
  } received;
  ln_event_connection connection = nullptr;
  four_strings_t connect = strings("", "", "", "");
  ASSERT_EQ(ln_event_connect(
                listener, &connection, "my.event", kResourceSignature, &connect,
                [](ln_client, ln_event_call call, void* user) {
                  auto* r = static_cast<Received*>(user);
                  void* data = nullptr;
                  uint32_t len = 0;
                  ln_event_call_get_buffer(call, &data, &len);
                  r->buffers.emplace_back(static_cast<char*>(data), len);
                  four_strings_t event{};
                  r->matching.push_back(ln_event_call_set_data(call, kResourceSignature, &event));
                  r->wrong_signature.push_back(ln_event_call_set_data(call, "x/y: int8_t 1 1", &event));
                },
                &received),
            0);
  EXPECT_GT(ln_event_connection_get_id(connection), 0u) << "unique per client";

  ln_client emitter = connect_client("emitter");
  ln_service handler = nullptr;
  ASSERT_EQ(ln_service_init(emitter, &handler, "my.event.listener", "ln/event/call", kEventCallSignature), 0);
  const std::string good = std::string("\2\0\0\0ab\0\0\0\0\1\0\0\0c\0\0\0\0", 19);
  for (const std::string& data : {good, std::string("\2\0\0", 3)}) {
    event_call_t call{};
    call.req.data = reinterpret_cast<uint8_t*>(const_cast<char*>(data.data()));
    call.req.data_len = static_cast<uint32_t>(data.size());
    call.req.signature = const_cast<char*>(kResourceSignature);
    call.req.signature_len = static_cast<uint32_t>(std::strlen(kResourceSignature));
    ln_service_request request = nullptr;
    ASSERT_EQ(ln_service_call_async(handler, &call, &request), 0);
    int result = -1;
    ASSERT_TRUE(handle_until(listener, [&] { return ln_service_request_finished(request, &result) == 1; }));
    EXPECT_EQ(result, 0) << "the handler service always answers";
  }
  ASSERT_EQ(received.buffers.size(), 2u);
  EXPECT_EQ(received.buffers[0], good);
  EXPECT_EQ(received.matching, (std::vector<int>{0, -LNE_SVC_RECV_REQ}));
  EXPECT_EQ(received.wrong_signature, (std::vector<int>{-LNE_SVC_REQ_SET_DATA_WRONG, -LNE_SVC_REQ_SET_DATA_WRONG}));
  EXPECT_NE(std::string(ln_get_error_message(listener)).find("x/y: int8_t 1 1"), std::string::npos)
      << ln_get_error_message(listener);
  EXPECT_EQ(ln_service_deinit(&handler), 0);

  // Disconnected: the handler service is gone.
  EXPECT_EQ(ln_event_connection_deinit(&connection), 0);
  EXPECT_EQ(ln_wait_for_service(emitter, "my.event.listener", 0), 0);
}

TEST_F(EventsTest, BadConnectsFailClearly) {
  ln_client client = connect_client("bad");
  Seen seen;
  ln_event_connection connection = nullptr;
  four_strings_t connect = strings("*", "*", "*", "*");
  EXPECT_EQ(ln_event_connect(client, &connection, "ln.resource_event", "no definition prefix", &connect,
                             record_resource_event, &seen),
            -LNE_INVALID_SIGNATURE);
  EXPECT_EQ(
      ln_event_connect(client, &connection, "ln.unknown", kResourceSignature, &connect, record_resource_event, &seen),
      -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client)).find("unknown event 'ln.unknown'"), std::string::npos)
      << ln_get_error_message(client);
  EXPECT_EQ(ln_wait_for_service(client, "ln.unknown.bad", 0), 0) << "a refused connection leaves no service";
  EXPECT_EQ(ln_event_connect(client, &connection, "x.y", kResourceSignature, nullptr, record_resource_event, &seen),
            -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_event_connect(client, &connection, "x.y", kResourceSignature, &connect, nullptr, &seen),
            -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_event_connect(client, nullptr, "x.y", kResourceSignature, &connect, record_resource_event, &seen),
            -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_event_connect_flat(client, &connection, "ln.resource_event", kResourceSignature, &connect, 3,
                                  record_resource_event, &seen),
            -LNE_INVALID_PARAMETER)
      << "three bytes are no four patterns";

  ASSERT_EQ(ln_event_connect(client, &connection, "x.y", kResourceSignature, &connect, record_resource_event, &seen),
            0);
  ln_event_connection second = nullptr;
  EXPECT_EQ(ln_event_connect(client, &second, "x.y", kResourceSignature, &connect, record_resource_event, &seen),
            -LNE_REQUEST_FAILED);
  EXPECT_EQ(ln_wait_for_service(client, "x.y.bad", 0), 1) << "the first connection keeps its service";
  ln_event_connection copy = connection;
  EXPECT_EQ(ln_event_connection_deinit(&connection), 0);
  EXPECT_EQ(ln_event_connection_deinit(&connection), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_event_connection_get_id(nullptr), 0u);
  (void)copy;  // a stale copy is refused by the check too, but reading freed memory is not tested here
  EXPECT_EQ(ln_event_call_set_data(nullptr, kResourceSignature, &connect), -LNE_INVALID_PARAMETER);
  void* data = nullptr;
  uint32_t len = 0;
  EXPECT_EQ(ln_event_call_get_buffer(nullptr, &data, &len), -LNE_INVALID_PARAMETER);
}

TEST_F(EventsTest, ConnectionsSurviveAManagerRestart) {
  ln_client watcher = connect_client("watcher");
  Seen seen;
  ln_event_connection connection = connect_resources(watcher, seen, strings("topic_new_publisher", "*", "*", "*"));
  ASSERT_TRUE(handle_until(watcher, [&] { return seen.copy().size() >= 1; }));
  manager_.restart();
  ln_client other = nullptr;
  ASSERT_TRUE(wait_until([&] { return ln_init_to_manager(&other, "other", manager_.address().c_str()) == 0; }, 10s));
  clients_.push_back(other);
  ln_outport port = nullptr;
  // Published until the watcher, announced again after the restart, hears of it.
  ASSERT_EQ(ln_publish(other, "after.restart", "test/vec3", &port), 0);
  EXPECT_TRUE(handle_until(
      watcher,
      [&] {
        for (const std::string& line : seen.copy())
          if (line == "topic_new_publisher after.restart test/vec3 other") return true;
        return false;
      },
      10s))
      << seen.copy().size();
  EXPECT_EQ(ln_event_connection_deinit(&connection), 0);
}

// The C++ API (cppwrapper.h) over the same.
TEST_F(EventsTest, CppConnectionsDeliverAndDisconnect) {
  ln::client clnt("cpp_watcher", manager_.address());
  Seen seen;
  four_strings_t connect = strings("*", "*", "*", "*");
  ln::event_connection* connection = clnt.connect_to_event(
      "ln.resource_event", kResourceSignature, &connect,
      [](ln::event_call& call, void* user) {
        four_strings_t event{};
        call.set_data(&event, kResourceSignature);
        static_cast<Seen*>(user)->add(std::string(event.a, event.a_len));
      },
      &seen);
  EXPECT_EQ(connection->event_name, "ln.resource_event");
  const auto deadline = Clock::now() + 5s;
  while (seen.copy().size() < 2 && Clock::now() < deadline) clnt.wait_and_handle_service_group_requests(nullptr, 0.05);
  EXPECT_EQ(seen.copy(), (std::vector<std::string>{"service_new_provider", "initial_sync_done"}));
  clnt.disconnect_from_event(connection);
}

}  // namespace
