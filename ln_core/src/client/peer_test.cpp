#include "client/peer.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <future>

#include "client/c_api.hpp"
#include "client/failure.hpp"

namespace ln::clientlib {
namespace {

using namespace std::chrono_literals;

class PeerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_.add_method("echo", [](PeerRequest& request) {
      request.connection->send(protocol::Message::response_to(request.message)
                                   .set("text", request.message.get_string("text"))
                                   .set("uid", static_cast<std::int64_t>(request.connection->peer_uid())));
    });
    server_.add_method("adopt", [this](PeerRequest& request) {
      request.connection->send(protocol::Message::response_to(request.message));
      adopted_.set_value(server_.take_over(request.connection));
    });
    server_.start(new_peer_socket_name());
    loop_.start("peer_test");
  }
  void TearDown() override {
    loop_.post([this] { server_.stop(); });
    loop_.stop();
  }

  Reply call(protocol::Message request) {
    std::promise<Reply> answered;
    loop_.post([&] {
      call_peer(loop_, server_.socket_name(), std::move(request), 2000ms,
                [&](Reply& reply, UniqueFd) { answered.set_value(std::move(reply)); });
    });
    auto future = answered.get_future();
    EXPECT_EQ(future.wait_for(5s), std::future_status::ready);
    return future.get();
  }

  EventLoop loop_;
  PeerServer server_{loop_};
  std::promise<UniqueFd> adopted_;
};

TEST_F(PeerTest, DispatchesByMethodName) {
  protocol::Message request = protocol::Message::request(7, "echo");
  request.set("text", "hello");
  Reply reply = call(std::move(request));
  ASSERT_EQ(reply.error, 0) << reply.error_text;
  EXPECT_EQ(reply.message.get_string("text"), "hello");
  EXPECT_EQ(reply.message.get_int("uid"), static_cast<std::int64_t>(::getuid()));
}

TEST_F(PeerTest, UnknownMethodsAreRefused) {
  Reply reply = call(protocol::Message::request(8, "no_such_method"));
  EXPECT_EQ(reply.error, LNE_NOT_YET_IMPLEMENTED);
  EXPECT_NE(reply.error_text.find("no_such_method"), std::string::npos);
}

TEST_F(PeerTest, UnreachablePeerFailsWithoutHanging) {
  std::promise<Reply> answered;
  loop_.post([&] {
    call_peer(loop_, "ln_core/nobody/listens/here", protocol::Message::request(9, "echo"), 2000ms,
              [&](Reply& reply, UniqueFd) { answered.set_value(std::move(reply)); });
  });
  auto future = answered.get_future();
  ASSERT_EQ(future.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(future.get().error, LNE_REQUEST_FAILED);
}

TEST_F(PeerTest, HandlerCanTakeTheConnectionOver) {
  UniqueFd client = connect_abstract_unix(server_.socket_name());
  ASSERT_EQ(send_all(client.get(), protocol::encode(protocol::Message::request(1, "adopt")), -1, 1000ms), 0);
  auto adopted = adopted_.get_future();
  ASSERT_EQ(adopted.wait_for(5s), std::future_status::ready);
  UniqueFd handed = adopted.get();
  ASSERT_TRUE(handed.valid());
  // The ok response arrived, then the socket is the handler's alone.
  protocol::FrameReader reader;
  std::string bytes;
  std::vector<UniqueFd> fds;
  pollfd readable{client.get(), POLLIN, 0};
  ASSERT_EQ(::poll(&readable, 1, 5000), 1);
  ASSERT_GT(receive_some(client.get(), bytes, fds), 0);
  reader.append(bytes.data(), bytes.size());
  auto response = reader.next();
  ASSERT_TRUE(response.has_value());
  EXPECT_FALSE(response->is_error());
  ASSERT_EQ(::write(client.get(), "raw", 3), 3);
  pollfd handed_readable{handed.get(), POLLIN, 0};
  ASSERT_EQ(::poll(&handed_readable, 1, 5000), 1);
  char raw[8] = {};
  EXPECT_EQ(::read(handed.get(), raw, sizeof raw), 3);
  EXPECT_STREQ(raw, "raw");
}

// Segments and services on this host: our own user, and the users
// LN_PEER_ALLOW_UIDS lists; nobody over TCP (there is no uid to check).
TEST(PeerAccess, SameUserUnlessConfigured) {
  const long me = static_cast<long>(::getuid());
  const long other = me + 1;
  const auto allowed = [](long uid, bool over_tcp) {
    return PeerConnection(UniqueFd(), uid, over_tcp).local_user_allowed();
  };
  const char* saved = std::getenv("LN_PEER_ALLOW_UIDS");
  const std::string old = saved ? saved : "";
  ::unsetenv("LN_PEER_ALLOW_UIDS");
  EXPECT_TRUE(allowed(me, false));
  EXPECT_FALSE(allowed(other, false));
  EXPECT_FALSE(allowed(-1, false));
  EXPECT_FALSE(allowed(me, true));
  ::setenv("LN_PEER_ALLOW_UIDS", ("7," + std::to_string(other)).c_str(), 1);
  EXPECT_TRUE(allowed(other, false));
  EXPECT_FALSE(allowed(other + 1, false));
  ::setenv("LN_PEER_ALLOW_UIDS", std::to_string(other * 10).c_str(), 1);
  EXPECT_FALSE(allowed(other, false)) << "whole numbers only, not prefixes";
  ::setenv("LN_PEER_ALLOW_UIDS", "*", 1);
  EXPECT_TRUE(allowed(other, false));
  EXPECT_FALSE(allowed(other, true));
  if (saved)
    ::setenv("LN_PEER_ALLOW_UIDS", old.c_str(), 1);
  else
    ::unsetenv("LN_PEER_ALLOW_UIDS");
}

}  // namespace
}  // namespace ln::clientlib
