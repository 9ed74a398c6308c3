// The logger_* methods of the manager at the protocol level (methods.hpp):
// how a recorder tap shows to the publisher, what is refused, and a
// publisher the manager cannot reach (another host). Recording itself is
// tested through the client API (src/client/loggers_test.cpp).
#include <gtest/gtest.h>

#include "manager/recorder.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

using protocol::StringList;

class LoggerProtocolTest : public ManagerWithClientsTest {
 protected:
  static Message enable(TestClient& c, const std::string& name, StringList topics, StringList sizes,
                        StringList divisors) {
    return c.call("logger_enable", [&](Message& m) {
      m.set("name", name).set("topics", topics).set("log_sizes", sizes).set("divisors", divisors);
      m.set("only_ts", false);
    });
  }
};

TEST_F(LoggerProtocolTest, ATapIsListedToThePublisherButNotCountedAsSubscriber) {
  auto publisher = client("publisher");
  ASSERT_FALSE(
      publisher
          ->call("publish",
                 [](Message& m) { m.set("topic", "lg.tap").set("message_definition", "mt/point").set("buffers", 1); })
          .is_error());
  const Message first = publisher->wait_notification("subscribers_changed");
  EXPECT_EQ(first.get_list("local").size(), 0u);

  auto user = client("user");
  // No publisher_ready yet: nothing to attach to, so enable answers at once.
  const Message enabled = enable(*user, "L", {"lg.tap"}, {"10"}, {"1"});
  ASSERT_FALSE(enabled.is_error()) << enabled.error_text();
  const Message told = publisher->wait_notification("subscribers_changed");
  EXPECT_EQ(told.get_int("subscribers"), 0);
  ASSERT_EQ(told.get_list("local").size(), 1u);
  // The window of a 24-byte topic, so the recorder can poll.
  EXPECT_EQ(told.get_int("subscriber_buffers"), tap_slots(24));

  const Message topics = user->call("list_topics");
  EXPECT_EQ(topics.get_list("subscribers"), StringList{"0"});
  ASSERT_FALSE(user->call("logger_disable", [](Message& m) { m.set("name", "L"); }).is_error());
  const Message untold = publisher->wait_notification("subscribers_changed");
  EXPECT_EQ(untold.get_list("local").size(), 0u);
  EXPECT_EQ(untold.get_int("subscriber_buffers"), 0);
}

TEST_F(LoggerProtocolTest, APublisherTheManagerCannotReachIsAClearError) {
  // The test client's peer socket does not exist: like a publisher on another host.
  auto publisher = client("far_publisher");
  const Message published = publisher->call(
      "publish", [](Message& m) { m.set("topic", "lg.far").set("message_definition", "mt/point").set("buffers", 1); });
  ASSERT_FALSE(published.is_error());
  ASSERT_FALSE(
      publisher
          ->call("publisher_ready",
                 [&](Message& m) { m.set("topic_id", published.get_int("topic_id")).set("segment_generation", 0); })
          .is_error());
  auto user = client("user");
  const Message enabled = enable(*user, "far", {"lg.far", "lg.unpublished"}, {"10", "10"}, {"1", "1"});
  ASSERT_TRUE(enabled.is_error());
  EXPECT_EQ(enabled.error_code(), LNE_REQUEST_FAILED);
  EXPECT_NE(enabled.error_text().find("records topics of publishers on its own host"), std::string::npos)
      << enabled.error_text();
  EXPECT_NE(enabled.error_text().find("lg.far"), std::string::npos);
  // The logger exists and lists both topics; nothing was recorded.
  const Message download = user->call("logger_download", [](Message& m) { m.set("name", "far"); });
  ASSERT_FALSE(download.is_error()) << download.error_text();
  EXPECT_EQ(download.get_list("topics"), (StringList{"lg.far", "lg.unpublished"}));
  EXPECT_EQ(download.get_list("n_samples"), (StringList{"0", "0"}));
  EXPECT_EQ(download.get_list("md_names"), (StringList{"mt/point", ""}));
}

TEST_F(LoggerProtocolTest, BadRequestsAreRefusedWithTheReason) {
  TestClient stranger(manager.port());
  const Message early = stranger.call("logger_disable", [](Message& m) { m.set("name", "x"); });
  EXPECT_EQ(early.error_code(), LNE_CLIENT_NOT_INITIALIZED);

  auto user = client("user");
  auto refused = [&](StringList topics, StringList sizes, StringList divisors, int code, const std::string& text) {
    const Message answer = enable(*user, "bad", topics, sizes, divisors);
    EXPECT_EQ(answer.error_code(), code) << answer.error_text();
    EXPECT_NE(answer.error_text().find(text), std::string::npos) << answer.error_text();
  };
  refused({"a"}, {}, {"1"}, LNE_INVALID_PARAMETER, "as many log_sizes and divisors");
  refused({}, {}, {}, LNE_NO_LOGGER_TOPICS, "no topics");
  refused({"a"}, {"0"}, {"1"}, LNE_INVALID_PARAMETER, "at least 1 sample");
  refused({"a"}, {"-3"}, {"1"}, LNE_INVALID_PARAMETER, "not a number in range");
  refused({"a"}, {"5"}, {"x"}, LNE_INVALID_PARAMETER, "the divisor of topic 'a'");
  refused({""}, {"5"}, {"1"}, LNE_INVALID_PARAMETER, "topic");
  refused({"a"}, {"18446744073709551615"}, {"1"}, LNE_NO_MEM, "do not fit");
  const Message unnamed = user->call("logger_enable", [](Message& m) {
    m.set("name", "").set("topics", StringList{"a"}).set("log_sizes", StringList{"1"});
    m.set("divisors", StringList{"1"});
  });
  EXPECT_EQ(unnamed.error_code(), LNE_INVALID_PARAMETER);

  const Message unknown = user->call("logger_download", [](Message& m) { m.set("name", "nobody"); });
  EXPECT_EQ(unknown.error_code(), LNE_REQUEST_FAILED);
  const Message stale =
      user->call("logger_download_data", [](Message& m) { m.set("download", 99).set("topic", 0).set("offset", 0); });
  EXPECT_EQ(stale.error_code(), LNE_INVALID_PARAMETER);
  ASSERT_FALSE(enable(*user, "ok", {"lg.ok"}, {"3"}, {"1"}).is_error());
  const Message view = user->call("logger_download", [](Message& m) { m.set("name", "ok"); });
  const Message beyond = user->call("logger_download_data", [&](Message& m) {
    m.set("download", view.get_int("download")).set("topic", 1).set("offset", 0);
  });
  EXPECT_EQ(beyond.error_code(), LNE_INVALID_PARAMETER);
  const Message save = user->call("logger_manager_save", [&](Message& m) {
    m.set("name", "ok").set("filename", dir.path() + "/x.dat").set("format", "auto");
  });
  EXPECT_EQ(save.error_code(), LNE_REQUEST_FAILED);
  EXPECT_NE(save.error_text().find("cannot tell the format"), std::string::npos);
}

}  // namespace
}  // namespace ln::manager::testing
