// Service loggers through the public API of libln.so, against an
// in-process manager: who sends which items when, what they hold, and that
// a logger never holds up the calls it logs. (tests/ln29_behaviour compares
// the items with LN 2.9's.)
#include <gtest/gtest.h>
#include <ln/ln.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <initializer_list>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

const char* const kLogSignature =
    "uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint8_t 1 1,uint8_t 1 1,double 8 1,"
    "double 8 1,double 8 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,uint32_t 4 1,uint64_t 8 1,uint32_t 4 1,uint8_t* 1 1"
    "|uint32_t 4 1,char* 1 1";
const char* const kEchoSignature = "uint32_t 4 1,char* 1 1|uint32_t 4 1,char* 1 1";

#include "ln/packed.h"
typedef struct LN_PACKED {
  struct LN_PACKED {
    uint32_t client_name_len;
    char* client_name;
    uint32_t service_name_len;
    char* service_name;
    uint32_t service_interface_len;
    char* service_interface;
    uint8_t item_type;
    uint8_t flags;
    double completion_time;
    double transfer_time;
    double request_time;
    uint32_t peer_address_len;
    char* peer_address;
    uint32_t client_id;
    uint32_t request_id;
    uint64_t thread_id;
    uint32_t data_len;
    uint8_t* data;
  } req;
  struct LN_PACKED {
    uint32_t error_message_len;
    char* error_message;
  } resp;
} log_service_t;
typedef struct LN_PACKED {
  struct LN_PACKED {
    uint32_t text_len;
    char* text;
  } req;
  struct LN_PACKED {
    uint32_t text_len;
    char* text;
  } resp;
} echo_t;
#include "ln/endpacked.h"

// "<type> <service> <client>" per item; a gate can hold the logger's handler.
struct LogBook : LockedLines {  // lines: the items
  std::condition_variable changed;
  std::vector<std::string> data;
  bool hold = false;
};

int log_handler(ln_client, ln_service_request request, void* user_data) {
  auto* book = static_cast<LogBook*>(user_data);
  log_service_t item{};
  if (ln_service_request_set_data(request, &item, kLogSignature) != 0) return -1;
  std::unique_lock<std::mutex> lock(book->mutex);
  book->changed.wait(lock, [&] { return !book->hold; });
  book->lines.push_back(std::to_string(item.req.item_type) + " " +
                        std::string(item.req.service_name, item.req.service_name_len) + " " +
                        std::string(item.req.client_name, item.req.client_name_len));
  book->data.push_back(std::string(reinterpret_cast<char*>(item.req.data), item.req.data_len));
  book->changed.notify_all();
  lock.unlock();
  return ln_service_request_respond(request);
}

int echo_handler(ln_client, ln_service_request request, void*) {
  echo_t data{};
  if (ln_service_request_set_data(request, &data, kEchoSignature) != 0) return -1;
  data.resp.text = data.req.text;
  data.resp.text_len = data.req.text_len;
  return ln_service_request_respond(request);
}

class ServiceLoggingTest : public ::testing::Test {
 protected:
  ln_client connect_client(const char* name) {
    ln_client client = connect_to(manager_.address(), name);
    clients_.push_back(client);
    return client;
  }
  ln_service provide(ln_client client, const char* name, const char* interface, const char* signature,
                     ln_service_handler handler, void* user_data) {
    ln_service service = nullptr;
    EXPECT_EQ(ln_service_init(client, &service, name, interface, signature), 0);
    EXPECT_EQ(ln_service_provider_set_handler(service, handler, user_data), 0);
    EXPECT_EQ(ln_service_provider_register(client, service), 0) << ln_get_error_message(client);
    services_.push_back(service);
    return service;
  }
  // Every client's default group, served by a pool thread.
  void serve(ln_client client) { ASSERT_EQ(ln_handle_service_group_in_thread_pool(client, nullptr, "serve"), 0); }
  // A client whose default group is served (serve()).
  ln_client serving_client(const char* name) {
    ln_client client = connect_client(name);
    serve(client);
    return client;
  }
  static int call(ln_service service, const char* text) {
    echo_t data{};
    data.req.text = const_cast<char*>(text);
    data.req.text_len = static_cast<uint32_t>(std::strlen(text));
    return ln_service_call(service, &data);
  }
  // `logger` provides "svc.log", logging into book_, and registers it as the logger of "svc.*".
  void become_logger(ln_client logger) {
    provide(logger, "svc.log", "ln/log_service", kLogSignature, log_handler, &book_);
    ASSERT_EQ(ln_register_as_service_logger(logger, "svc.log", "svc.*"), 0) << ln_get_error_message(logger);
  }
  void provide_echo(ln_client provider) {
    provide(provider, "svc.echo", "test/echo", kEchoSignature, echo_handler, nullptr);
  }
  // `caller`'s handle of "svc.echo".
  ln_service echo_of(ln_client caller) {
    ln_service echo = nullptr;
    EXPECT_EQ(ln_service_init(caller, &echo, "svc.echo", "test/echo", kEchoSignature), 0);
    services_.push_back(echo);
    return echo;
  }
  // Calls `echo` with `text` until book_ holds each of `items` (the notifications that make the
  // sides log travel asynchronously), bounded by `limit`.
  bool call_until_logged(ln_service echo, const char* text, std::initializer_list<const char*> items,
                         std::chrono::seconds limit) {
    return wait_until(
        [&] {
          call(echo, text);
          const auto logged = book_.copy();
          for (const char* item : items)
            if (std::find(logged.begin(), logged.end(), item) == logged.end()) return false;
          return true;
        },
        limit);
  }
  void TearDown() override {
    for (ln_service& service : services_) ln_service_deinit(&service);
    for (ln_client& client : clients_) ln_deinit(&client);
  }

  ScopedEnv no_manager_env_{"LN_MANAGER", std::nullopt};
  ScopedEnv no_map_{"LN_MAP_SERVICES", std::nullopt};
  InProcessManager manager_;
  // Outlives the clients: their pool threads may still log into it until TearDown's ln_deinit.
  LogBook book_;
  std::vector<ln_client> clients_;
  std::vector<ln_service> services_;
};

// LN 2.9's provider hangs in this order (a logger of a service it already
// provides); here providers and callers that exist already learn of it.
TEST_F(ServiceLoggingTest, ExistingProvidersAndCallersLogToANewLogger) {
  ln_client provider = serving_client("provider");
  ln_client caller = connect_client("caller");
  ln_client logger = serving_client("logger");
  provide_echo(provider);
  ln_service echo = echo_of(caller);
  ASSERT_EQ(call(echo, "before"), 0);

  become_logger(logger);
  // The add_service_logger notifications travel asynchronously: call until both sides log.
  ASSERT_TRUE(call_until_logged(echo, "after", {"0 svc.echo caller", "1 svc.echo provider"}, 30s));
}

TEST_F(ServiceLoggingTest, ALoggerNeverHoldsUpTheCallsItLogs) {
  ln_client logger = serving_client("logger");
  ln_client provider = serving_client("provider");
  ln_client caller = connect_client("caller");
  LogBook& book = book_;
  become_logger(logger);
  provide_echo(provider);
  ln_service echo = echo_of(caller);
  {
    std::lock_guard<std::mutex> lock(book.mutex);
    book.hold = true;  // the logger handles nothing until released
  }
  for (int i = 0; i < 5; ++i) ASSERT_EQ(call(echo, "x"), 0) << "calls complete while the logger is stuck";
  {
    std::lock_guard<std::mutex> lock(book.mutex);
    book.hold = false;
  }
  book.changed.notify_all();
  ASSERT_TRUE(wait_until([&] { return book.copy().size() == 10; }, 30s)) << book.copy().size();
  // LN 2.9's data: request = u32 size | u16 32 | u32 client id | u32 request id | flat;
  // response = u32 size | i32 0 | flat.
  std::lock_guard<std::mutex> lock(book.mutex);
  for (std::size_t i = 0; i < book.lines.size(); ++i) {
    const std::string& d = book.data[i];
    uint32_t size = 0;
    std::memcpy(&size, d.data(), 4);
    EXPECT_EQ(size, d.size());
    if (book.lines[i][0] == '0') {
      EXPECT_EQ(d.size(), 14u + 5u);
      EXPECT_EQ(d.substr(4, 2), std::string("\x20\0", 2));
    } else {
      EXPECT_EQ(d.substr(4), std::string("\0\0\0\0\1\0\0\0x", 9));
    }
  }
}

TEST_F(ServiceLoggingTest, BadRegistrationsFailClearly) {
  ln_client logger = connect_client("logger");
  EXPECT_EQ(ln_register_as_service_logger(logger, "not.mine", "*"), -LNE_SVC_NOT_REGISTERED);
  EXPECT_NE(std::string(ln_get_error_message(logger)).find("not.mine"), std::string::npos);
  EXPECT_EQ(ln_register_as_service_logger(logger, nullptr, "*"), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_register_as_service_logger(logger, "x", nullptr), -LNE_INVALID_PARAMETER);
  provide(logger, "not.a.logger", "test/echo", kEchoSignature, echo_handler, nullptr);
  EXPECT_EQ(ln_register_as_service_logger(logger, "not.a.logger", "*"), -LNE_INVALID_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(logger)).find("ln/log_service"), std::string::npos)
      << ln_get_error_message(logger);
}

TEST_F(ServiceLoggingTest, LoggingResumesAfterAManagerRestart) {
  ln_client logger = serving_client("logger");
  ln_client provider = serving_client("provider");
  become_logger(logger);
  provide_echo(provider);
  manager_.restart();
  ln_client caller = nullptr;
  ASSERT_TRUE(wait_until([&] { return ln_init_to_manager(&caller, "caller", manager_.address().c_str()) == 0; }, 10s));
  clients_.push_back(caller);
  ln_service echo = echo_of(caller);
  // Once the provider and the logger are registered again, calls are logged again.
  EXPECT_TRUE(call_until_logged(echo, "again", {"1 svc.echo provider"}, 10s));
}

}  // namespace
