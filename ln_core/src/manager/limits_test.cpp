// The manager's limits (manager.hpp ManagerLimits, limits.hpp): a client
// that holds connections, memory or shared memory beyond them loses its
// connection or gets its request refused, with a reason in the log; the
// manager and everyone else keep working.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "manager/config.hpp"
#include "manager/limits.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"
#include "transport/shm_ring.hpp"

namespace ln::manager::testing {
namespace {

class LimitsTest : public ::testing::Test {
 protected:
  void start(const std::function<void(ManagerLimits&)>& adjust) {
    manager = std::make_unique<RunningManager>(dir, [&](ManagerOptions& o) { adjust(o.limits); });
  }

  std::unique_ptr<TestClient> registered(const std::string& name) {
    auto c = std::make_unique<TestClient>(manager->port());
    const Message r = c->hello(name);
    EXPECT_FALSE(r.is_error()) << r.error_text();
    return c;
  }

  // A registered client still gets answers.
  void expect_served() {
    auto c = registered("normal");
    EXPECT_FALSE(c->call("ping").is_error());
    EXPECT_FALSE(c->call("list_topics").is_error());
  }

  TempDir dir;
  const bool definitions_written = (write_test_definitions(dir), true);
  std::unique_ptr<RunningManager> manager;
};

TEST_F(LimitsTest, SilentConnectionsAreClosed) {
  start([](ManagerLimits& l) { l.pending_idle_timeout = 0.2; });
  TestClient silent(manager->port());
  EXPECT_TRUE(silent.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("sent nothing for 0.2 s without registering (pending_idle_timeout)"));
  expect_served();
}

TEST_F(LimitsTest, SlowSendersMustRegisterWithinTheHandshakeTimeout) {
  start([](ManagerLimits& l) {
    l.handshake_timeout = 0.5;
    l.pending_idle_timeout = 10;
  });
  TestClient slow(manager->port());
  const std::string hello =
      protocol::encode(slow.make_request("hello", [](Message& m) { m.set("program_name", "x"); }));
  bool closed = false;
  // One byte every 50 ms: active, but never done.
  for (std::size_t i = 0; i + 1 < hello.size() && i < 60 && !closed; ++i) {
    closed = !slow.send_raw(hello.substr(i, 1)) || slow.wait_closed(50ms);
  }
  EXPECT_TRUE(closed || slow.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("did not register within 0.5 s (handshake_timeout)")) << manager->log_text();
  expect_served();
}

TEST_F(LimitsTest, IdleConnectionsCannotCrowdOutClients) {
  start([](ManagerLimits& l) {
    l.max_clients = 64;
    l.max_pending_per_peer = 8;
  });
  // Far more idle connections than max_clients, all from 127.0.0.1: only
  // the newest 8 stay, and clients still get in.
  std::vector<std::unique_ptr<TestClient>> idle;
  for (int i = 0; i < 120; ++i) idle.push_back(std::make_unique<TestClient>(manager->port()));
  auto first = registered("first");
  for (int i = 0; i < 120; ++i) idle.push_back(std::make_unique<TestClient>(manager->port()));
  auto second = registered("second");
  EXPECT_TRUE(manager->wait_for_log("that did not register (max_pending_per_peer)"));
  std::size_t closed = 0;
  for (auto& c : idle) closed += c->wait_closed(100ms) ? 1 : 0;
  EXPECT_EQ(closed, 240u - 7);  // the 8th place went to "second" until it registered
  EXPECT_FALSE(first->call("ping").is_error());
  EXPECT_FALSE(second->call("ping").is_error());
  expect_served();
}

TEST_F(LimitsTest, UnregisteredConnectionsMaySendOnlyAHello) {
  start([](ManagerLimits&) {});
  TestClient attacker(manager->port());
  std::string header(4, '\0');
  const std::uint32_t announced = 1024 * 1024;  // within max_request_size
  for (int i = 0; i < 4; ++i) header[static_cast<std::size_t>(i)] = static_cast<char>(announced >> (8 * i));
  attacker.send_raw(header + std::string(100 * 1024, 'x'));
  EXPECT_TRUE(attacker.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("sent more than 65536 bytes without registering"));
  expect_served();
}

TEST_F(LimitsTest, PartialRequestsOfAllClientsShareOneBudget) {
  start([](ManagerLimits& l) { l.max_total_input = 3 * 1024 * 1024; });
  std::vector<std::unique_ptr<TestClient>> holders;
  std::string header(4, '\0');
  const std::uint32_t announced = 2 * 1024 * 1024;
  for (int i = 0; i < 4; ++i) header[static_cast<std::size_t>(i)] = static_cast<char>(announced >> (8 * i));
  for (int i = 0; i < 4; ++i) {
    holders.push_back(registered("holder"));
    holders.back()->send_raw(header + std::string(1024 * 1024 + static_cast<std::size_t>(i) * 65536, 'x'));
  }
  EXPECT_TRUE(manager->wait_for_log("(max_total_input); disconnected")) << manager->log_text();
  std::size_t closed = 0;
  for (auto& c : holders) closed += c->wait_closed(200ms) ? 1 : 0;
  EXPECT_GE(closed, 1u);
  EXPECT_LE(closed, 3u);
  expect_served();
}

TEST_F(LimitsTest, UnreadAnswersOfAllClientsShareOneBudget) {
  start([](ManagerLimits& l) {
    l.max_total_output = 1024 * 1024;
    l.max_output_queue = 64 * 1024 * 1024;
  });
  dir.write("md/mt/big", "double x\n" + std::string(100000, '#') + "\n");
  std::vector<std::unique_ptr<TestClient>> readers_that_do_not_read;
  for (int n = 0; n < 4; ++n) {
    auto c = registered("deaf");
    std::string requests;
    for (std::uint32_t id = 100; id < 200; ++id) {
      Message m = Message::request(id, "get_message_definition");
      m.set("name", "mt/big");
      requests += protocol::encode(m);
    }
    c->send_raw(requests);  // 100 answers of ~100 KB each, never read
    readers_that_do_not_read.push_back(std::move(c));
  }
  EXPECT_TRUE(manager->wait_for_log("max_total_output); disconnected")) << manager->log_text();
  expect_served();
}

// ------------------------------------------------------------- shared memory

TEST_F(LimitsTest, TopicSegmentsAreLimited) {
  start([](ManagerLimits& l) { l.max_topic_shm = 1024 * 1024; });
  dir.write("md/mt/kib", "uint8_t data[1024]\n");
  auto c = registered("user");
  // 4096 buffers of a 1 KiB packet: about 4 MiB.
  const Message refused = c->call("subscribe", [](Message& m) {
    m.set("topic", "big.topic").set("message_definition", "mt/kib").set("buffers", 4096);
    m.set("rate", -1.0).set("reliable", false);
  });
  ASSERT_TRUE(refused.is_error());
  EXPECT_EQ(refused.error_code(), LNE_SHM_IS_TOO_BIG);
  EXPECT_NE(refused.error_text().find("topic 'big.topic': 4096 buffers of 1 KiB packets (asked for by this subscriber) "
                                      "need a shared-memory segment of 4.3 MiB, more than the manager allows per "
                                      "topic (max_topic_shm 1 MiB); at most 947 buffers fit"),
            std::string::npos)
      << refused.error_text();
  // Nothing was left behind, and what fits is granted.
  EXPECT_TRUE(c->call("list_topics").get_list("names").empty());
  const Message publish = c->call("publish", [](Message& m) {
    m.set("topic", "big.topic").set("message_definition", "mt/kib").set("buffers", 100);
  });
  ASSERT_FALSE(publish.is_error()) << publish.error_text();
  EXPECT_EQ(publish.get_int("segment_limit"), 1024 * 1024);
  const Message too_many = c->call("publish", [](Message& m) {
    m.set("topic", "other.topic").set("message_definition", "mt/kib").set("buffers", 2000);
  });
  EXPECT_EQ(too_many.error_code(), LNE_SHM_IS_TOO_BIG);
  expect_served();
}

TEST_F(LimitsTest, APublishersTopicsShareOneLimit) {
  const std::uint64_t one_topic = transport::topic_segment_size(1024, 200);
  start([&](ManagerLimits& l) { l.max_client_shm = 2 * one_topic + one_topic / 2; });
  dir.write("md/mt/kib", "uint8_t data[1024]\n");
  auto publisher = registered("publisher");
  auto publish = [&](const std::string& topic) {
    return publisher->call(
        "publish", [&](Message& m) { m.set("topic", topic).set("message_definition", "mt/kib").set("buffers", 200); });
  };
  ASSERT_FALSE(publish("a").is_error());
  ASSERT_FALSE(publish("b").is_error());
  const Message third = publish("c");
  EXPECT_EQ(third.error_code(), LNE_SHM_IS_TOO_BIG);
  EXPECT_NE(third.error_text().find("of the other topics client 'publisher' publishes, that is more than the manager "
                                    "allows per client (max_client_shm"),
            std::string::npos)
      << third.error_text();
  // A subscriber that would make one of them grow past the client's limit
  // is refused too; one that fits is not.
  auto subscriber = registered("subscriber");
  auto subscribe = [&](int buffers) {
    return subscriber->call("subscribe", [&](Message& m) {
      m.set("topic", "a").set("message_definition", "mt/kib").set("buffers", buffers);
      m.set("rate", -1.0).set("reliable", false);
    });
  };
  EXPECT_EQ(subscribe(400).error_code(), LNE_SHM_IS_TOO_BIG);
  EXPECT_FALSE(subscribe(250).is_error());
  expect_served();
}

TEST_F(LimitsTest, TopicsSubscriptionsAndServicesOfAClientAreLimited) {
  start([](ManagerLimits& l) { l.max_ports_per_client = 3; });
  auto c = registered("collector");
  auto subscribe = [&](const std::string& topic) {
    return c->call("subscribe", [&](Message& m) {
      m.set("topic", topic).set("message_definition", "mt/point").set("buffers", 1).set("rate", -1.0);
      m.set("reliable", false);
    });
  };
  ASSERT_FALSE(c->call("publish", [](Message& m) {
                  m.set("topic", "p.a").set("message_definition", "mt/point").set("buffers", 1);
                }).is_error());
  const Message first = subscribe("s.a");
  ASSERT_FALSE(first.is_error()) << first.error_text();
  ASSERT_FALSE(c->call("register_service", [](Message& m) {
                  m.set("name", "svc.a").set("interface", "mt/add").set("signature", "");
                }).is_error());
  const Message fourth = subscribe("s.b");
  EXPECT_EQ(fourth.error_code(), LNE_REQUEST_FAILED);
  EXPECT_NE(fourth.error_text().find("client 'collector' has 3 topics it publishes, subscriptions and services, as "
                                     "many as the manager allows per client (max_ports_per_client)"),
            std::string::npos)
      << fourth.error_text();
  ASSERT_FALSE(c->call("unsubscribe", [&](Message& m) {
                  m.set("subscription_id", first.get_int("subscription_id"));
                }).is_error());
  EXPECT_FALSE(subscribe("s.b").is_error());
  expect_served();
}

// -------------------------------------------------------------- definitions

TEST_F(LimitsTest, StoredDefinitionsHaveAQuota) {
  start([](ManagerLimits& l) {
    l.max_stored_definitions = 3;
    l.max_definitions_per_client = 2;
  });
  auto put = [](TestClient& c, const std::string& name, const std::string& text) {
    return c.call("put_message_definition", [&](Message& m) { m.set("name", name).set("text", text); });
  };
  auto first = registered("first");
  EXPECT_FALSE(put(*first, "q/a", "double a\n").is_error());
  EXPECT_FALSE(put(*first, "q/a", "double a\n").is_error()) << "the same text again is answered from the cache";
  EXPECT_EQ(put(*first, "q/bad", "no_such_type x\n").error_code(), LNE_INVALID_PARAMETER);  // parsed: counts
  const Message third = put(*first, "q/c", "double c\n");
  EXPECT_EQ(third.error_code(), LNE_REQUEST_FAILED);
  EXPECT_NE(third.error_text().find("this client has put 2 new message definitions, as many as the manager allows per "
                                    "client (max_definitions_per_client)"),
            std::string::npos)
      << third.error_text();
  auto second = registered("second");
  EXPECT_FALSE(put(*second, "q/b", "double b\n").is_error());
  EXPECT_FALSE(put(*second, "q/c", "double c\n").is_error());
  auto third_client = registered("third");
  const Message fourth = put(*third_client, "q/d", "double d\n");
  EXPECT_NE(fourth.error_text().find("3 stored definitions, as many as the manager allows (max_stored_definitions)"),
            std::string::npos)
      << fourth.error_text();
  EXPECT_FALSE(dir.exists("gen/q/d"));
  // Replacing a stored file takes no more room.
  EXPECT_FALSE(put(*third_client, "q/c", "float c\n").is_error());
  expect_served();
}

TEST_F(LimitsTest, AStoredDefinitionChangedOnDiskIsNotAnsweredFromTheCache) {
  start([](ManagerLimits&) {});
  auto c = registered("writer");
  auto put = [&](const std::string& text) {
    return c->call("put_message_definition", [&](Message& m) { m.set("name", "cache/x").set("text", text); });
  };
  const Message stored = put("double x\n");
  ASSERT_FALSE(stored.is_error()) << stored.error_text();
  EXPECT_EQ(put("double x\n").get_string("hash"), stored.get_string("hash"));
  dir.write("gen/cache/x", "int8_t x\n");  // someone else changes the file
  const Message again = put("double x\n");
  ASSERT_FALSE(again.is_error()) << again.error_text();
  EXPECT_EQ(again.get_string("hash"), stored.get_string("hash"));
  EXPECT_EQ(c->call("get_message_definition", [](Message& m) { m.set("name", "cache/x"); }).get_int("message_size"), 8);
}

// ------------------------------------------------------------------ config

TEST(LimitKeys, ComeFromTheInstanceSectionWithClearErrors) {
  const LncSettings settings = read_lnc_text(
      "instance\nname: limited\nmax_topic_shm: 64M\nhandshake_timeout: 2.5\nmax_pending_per_peer: 16\n", "x.lnc", {});
  EXPECT_EQ(settings.limits.max_topic_shm, 64u << 20);
  EXPECT_EQ(settings.limits.handshake_timeout, 2.5);
  EXPECT_EQ(settings.limits.max_pending_per_peer, 16u);
  EXPECT_EQ(settings.limits.max_client_shm, ManagerLimits().max_client_shm);
  try {
    read_lnc_text("instance\nname: x\n\nmax_topic_shm: lots\n", "x.lnc", {});
    ADD_FAILURE() << "accepted 'lots'";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(),
                 "x.lnc:4: max_topic_shm: 'lots' is not a byte count (a whole number, optionally with K, M "
                 "or G)");
  }
  ManagerLimits limits;
  EXPECT_THROW(set_limit(limits, "handshake_timeout", "0"), std::invalid_argument);
  EXPECT_THROW(set_limit(limits, "max_clients", "0"), std::invalid_argument);
  EXPECT_THROW(set_limit(limits, "max_client_shm", "99999999999G"), std::invalid_argument);
  set_limit(limits, "max_output_queue", "512k");
  EXPECT_EQ(limits.max_output_queue, 512u * 1024);
  EXPECT_EQ(byte_text(256u << 20), "256 MiB");
  EXPECT_EQ(byte_text(1536), "1.5 KiB");
}

}  // namespace
}  // namespace ln::manager::testing
