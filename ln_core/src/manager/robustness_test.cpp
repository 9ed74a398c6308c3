// Bad input: whatever one client sends, only that client suffers; the
// manager and everyone else keep working.
#include <gtest/gtest.h>

#include <random>

#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::manager::testing {
namespace {

std::string frame_with_payload(const std::string& payload) {
  std::string frame(4, '\0');
  for (int i = 0; i < 4; ++i) frame[static_cast<std::size_t>(i)] = static_cast<char>(payload.size() >> (8 * i));
  return frame + payload;
}

class RobustnessTest : public ::testing::Test {
 protected:
  std::unique_ptr<TestClient> bystander() {
    auto c = std::make_unique<TestClient>(manager->port());
    EXPECT_FALSE(c->hello("bystander").is_error());
    EXPECT_FALSE(c->call("subscribe", [](Message& m) {
                    m.set("topic", "keep.me").set("message_definition", "mt/point").set("buffers", 1);
                    m.set("rate", -1.0).set("reliable", false);
                  }).is_error());
    return c;
  }

  // The bystander still works and still owns what it had.
  void expect_unharmed(TestClient& c) {
    EXPECT_FALSE(c.call("ping").is_error());
    const Message topics = c.call("list_topics");
    EXPECT_EQ(topics.get_list("names"), protocol::StringList{"keep.me"});
    EXPECT_EQ(topics.get_list("subscribers"), protocol::StringList{"1"});
  }

  TempDir dir;
  const bool definitions_written = (write_test_definitions(dir), true);
  std::unique_ptr<RunningManager> manager = std::make_unique<RunningManager>(dir);
};

TEST_F(RobustnessTest, RandomBytesDisconnectOnlyTheSender) {
  auto good = bystander();
  std::mt19937 random(12345);
  for (int round = 0; round < 20; ++round) {
    std::string bytes(1 + random() % 4096, '\0');
    for (char& b : bytes) b = static_cast<char>(random());
    // Half of the rounds announce a plausible size, so the decoder sees them.
    const std::string sent = round % 2 ? frame_with_payload(bytes) : bytes;
    TestClient attacker(manager->port());
    attacker.send_raw(sent);
    if (round % 2) {
      EXPECT_TRUE(attacker.wait_closed()) << "round " << round;
    } else {
      attacker.close();
    }
  }
  EXPECT_TRUE(manager->wait_for_log("malformed"));
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, TruncatedFramesAreHarmless) {
  auto good = bystander();
  const std::string frame = protocol::encode(Message::request(1, "ping"));
  {
    TestClient attacker(manager->port());
    attacker.send_raw(frame.substr(0, frame.size() / 2));
    EXPECT_TRUE(attacker.no_notification_within(20ms)) << "half a frame is not answered";
  }  // and then the connection drops mid-frame
  EXPECT_TRUE(manager->wait_for_log("closed the connection"));
  // A frame whose fields run past its announced end.
  TestClient short_frame(manager->port());
  std::string payload = frame.substr(4);
  short_frame.send_raw(frame_with_payload(payload.substr(0, payload.size() - 3)));
  EXPECT_TRUE(short_frame.wait_closed());
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, HugeAnnouncedLengthDisconnectsAtOnce) {
  auto good = bystander();
  TestClient attacker(manager->port());
  attacker.send_raw(std::string("\xff\xff\xff\x7f", 4));  // 2 GB
  EXPECT_TRUE(attacker.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("announced a 2147483647-byte message"));
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, OversizedRequestsDisconnectBeforeTheyAreComplete) {
  auto good = bystander();
  TestClient attacker(manager->port());
  ASSERT_FALSE(attacker.hello("attacker").is_error());  // before hello, 64 KiB are the limit (limits_test.cpp)
  const std::uint32_t announced = 32u * 1024 * 1024;    // within the wire's limit, beyond the manager's
  std::string header(4, '\0');
  for (int i = 0; i < 4; ++i) header[static_cast<std::size_t>(i)] = static_cast<char>(announced >> (8 * i));
  attacker.send_raw(header);
  const std::string chunk(1024 * 1024, 'x');
  for (int i = 0; i < 8 && attacker.send_raw(chunk); ++i) {
  }
  EXPECT_TRUE(attacker.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("sent a message larger than 4194304 bytes"));
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, UnknownMessageKindDisconnects) {
  auto good = bystander();
  TestClient attacker(manager->port());
  attacker.send_raw(frame_with_payload(std::string("\x09\x01\x00\x00\x00\x00\x00", 7)));
  EXPECT_TRUE(attacker.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("unknown message kind 9"));
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, UnknownMethodsAndWrongFieldsGetErrorResponses) {
  auto good = bystander();
  TestClient c(manager->port());
  ASSERT_FALSE(c.hello("confused").is_error());
  Message r = c.call("format_disk");
  EXPECT_EQ(r.error_code(), LNE_MANAGER_TOO_OLD);
  EXPECT_NE(r.error_text().find("'format_disk'"), std::string::npos);
  r = c.call(Message(protocol::Kind::Request, 77));  // no method at all
  EXPECT_EQ(r.error_code(), LNE_INVALID_PARAMETER);
  EXPECT_NE(r.error_text().find("missing field 'method'"), std::string::npos);
  r = c.call("publish", [](Message& m) {
    m.set("topic", protocol::StringList{"a"}).set("message_definition", "mt/point").set("buffers", 1);
  });
  EXPECT_EQ(r.error_code(), LNE_INVALID_PARAMETER);
  EXPECT_NE(r.error_text().find("'topic' is a list"), std::string::npos);
  r = c.call("unpublish", [](Message& m) { m.set("topic_id", -5); });
  EXPECT_EQ(r.error_code(), LNE_INVALID_PARAMETER);
  // Notifications and responses from clients are ignored, not fatal.
  c.send_raw(protocol::encode(Message::notification("publisher_gone")));
  c.send_raw(protocol::encode(Message(protocol::Kind::Response, 3)));
  EXPECT_FALSE(c.call("ping").is_error());
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, AClientThatNeverReadsIsDisconnected) {
  manager.reset();
  manager = std::make_unique<RunningManager>(dir, [](ManagerOptions& o) { o.limits.max_output_queue = 256 * 1024; });
  // A definition with a large text (comments), so each answer is ~100 KB.
  dir.write("md/mt/big", "double x\n" + std::string(100000, '#') + "\n");
  auto good = bystander();

  TestClient slow(manager->port());
  ASSERT_FALSE(slow.hello("slow").is_error());
  std::string requests;
  for (std::uint32_t id = 100; id < 400; ++id) {
    Message m = Message::request(id, "get_message_definition");
    m.set("name", "mt/big");
    requests += protocol::encode(m);
  }
  slow.send_raw(requests);  // 300 requests, ~30 MB of answers, none read
  EXPECT_TRUE(manager->wait_for_log("does not read what the manager sends")) << manager->log_text();
  EXPECT_TRUE(slow.wait_closed()) << manager->log_text();
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, ClientsBeyondTheLimitAreRefused) {
  manager.reset();
  manager = std::make_unique<RunningManager>(dir, [](ManagerOptions& o) { o.limits.max_clients = 2; });
  auto good = bystander();
  auto second = std::make_unique<TestClient>(manager->port());
  ASSERT_FALSE(second->hello("second").is_error());
  TestClient third(manager->port());
  EXPECT_TRUE(third.wait_closed());
  EXPECT_TRUE(manager->wait_for_log("(the limit)"));
  second.reset();
  EXPECT_TRUE(manager->wait_for_log("closed the connection"));
  TestClient fourth(manager->port());
  EXPECT_FALSE(fourth.hello("fourth").is_error());
  expect_unharmed(*good);
}

TEST_F(RobustnessTest, AClientLeavingBeforeItsAnswerIsHarmless) {
  auto good = bystander();
  for (int i = 0; i < 20; ++i) {
    TestClient c(manager->port());
    c.send_raw(protocol::encode(Message::request(1, "list_topics")));
    const linger abort_on_close{1, 0};  // RST instead of FIN: the manager's write fails
    ::setsockopt(c.fd(), SOL_SOCKET, SO_LINGER, &abort_on_close, sizeof abort_on_close);
  }
  expect_unharmed(*good);
}

}  // namespace
}  // namespace ln::manager::testing
