// ln.resource_event: connect_event, the initial sync, the events the
// registry emits, filters and disconnecting, through real connections to an
// in-process manager.
#include <gtest/gtest.h>

#include "manager/events.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

const std::string kSignature = "ln/resource_event: " + std::string(kResourceEventSignature);

std::string flat_strings(const std::vector<std::string>& texts) {
  std::string flat;
  for (const std::string& text : texts) {
    const auto size = static_cast<std::uint32_t>(text.size());
    for (int shift = 0; shift < 32; shift += 8) flat += static_cast<char>((size >> shift) & 0xff);
    flat += text;
  }
  return flat;
}

// "event name md client" of an `event` notification's flat data.
std::string describe(const Message& event) {
  std::string data = event.get_string("data"), out;
  for (int i = 0; i < 4; ++i) {
    std::uint32_t size = 0;
    for (int byte = 3; byte >= 0; --byte) size = size << 8 | static_cast<std::uint8_t>(data[byte]);
    out += (i ? " " : "") + data.substr(4, size);
    data.erase(0, 4 + size);
  }
  return out;
}

class ResourceEventTest : public ManagerWithClientsTest {
 protected:
  static Message connect(TestClient& c, const std::vector<std::string>& patterns,
                         const std::string& name = std::string(kResourceEventName),
                         const std::string& signature = kSignature) {
    return c.call("connect_event", [&](Message& m) {
      m.set("name", name).set("signature", signature).set("connect_data", flat_strings(patterns));
      m.set("handler", "ln.resource_event.watcher");
    });
  }

  // The events that arrive until initial_sync_done (or, with until_quiet,
  // until nothing came for a moment).
  static std::vector<std::string> events(TestClient& c, bool until_quiet = false) {
    std::vector<std::string> seen;
    for (;;) {
      auto m = c.next_notification(until_quiet ? 300ms : default_timeout);
      if (!m) {
        if (!until_quiet) ADD_FAILURE() << "no initial_sync_done";
        return seen;
      }
      if (m->method() != "event") continue;
      EXPECT_EQ(m->get_string("signature"), kSignature);
      EXPECT_EQ(m->get_string("handler"), "ln.resource_event.watcher");
      seen.push_back(describe(*m));
      if (!until_quiet && seen.back().rfind("initial_sync_done", 0) == 0) return seen;
    }
  }
};

TEST_F(ResourceEventTest, InitialSyncThenChangesAsTheyHappen) {
  auto provider = client("provider");
  provider->call("register_service", [](Message& m) {
    m.set("name", "svc.add").set("interface", "mt/add").set("signature", "x").set("group", "");
  });
  provider->call("publish",
                 [](Message& m) { m.set("topic", "t.point").set("message_definition", "mt/point").set("buffers", 1); });
  auto watcher = client("watcher");
  const Message connected = connect(*watcher, {"*", "*", "*", "*"});
  ASSERT_FALSE(connected.is_error()) << connected.error_text();
  EXPECT_GT(connected.get_int("event_connection_id"), 0);
  EXPECT_EQ(events(*watcher),
            (std::vector<std::string>{"service_new_provider svc.add mt/add provider",
                                      "topic_new_publisher t.point mt/point provider", "initial_sync_done   "}));

  auto other = client("other");
  const Message subscribed = other->call("subscribe", [](Message& m) {
    m.set("topic", "t.point").set("message_definition", "mt/point").set("buffers", 1).set("rate", -1.0);
    m.set("reliable", false).set("receive_address", "");
  });
  other->call("unsubscribe", [&](Message& m) { m.set("subscription_id", subscribed.get_int("subscription_id")); });
  provider->call("unregister_service", [](Message& m) { m.set("service_id", std::int64_t{2}); });
  provider->close();  // leaving unpublishes
  EXPECT_EQ(events(*watcher, true),
            (std::vector<std::string>{
                "topic_new_subscriber t.point mt/point other", "topic_del_subscriber t.point mt/point other",
                "service_del_provider svc.add mt/add provider", "topic_del_publisher t.point mt/point provider"}));
}

TEST_F(ResourceEventTest, FiltersAreFnmatchPatterns) {
  auto watcher = client("watcher");
  ASSERT_FALSE(connect(*watcher, {"topic_*", "a.[bc]?", "mt/*", "*"}).is_error());
  EXPECT_EQ(events(*watcher), (std::vector<std::string>{"initial_sync_done   "})) << "not filtered";
  auto publisher = client("publisher");
  for (const char* topic : {"a.b1", "a.c22", "a.d1", "a.c2"})
    publisher->call("publish",
                    [&](Message& m) { m.set("topic", topic).set("message_definition", "mt/point").set("buffers", 1); });
  publisher->call("register_service", [](Message& m) {
    m.set("name", "a.b2").set("interface", "mt/add").set("signature", "x").set("group", "");
  });
  EXPECT_EQ(events(*watcher, true), (std::vector<std::string>{"topic_new_publisher a.b1 mt/point publisher",
                                                              "topic_new_publisher a.c2 mt/point publisher"}));
}

TEST_F(ResourceEventTest, DisconnectedConnectionsHearNothing) {
  auto watcher = client("watcher");
  const Message connected = connect(*watcher, {"*", "*", "*", "*"});
  events(*watcher);
  const std::int64_t id = connected.get_int("event_connection_id");
  auto stranger = client("stranger");
  EXPECT_TRUE(stranger->call("disconnect_event", [&](Message& m) { m.set("event_connection_id", id); }).is_error())
      << "not the stranger's connection";
  EXPECT_FALSE(watcher->call("disconnect_event", [&](Message& m) { m.set("event_connection_id", id); }).is_error());
  stranger->call("publish",
                 [](Message& m) { m.set("topic", "t.x").set("message_definition", "mt/point").set("buffers", 1); });
  EXPECT_TRUE(events(*watcher, true).empty());
}

TEST_F(ResourceEventTest, BadConnectsAreRefusedClearly) {
  auto watcher = client("watcher");
  const Message unknown = connect(*watcher, {"*", "*", "*", "*"}, "ln.unknown");
  ASSERT_TRUE(unknown.is_error());
  EXPECT_EQ(unknown.error_code(), LNE_REQUEST_FAILED);
  EXPECT_NE(unknown.error_text().find("unknown event 'ln.unknown'"), std::string::npos) << unknown.error_text();
  const Message no_colon = connect(*watcher, {"*", "*", "*", "*"}, "ln.resource_event", "bad signature");
  EXPECT_EQ(no_colon.error_code(), LNE_INVALID_SIGNATURE);
  const Message other_layout = connect(*watcher, {"*", "*", "*", "*"}, "ln.resource_event", "x/y: int32_t 4 1");
  EXPECT_EQ(other_layout.error_code(), LNE_INVALID_SIGNATURE);
  const Message three = connect(*watcher, {"*", "*", "*"});
  EXPECT_EQ(three.error_code(), LNE_INVALID_PARAMETER);
  EXPECT_NE(three.error_text().find("client_pattern"), std::string::npos) << three.error_text();
  const Message truncated = watcher->call("connect_event", [](Message& m) {
    m.set("name", "ln.resource_event").set("signature", kSignature).set("handler", "h");
    m.set("connect_data", std::string("\xff\xff\xff\x7f", 4));
  });
  EXPECT_EQ(truncated.error_code(), LNE_INVALID_PARAMETER);
}

TEST_F(ResourceEventTest, FilterMatchingIsPythonsFnmatch) {
  const ResourceFilter all{"*", "*", "*", "*"};
  EXPECT_TRUE(filter_accepts(all, {"topic_new_publisher", "a/b.c", ".hidden", "x"}));
  const ResourceFilter literal_backslash{"*", "a\\*", "*", "*"};
  EXPECT_TRUE(filter_accepts(literal_backslash, {"e", "a\\xyz", "m", "c"}));
  EXPECT_FALSE(filter_accepts(literal_backslash, {"e", "a*", "m", "c"}));
  const ResourceFilter negated{"*", "[!a]*", "*", "*"};
  EXPECT_FALSE(filter_accepts(negated, {"e", "abc", "m", "c"}));
  EXPECT_TRUE(filter_accepts(negated, {"e", "Abc", "m", "c"})) << "case-sensitive";
  const ResourceFilter nothing{"", "", "", ""};
  EXPECT_FALSE(filter_accepts(nothing, {"e", "n", "m", "c"}));
  EXPECT_TRUE(filter_accepts(nothing, {kInitialSyncDone, "", "", ""}));
}

}  // namespace
}  // namespace ln::manager::testing
