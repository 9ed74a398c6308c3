// The client protocol of the manager, method by method, through real TCP
// connections to an in-process manager.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "ln/md/message_definition.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

using protocol::StringList;

class ManagerTest : public ::testing::Test {
 protected:
  std::unique_ptr<TestClient> client(const std::string& name, const std::function<void(Message&)>& fill = {}) {
    auto c = std::make_unique<TestClient>(manager.port());
    const Message response = c->hello(name, fill);
    EXPECT_FALSE(response.is_error()) << response.error_text();
    return c;
  }

  std::string hash_of(const std::string& name) {
    md::Library library(md::SearchPath::exactly({dir.path() + "/md"}));
    return library.load(name).hash;
  }

  static Message publish(TestClient& c, const std::string& topic, const std::string& md, std::int64_t buffers = 2) {
    return c.call("publish",
                  [&](Message& m) { m.set("topic", topic).set("message_definition", md).set("buffers", buffers); });
  }

  static Message subscribe(TestClient& c, const std::string& topic, const std::string& md,
                           const std::function<void(Message&)>& fill = {}) {
    return c.call("subscribe", [&](Message& m) {
      m.set("topic", topic).set("message_definition", md).set("buffers", 3).set("rate", -1.0);
      m.set("reliable", false).set("receive_address", "");
      if (fill) fill(m);
    });
  }

  static Message register_service(TestClient& c, const std::string& name, const std::string& interface,
                                  const std::string& signature) {
    return c.call("register_service", [&](Message& m) {
      m.set("name", name).set("interface", interface).set("signature", signature).set("group", "");
    });
  }

  TempDir dir;
  const bool definitions_written = (write_test_definitions(dir), true);  // before the manager starts
  RunningManager manager{dir};
};

#define EXPECT_ERROR(response, code, text)                                                         \
  do {                                                                                             \
    const Message& r_ = (response);                                                                \
    EXPECT_TRUE(r_.is_error());                                                                    \
    EXPECT_EQ(r_.error_code(), code) << r_.error_text();                                           \
    EXPECT_NE(r_.error_text().find(text), std::string::npos) << "error text: " << r_.error_text(); \
  } while (0)

// ------------------------------------------------------------------ hello

TEST_F(ManagerTest, HelloAssignsNameIdAndVersion) {
  TestClient c(manager.port());
  const Message r = c.hello("alpha");
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_EQ(r.get_string("client_name"), "alpha");
  EXPECT_GT(r.get_int("client_id"), 0);
  EXPECT_NE(r.get_string("manager_version").find("ln_core"), std::string::npos);
}

TEST_F(ManagerTest, DuplicateNamesGetACounterLikeLn) {
  TestClient a(manager.port()), b(manager.port()), c(manager.port());
  EXPECT_EQ(a.hello("dup").get_string("client_name"), "dup");
  EXPECT_EQ(b.hello("dup").get_string("client_name"), "dup 1");
  EXPECT_EQ(c.hello("dup").get_string("client_name"), "dup 2");
}

TEST_F(ManagerTest, ExactNameFailsWhenTaken) {
  TestClient a(manager.port()), b(manager.port()), c(manager.port());
  EXPECT_EQ(a.hello("dup").get_string("client_name"), "dup");
  EXPECT_ERROR(b.hello("dup", [](Message& m) { m.set("exact", true); }), LNE_CLNT_NAME_IN_USE, "already in use");
  // The refused connection may try again with a free name.
  EXPECT_EQ(b.hello("other", [](Message& m) { m.set("exact", true); }).get_string("client_name"), "other");
  EXPECT_EQ(c.hello("dup").get_string("client_name"), "dup 1");
}

TEST_F(ManagerTest, PreviousNameIsGrantedWhenFree) {
  TestClient a(manager.port()), b(manager.port()), c(manager.port());
  EXPECT_EQ(a.hello("dup").get_string("client_name"), "dup");
  EXPECT_EQ(b.hello("dup", [](Message& m) { m.set("previous_name", "dup 7"); }).get_string("client_name"), "dup 7");
  EXPECT_EQ(c.hello("dup", [](Message& m) { m.set("previous_name", "dup 7"); }).get_string("client_name"), "dup 1");
}

TEST_F(ManagerTest, HelloMustComeFirstAndOnlyOnce) {
  TestClient c(manager.port());
  EXPECT_ERROR(c.call("ping"), LNE_CLIENT_NOT_INITIALIZED, "hello first");
  EXPECT_ERROR(c.call("list_topics"), LNE_CLIENT_NOT_INITIALIZED, "hello first");
  EXPECT_FALSE(c.hello("late").is_error());
  EXPECT_ERROR(c.hello("again"), LNE_REGISTER_DENIED, "already registered");
  EXPECT_FALSE(c.call("ping").is_error());
}

TEST_F(ManagerTest, HelloRejectsUnusableNamesAndFields) {
  TestClient c(manager.port());
  EXPECT_ERROR(c.hello(""), LNE_INVALID_PARAMETER, "must not be empty");
  EXPECT_ERROR(c.hello("a\nb"), LNE_INVALID_PARAMETER, "control characters");
  EXPECT_ERROR(c.call("hello", [](Message& m) { m.set("program_name", 5); }), LNE_INVALID_PARAMETER,
               "'program_name' is an integer");
  EXPECT_ERROR(c.call("hello"), LNE_INVALID_PARAMETER, "missing field 'program_name'");
}

TEST_F(ManagerTest, GoodbyeAnswersReleasesTheNameAndCloses) {
  auto a = client("leaver");
  EXPECT_FALSE(a->call("goodbye").is_error());
  EXPECT_TRUE(a->wait_closed());
  TestClient b(manager.port());
  EXPECT_EQ(b.hello("leaver", [](Message& m) { m.set("exact", true); }).get_string("client_name"), "leaver");
}

// ---------------------------------------------------- message definitions

TEST_F(ManagerTest, GetMessageDefinitionReturnsTheBundleWithImports) {
  auto c = client("reader");
  const Message r = c->call("get_message_definition", [](Message& m) { m.set("name", "mt/with_import"); });
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_EQ(r.get_string("name"), "mt/with_import");
  EXPECT_EQ(r.get_string("hash"), hash_of("mt/with_import"));
  EXPECT_EQ(r.get_int("message_size"), 25);
  EXPECT_EQ(r.get_list("names"), (StringList{"mt/with_import", "mt/point"}));
  EXPECT_EQ(r.get_list("texts"),
            (StringList{"define point_t as \"point\"\npoint_t p\nuint8_t flag\n", "double x\ndouble y\ndouble z\n"}));
}

TEST_F(ManagerTest, GetMessageDefinitionChecksAPinnedHash) {
  auto c = client("reader");
  const std::string hash = hash_of("mt/point");
  EXPECT_FALSE(c->call("get_message_definition", [&](Message& m) { m.set("name", "mt/point|" + hash); }).is_error());
  EXPECT_ERROR(c->call("get_message_definition", [](Message& m) { m.set("name", "mt/point|0badc0de"); }),
               LNE_WRONG_MD_HASH, "expects 0badc0de");
}

TEST_F(ManagerTest, UnknownDefinitionErrorListsTheSearchDirectories) {
  auto c = client("reader");
  EXPECT_ERROR(c->call("get_message_definition", [](Message& m) { m.set("name", "mt/missing"); }), LNE_REQUEST_FAILED,
               dir.path() + "/md");
}

TEST_F(ManagerTest, DefinitionNamesCannotReachFilesByPath) {
  auto c = client("reader");
  const std::string outside = dir.write("outside", "double secret\n");
  for (const std::string& name : {outside, std::string("../outside"), std::string("mt/../../outside")})
    EXPECT_ERROR(c->call("get_message_definition", [&](Message& m) { m.set("name", name); }), LNE_INVALID_PARAMETER,
                 "not valid");
}

TEST_F(ManagerTest, PutMessageDefinitionStoresValidatedTextInTheGeneratedDir) {
  auto c = client("writer");
  const std::string text = "uint16_t width\nuint16_t height\n";
  const Message r =
      c->call("put_message_definition", [&](Message& m) { m.set("name", "gen_test/size").set("text", text); });
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_EQ(r.get_string("name"), "gen_test/size");
  EXPECT_EQ(r.get_string("hash").size(), 64u);
  std::ifstream stored(dir.path() + "/gen/gen_test/size");
  std::stringstream content;
  content << stored.rdbuf();
  EXPECT_EQ(content.str(), text);

  const Message got = c->call("get_message_definition", [](Message& m) { m.set("name", "gen_test/size"); });
  ASSERT_FALSE(got.is_error()) << got.error_text();
  EXPECT_EQ(got.get_string("hash"), r.get_string("hash"));
  EXPECT_EQ(got.get_int("message_size"), 4);
  // The same text again changes nothing; a new one replaces an unused definition.
  EXPECT_EQ(c->call("put_message_definition", [&](Message& m) { m.set("name", "gen_test/size").set("text", text); })
                .get_string("hash"),
            r.get_string("hash"));
  const Message replaced = c->call("put_message_definition",
                                   [&](Message& m) { m.set("name", "gen_test/size").set("text", "uint32_t width\n"); });
  ASSERT_FALSE(replaced.is_error()) << replaced.error_text();
  EXPECT_NE(replaced.get_string("hash"), r.get_string("hash"));
  EXPECT_EQ(
      c->call("get_message_definition", [](Message& m) { m.set("name", "gen_test/size"); }).get_int("message_size"), 4);
}

TEST_F(ManagerTest, PutMessageDefinitionRefusesBadTextAndNames) {
  auto c = client("writer");
  EXPECT_ERROR(c->call("put_message_definition",
                       [](Message& m) { m.set("name", "gen_test/bad").set("text", "no_such_type x\n"); }),
               LNE_INVALID_PARAMETER, "invalid message definition 'gen_test/bad'");
  EXPECT_FALSE(dir.exists("gen/gen_test/bad"));
  for (const char* name : {"../escape", "/tmp/escape", "a/../../escape", ""})
    EXPECT_ERROR(c->call("put_message_definition", [&](Message& m) { m.set("name", name).set("text", "double x\n"); }),
                 LNE_INVALID_PARAMETER, "message-definition name");
  EXPECT_FALSE(dir.exists("escape"));
}

TEST_F(ManagerTest, PutMessageDefinitionNeverShadowsAnExistingDefinition) {
  auto c = client("writer");
  EXPECT_ERROR(
      c->call("put_message_definition", [](Message& m) { m.set("name", "mt/point").set("text", "float x\n"); }),
      LNE_REQUEST_FAILED, "already exists");
  const Message same = c->call("put_message_definition", [](Message& m) {
    m.set("name", "mt/point").set("text", "double x\ndouble y\ndouble z\n");
  });
  ASSERT_FALSE(same.is_error()) << same.error_text();
  EXPECT_EQ(same.get_string("hash"), hash_of("mt/point"));
}

TEST_F(ManagerTest, PutMessageDefinitionKeepsDefinitionsThatTopicsUse) {
  auto c = client("writer");
  ASSERT_FALSE(c->call("put_message_definition", [](Message& m) {
                  m.set("name", "gen_test/live").set("text", "double a\n");
                }).is_error());
  ASSERT_FALSE(publish(*c, "live.topic", "gen_test/live").is_error());
  EXPECT_ERROR(
      c->call("put_message_definition", [](Message& m) { m.set("name", "gen_test/live").set("text", "float a\n"); }),
      LNE_REQUEST_FAILED, "in use");
}

TEST_F(ManagerTest, GetMessageDefinitionForTopic) {
  auto c = client("reader");
  EXPECT_ERROR(c->call("get_message_definition_for_topic", [](Message& m) { m.set("topic", "nobody.uses"); }),
               LNE_PORT_NOT_FOUND, "neither published nor subscribed");
  ASSERT_FALSE(subscribe(*c, "robot.point", "mt/point").is_error());
  const Message r = c->call("get_message_definition_for_topic", [](Message& m) { m.set("topic", "robot.point"); });
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_EQ(r.get_string("name"), "mt/point");
  EXPECT_EQ(r.get_string("hash"), hash_of("mt/point"));
  EXPECT_EQ(r.get_int("message_size"), 24);
}

// ----------------------------------------------------------------- topics

TEST_F(ManagerTest, PublishAnswersSizeHashAndTellsTheSubscriberCount) {
  auto c = client("publisher");
  const Message r = publish(*c, "robot.point", "mt/point|" + hash_of("mt/point"), 4);
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_GT(r.get_int("topic_id"), 0);
  EXPECT_EQ(r.get_int("message_size"), 24);
  EXPECT_EQ(r.get_string("hash"), hash_of("mt/point"));
  EXPECT_EQ(r.get_int("subscriber_buffers"), 0);
  const Message changed = c->wait_notification("subscribers_changed");
  EXPECT_EQ(changed.get_int("topic_id"), r.get_int("topic_id"));
  EXPECT_EQ(changed.get_int("subscribers"), 0);
}

TEST_F(ManagerTest, PublishRefusesWhatTopicsCannotCarry) {
  auto c = client("publisher");
  EXPECT_ERROR(publish(*c, "t.dyn", "mt/dyn"), LNE_INVALID_PARAMETER, "dynamic field 'values'");
  EXPECT_ERROR(publish(*c, "t.nested", "mt/nested_dyn"), LNE_INVALID_PARAMETER, "dynamic field 'label.text'");
  EXPECT_ERROR(publish(*c, "t.service", "mt/add"), LNE_INVALID_PARAMETER, "is a service definition");
  EXPECT_ERROR(publish(*c, "t.hash", "mt/point|ffff"), LNE_WRONG_MD_HASH, "hash");
  EXPECT_ERROR(publish(*c, "t.missing", "mt/missing"), LNE_REQUEST_FAILED, "not found");
  EXPECT_ERROR(publish(*c, "t.buffers", "mt/point", 0), LNE_INVALID_PARAMETER, "buffers");
  for (const char* name : {"", "a/b", ".a", "a.", "a..b", "a*b"})
    EXPECT_ERROR(publish(*c, name, "mt/point"), LNE_INVALID_PARAMETER, "topic name");
  const Message list = c->call("list_topics");
  EXPECT_TRUE(list.get_list("names").empty()) << "refused requests leave nothing behind";
}

TEST_F(ManagerTest, ASecondPublisherIsRefusedLikeLn) {
  auto a = client("first");
  auto b = client("second");
  ASSERT_FALSE(publish(*a, "robot.point", "mt/point").is_error());
  EXPECT_ERROR(publish(*b, "robot.point", "mt/point"), LNE_REQUEST_FAILED,
               "topic 'robot.point' already published by client 'first'");
  EXPECT_ERROR(publish(*a, "robot.point", "mt/point"), LNE_REQUEST_FAILED, "already published");
}

TEST_F(ManagerTest, DefinitionMismatchIsRefusedWithLnsText) {
  auto a = client("publisher");
  auto b = client("subscriber");
  ASSERT_FALSE(publish(*a, "probe.dup", "mt/point").is_error());
  EXPECT_ERROR(subscribe(*b, "probe.dup", "mt/other"), LNE_REQUEST_FAILED,
               "you requested message_definition 'mt/other' but topic 'probe.dup' uses 'mt/point'");
  ASSERT_FALSE(subscribe(*b, "early.sub", "mt/other").is_error());
  EXPECT_ERROR(publish(*a, "early.sub", "mt/point"), LNE_REQUEST_FAILED,
               "you requested message_definition 'mt/point' but topic 'early.sub' uses 'mt/other'");
  EXPECT_ERROR(subscribe(*b, "probe.dup", "mt/point|0000"), LNE_WRONG_MD_HASH, "0000");
}

TEST_F(ManagerTest, SubscribeBeforePublishThenPublisherAvailableOnReady) {
  auto sub = client("subscriber");
  auto pub =
      client("publisher", [](Message& m) { m.set("peer_socket", "@pub-socket").set("peer_address", "127.0.0.1:999"); });
  const Message s = subscribe(*sub, "robot.point", "mt/point");
  ASSERT_FALSE(s.is_error()) << s.error_text();
  EXPECT_EQ(s.get_int("message_size"), 24);
  EXPECT_EQ(s.get_string("message_definition"), "mt/point");
  EXPECT_EQ(s.get_string("hash"), hash_of("mt/point"));
  EXPECT_FALSE(s.has("publisher"));

  const Message p = publish(*pub, "robot.point", "mt/point");
  ASSERT_FALSE(p.is_error()) << p.error_text();
  EXPECT_EQ(p.get_int("topic_id"), s.get_int("topic_id"));
  EXPECT_EQ(p.get_int("subscriber_buffers"), 3);
  const Message changed = pub->wait_notification("subscribers_changed");
  EXPECT_EQ(changed.get_int("subscribers"), 1);
  EXPECT_EQ(changed.get_int("subscriber_buffers"), 3);
  EXPECT_TRUE(changed.get_list("remote").empty());
  EXPECT_EQ(changed.get_list("local"), (StringList{std::to_string(s.get_int("subscription_id"))}));
  EXPECT_TRUE(sub->no_notification_within(50ms)) << "nobody is told before publisher_ready";

  ASSERT_FALSE(pub->call("publisher_ready",
                         [&](Message& m) { m.set("topic_id", p.get_int("topic_id")).set("segment_generation", 1); })
                   .is_error());
  const Message available = sub->wait_notification("publisher_available");
  EXPECT_EQ(available.get_int("subscription_id"), s.get_int("subscription_id"));
  EXPECT_EQ(available.get_int("topic_id"), s.get_int("topic_id"));
  EXPECT_EQ(available.get_string("publisher"), "publisher");
  EXPECT_EQ(available.get_string("host_id"), "host-a");
  EXPECT_EQ(available.get_string("peer_socket"), "@pub-socket");
  EXPECT_EQ(available.get_string("peer_address"), "127.0.0.1:999");
  EXPECT_EQ(available.get_int("segment_generation"), 1);

  // A later subscriber finds the publisher in its response.
  auto late = client("late");
  const Message l = subscribe(*late, "robot.point", "");
  ASSERT_FALSE(l.is_error()) << l.error_text();
  EXPECT_EQ(l.get_string("message_definition"), "mt/point");
  EXPECT_EQ(l.get_string("publisher"), "publisher");
  EXPECT_EQ(l.get_int("segment_generation"), 1);
  EXPECT_EQ(pub->wait_notification("subscribers_changed").get_int("subscribers"), 2);
}

TEST_F(ManagerTest, RemoteSubscribersAreListedForThePublisher) {
  auto pub = client("publisher");
  auto local = client("local");
  auto remote = client("remote", [](Message& m) { m.set("host_id", "host-b"); });
  const Message p = publish(*pub, "robot.point", "mt/point");
  EXPECT_TRUE(pub->wait_notification("subscribers_changed").get_list("local").empty());
  const Message l = subscribe(*local, "robot.point", "mt/point");
  ASSERT_FALSE(l.is_error()) << l.error_text();
  const std::string local_id = std::to_string(l.get_int("subscription_id"));
  const Message first = pub->wait_notification("subscribers_changed");
  EXPECT_TRUE(first.get_list("remote").empty());
  EXPECT_EQ(first.get_list("local"), StringList{local_id});
  const Message s = subscribe(*remote, "robot.point", "mt/point", [](Message& m) {
    m.set("rate", 10.0).set("reliable", true).set("receive_address", "10.0.0.2:4000").set("buffers", 8);
  });
  ASSERT_FALSE(s.is_error()) << s.error_text();
  const Message changed = pub->wait_notification("subscribers_changed");
  EXPECT_EQ(changed.get_int("subscribers"), 2);
  EXPECT_EQ(changed.get_int("subscriber_buffers"), 8);
  EXPECT_EQ(changed.get_list("remote"),
            (StringList{std::to_string(s.get_int("subscription_id")) + " 10 1 10.0.0.2:4000"}));
  EXPECT_EQ(changed.get_list("local"), StringList{local_id});  // the remote one reads no segment
}

TEST_F(ManagerTest, SubscribeChecksItsParameters) {
  auto c = client("subscriber");
  EXPECT_ERROR(subscribe(*c, "unknown.topic", ""), LNE_PORT_NOT_FOUND, "not known yet");
  EXPECT_ERROR(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("rate", 0.0); }), LNE_INVALID_PARAMETER, "rate");
  EXPECT_ERROR(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("rate", -4.0); }), LNE_INVALID_PARAMETER, "rate");
  EXPECT_ERROR(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("buffers", 0); }), LNE_INVALID_PARAMETER,
               "buffers");
  EXPECT_ERROR(subscribe(*c, "t", "mt/dyn"), LNE_INVALID_PARAMETER, "dynamic");
  EXPECT_ERROR(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("reliable", "yes"); }), LNE_INVALID_PARAMETER,
               "'reliable' is a string");
  EXPECT_FALSE(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("rate", -2.0); }).is_error());
  EXPECT_FALSE(subscribe(*c, "t", "mt/point", [](Message& m) { m.set("rate", -3.0); }).is_error());
}

TEST_F(ManagerTest, UnsubscribeAndUnpublishNotifyAndForgetTheTopic) {
  auto pub = client("publisher");
  auto sub = client("subscriber");
  const Message p = publish(*pub, "robot.point", "mt/point");
  pub->wait_notification("subscribers_changed");
  ASSERT_FALSE(pub->call("publisher_ready",
                         [&](Message& m) { m.set("topic_id", p.get_int("topic_id")).set("segment_generation", 0); })
                   .is_error());
  const Message s = subscribe(*sub, "robot.point", "mt/point");
  EXPECT_EQ(pub->wait_notification("subscribers_changed").get_int("subscribers"), 1);

  EXPECT_ERROR(sub->call("unsubscribe", [](Message& m) { m.set("subscription_id", 999999); }), LNE_PORT_NOT_FOUND,
               "no subscription");
  EXPECT_ERROR(pub->call("unsubscribe", [&](Message& m) { m.set("subscription_id", s.get_int("subscription_id")); }),
               LNE_PORT_NOT_FOUND, "no subscription");
  ASSERT_FALSE(
      sub->call("unsubscribe", [&](Message& m) { m.set("subscription_id", s.get_int("subscription_id")); }).is_error());
  EXPECT_EQ(pub->wait_notification("subscribers_changed").get_int("subscribers"), 0);

  const Message s2 = subscribe(*sub, "robot.point", "mt/point");
  pub->wait_notification("subscribers_changed");
  EXPECT_ERROR(sub->call("unpublish", [&](Message& m) { m.set("topic_id", p.get_int("topic_id")); }),
               LNE_PORT_NOT_FOUND, "do not publish");
  ASSERT_FALSE(pub->call("unpublish", [&](Message& m) { m.set("topic_id", p.get_int("topic_id")); }).is_error());
  const Message gone = sub->wait_notification("publisher_gone");
  EXPECT_EQ(gone.get_int("subscription_id"), s2.get_int("subscription_id"));
  EXPECT_EQ(gone.get_int("topic_id"), p.get_int("topic_id"));

  ASSERT_FALSE(sub->call("unsubscribe", [&](Message& m) { m.set("subscription_id", s2.get_int("subscription_id")); })
                   .is_error());
  EXPECT_TRUE(sub->call("list_topics").get_list("names").empty());
  // A forgotten topic may come back with another definition.
  EXPECT_FALSE(publish(*pub, "robot.point", "mt/other").is_error());
}

TEST_F(ManagerTest, PublisherReadyOnlyForOwnTopics) {
  auto pub = client("publisher");
  auto other = client("other");
  const Message p = publish(*pub, "robot.point", "mt/point");
  EXPECT_ERROR(other->call("publisher_ready",
                           [&](Message& m) { m.set("topic_id", p.get_int("topic_id")).set("segment_generation", 1); }),
               LNE_PORT_NOT_FOUND, "do not publish");
  EXPECT_ERROR(pub->call("publisher_ready",
                         [&](Message& m) { m.set("topic_id", p.get_int("topic_id")).set("segment_generation", -1); }),
               LNE_INVALID_PARAMETER, "segment_generation");
}

TEST_F(ManagerTest, DisconnectReleasesEverythingAndNotifiesTheOthers) {
  auto pub = client("publisher");
  auto sub = client("subscriber");
  auto watcher = client("watcher");
  const Message p = publish(*pub, "robot.point", "mt/point");
  ASSERT_FALSE(pub->call("publisher_ready",
                         [&](Message& m) { m.set("topic_id", p.get_int("topic_id")).set("segment_generation", 1); })
                   .is_error());
  ASSERT_FALSE(subscribe(*sub, "robot.point", "mt/point").is_error());
  ASSERT_FALSE(subscribe(*pub, "other.topic", "mt/other").is_error());
  ASSERT_FALSE(publish(*sub, "other.topic", "mt/other").is_error());
  ASSERT_FALSE(register_service(*pub, "pub.service", "mt/add", "sig").is_error());
  watcher->wait_notification("service_available");

  pub->close();  // the connection drops without goodbye
  EXPECT_EQ(sub->wait_notification("publisher_gone").get_int("topic_id"), p.get_int("topic_id"));
  EXPECT_EQ(sub->wait_notification("subscribers_changed").get_int("subscribers"), 0);
  EXPECT_EQ(watcher->wait_notification("service_gone").get_string("name"), "pub.service");

  const Message topics = watcher->call("list_topics");
  EXPECT_EQ(topics.get_list("names"), (StringList{"robot.point", "other.topic"}));
  EXPECT_EQ(topics.get_list("publishers"), (StringList{"", "subscriber"}));
  EXPECT_TRUE(watcher->call("list_services").get_list("names").empty());
  TestClient again(manager.port());
  EXPECT_EQ(again.hello("publisher", [](Message& m) { m.set("exact", true); }).get_string("client_name"), "publisher");
}

// --------------------------------------------------------------- services

TEST_F(ManagerTest, RegisterServiceIsAnnouncedAndUnique) {
  auto provider = client("provider");
  auto other = client("other");
  const Message r = register_service(*provider, "calc.add", "mt/add", "int32_t 4 1,int32_t 4 1|int32_t 4 1");
  ASSERT_FALSE(r.is_error()) << r.error_text();
  EXPECT_GT(r.get_int("service_id"), 0);
  const Message available = other->wait_notification("service_available");
  EXPECT_EQ(available.get_string("name"), "calc.add");
  EXPECT_EQ(available.get_string("provider"), "provider");
  EXPECT_ERROR(register_service(*other, "calc.add", "mt/add", "x"), LNE_SVC_ALREADY_REGISTERED,
               "already provided by client 'provider'");
  EXPECT_ERROR(register_service(*other, "calc/add", "mt/add", "x"), LNE_INVALID_PARAMETER, "'/'");
  EXPECT_ERROR(register_service(*other, "calc.sub", "../add", "x"), LNE_INVALID_PARAMETER, "not valid");

  EXPECT_ERROR(other->call("unregister_service", [&](Message& m) { m.set("service_id", r.get_int("service_id")); }),
               LNE_SVC_NOT_REGISTERED, "no service");
  ASSERT_FALSE(provider->call("unregister_service", [&](Message& m) { m.set("service_id", r.get_int("service_id")); })
                   .is_error());
  EXPECT_EQ(other->wait_notification("service_gone").get_string("name"), "calc.add");
  EXPECT_FALSE(register_service(*other, "calc.add", "mt/add", "x").is_error());
}

TEST_F(ManagerTest, LookupServiceChecksInterfaceAndSignature) {
  auto provider =
      client("provider", [](Message& m) { m.set("peer_socket", "@svc").set("peer_address", "127.0.0.1:5"); });
  auto caller = client("caller");
  const std::string signature = "int32_t 4 1,int32_t 4 1|int32_t 4 1";
  const Message r = register_service(*provider, "calc.add", "mt/add|" + hash_of("mt/add"), signature);
  ASSERT_FALSE(r.is_error());
  const Message found = caller->call("lookup_service", [&](Message& m) {
    m.set("name", "calc.add").set("interface", "mt/add").set("signature", signature);
  });
  ASSERT_FALSE(found.is_error()) << found.error_text();
  EXPECT_EQ(found.get_string("provider"), "provider");
  EXPECT_EQ(found.get_string("signature"), signature);
  EXPECT_EQ(found.get_string("host_id"), "host-a");
  EXPECT_EQ(found.get_string("peer_socket"), "@svc");
  EXPECT_EQ(found.get_string("peer_address"), "127.0.0.1:5");
  EXPECT_EQ(found.get_int("service_id"), r.get_int("service_id"));
  EXPECT_FALSE(caller
                   ->call("lookup_service",
                          [](Message& m) { m.set("name", "calc.add").set("interface", "").set("signature", ""); })
                   .is_error());

  EXPECT_ERROR(
      caller->call("lookup_service",
                   [&](Message& m) { m.set("name", "calc.nothing").set("interface", "").set("signature", ""); }),
      LNE_NO_PROVIDER_FOUND, "no client provides service 'calc.nothing'");
  EXPECT_ERROR(caller->call("lookup_service",
                            [&](Message& m) {
                              m.set("name", "calc.add").set("interface", "mt/echo").set("signature", signature);
                            }),
               LNE_REQUEST_FAILED, "has interface 'mt/add', not the requested 'mt/echo'");
  EXPECT_ERROR(caller->call("lookup_service",
                            [&](Message& m) {
                              m.set("name", "calc.add").set("interface", "mt/add|abc").set("signature", signature);
                            }),
               LNE_WRONG_MD_HASH, "abc");
  EXPECT_ERROR(caller->call("lookup_service",
                            [&](Message& m) {
                              m.set("name", "calc.add").set("interface", "mt/add").set("signature", "int32_t 4 1|");
                            }),
               LNE_REQUEST_FAILED, "different versions");
}

TEST_F(ManagerTest, ServiceSignaturesComeFromTheDefinition) {
  auto provider = client("provider");
  const Message sig = provider->call("get_service_signature", [](Message& m) { m.set("interface", "mt/add"); });
  ASSERT_FALSE(sig.is_error()) << sig.error_text();
  EXPECT_EQ(sig.get_string("signature"), "int32_t 4 1,int32_t 4 1|int32_t 4 1");
  EXPECT_EQ(sig.get_string("definition"), "service\nrequest\nint32_t a\nint32_t b\nresponse\nint32_t sum\n");
  EXPECT_EQ(sig.get_list("names"), (StringList{"mt/add"}));
  EXPECT_EQ(provider->call("get_service_signature", [](Message& m) { m.set("interface", "mt/echo"); })
                .get_string("signature"),
            "uint32_t 4 1,char* 1 1|uint32_t 4 1,char* 1 1");
  EXPECT_ERROR(provider->call("get_service_signature", [](Message& m) { m.set("interface", "mt/none"); }),
               LNE_REQUEST_FAILED, "not found");

  ASSERT_FALSE(register_service(*provider, "calc.add", "mt/add", sig.get_string("signature")).is_error());
  const Message for_service =
      provider->call("get_service_signature_for_service", [](Message& m) { m.set("name", "calc.add"); });
  ASSERT_FALSE(for_service.is_error()) << for_service.error_text();
  EXPECT_EQ(for_service.get_string("interface"), "mt/add");
  EXPECT_EQ(for_service.get_string("signature"), sig.get_string("signature"));
  EXPECT_EQ(for_service.get_string("definition"), sig.get_string("definition"));
  EXPECT_ERROR(provider->call("get_service_signature_for_service", [](Message& m) { m.set("name", "calc.none"); }),
               LNE_NO_PROVIDER_FOUND, "calc.none");
}

TEST_F(ManagerTest, FindServicesWithInterface) {
  auto provider = client("provider");
  ASSERT_FALSE(register_service(*provider, "b.add", "mt/add", "s").is_error());
  ASSERT_FALSE(register_service(*provider, "a.add", "mt/add|123", "s").is_error());
  ASSERT_FALSE(register_service(*provider, "c.echo", "mt/echo", "s").is_error());
  EXPECT_EQ(provider->call("find_services_with_interface", [](Message& m) { m.set("interface", "mt/add"); })
                .get_list("services"),
            (StringList{"a.add", "b.add"}));
  EXPECT_TRUE(provider->call("find_services_with_interface", [](Message& m) { m.set("interface", "mt/none"); })
                  .get_list("services")
                  .empty());
}

// ---------------------------------------------------------- introspection

TEST_F(ManagerTest, IntrospectionListsClientsTopicsAndServices) {
  auto a = client("alpha", [](Message& m) { m.set("pid", 42).set("host_name", "robot"); });
  auto b = client("beta");
  ASSERT_FALSE(publish(*a, "a.topic", "mt/point").is_error());
  ASSERT_FALSE(subscribe(*b, "a.topic", "mt/point").is_error());
  ASSERT_FALSE(subscribe(*b, "b.topic", "mt/other").is_error());
  ASSERT_FALSE(register_service(*a, "a.service", "mt/add", "sig").is_error());

  const Message clients = b->call("list_clients");
  EXPECT_EQ(clients.get_list("names"), (StringList{"alpha", "beta"}));
  EXPECT_EQ(clients.get_list("pids"), (StringList{"42", "1234"}));
  EXPECT_EQ(clients.get_list("hosts"), (StringList{"robot", "testhost"}));
  EXPECT_EQ(clients.get_list("host_ids"), (StringList{"host-a", "host-a"}));
  EXPECT_EQ(clients.get_list("published"), (StringList{"a.topic", ""}));
  EXPECT_EQ(clients.get_list("subscribed"), (StringList{"", "a.topic,b.topic"}));
  EXPECT_EQ(clients.get_list("services"), (StringList{"a.service", ""}));
  EXPECT_EQ(clients.get_list("ids").size(), 2u);

  const Message topics = b->call("list_topics");
  EXPECT_EQ(topics.get_list("names"), (StringList{"a.topic", "b.topic"}));
  EXPECT_EQ(topics.get_list("definitions"), (StringList{"mt/point", "mt/other"}));
  EXPECT_EQ(topics.get_list("hashes"), (StringList{hash_of("mt/point"), hash_of("mt/other")}));
  EXPECT_EQ(topics.get_list("message_sizes"), (StringList{"24", "4"}));
  EXPECT_EQ(topics.get_list("publishers"), (StringList{"alpha", ""}));
  EXPECT_EQ(topics.get_list("subscribers"), (StringList{"1", "1"}));

  const Message services = b->call("list_services");
  EXPECT_EQ(services.get_list("names"), (StringList{"a.service"}));
  EXPECT_EQ(services.get_list("interfaces"), (StringList{"mt/add"}));
  EXPECT_EQ(services.get_list("signatures"), (StringList{"sig"}));
  EXPECT_EQ(services.get_list("providers"), (StringList{"alpha"}));
  EXPECT_EQ(services.get_list("groups"), (StringList{""}));
}

TEST_F(ManagerTest, StopIsIdempotentAndThreadSafe) {
  auto c = client("anyone");
  std::thread other([&] { manager.manager().stop(); });
  manager.manager().stop();
  other.join();
  manager.manager().stop();
  EXPECT_TRUE(c->wait_closed());
}

}  // namespace
}  // namespace ln::manager::testing
