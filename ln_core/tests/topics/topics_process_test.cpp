// Topics across processes: LN 2.9-style C and C++ programs started with
// posix_spawn against a manager in this process, publishers killed
// mid-stream, the manager stopped and restarted, and nothing left in
// /dev/shm afterwards.
#include <dirent.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "client/client_test_support.hpp"

extern char** environ;

namespace {

using namespace ln::clienttest;

struct P64 {
  uint32_t seq;
  uint8_t pad[60];
};

std::set<std::string> dev_shm_entries() {
  std::set<std::string> names;
  if (DIR* dir = ::opendir("/dev/shm")) {
    while (dirent* entry = ::readdir(dir)) names.insert(entry->d_name);
    ::closedir(dir);
  }
  return names;
}

class ProcessTopicTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(ln_init_to_manager(&client_, "driver", manager_.address().c_str()), 0); }
  void TearDown() override {
    if (client_ != nullptr) ln_deinit(&client_);
  }
  std::unique_ptr<ChildProcess> publisher(const std::string& topic, const std::string& count,
                                          const std::string& period_us, bool wait_for_subscriber = false,
                                          bool linger = false) {
    std::vector<std::string> args = {LN_TEST_PUBLISHER, topic, count, period_us};
    if (wait_for_subscriber) args.push_back("wait");
    if (linger) args.push_back("linger");
    auto child = std::make_unique<ChildProcess>(args, manager_.address());
    EXPECT_NE(child->wait_for_line("publishing"), "");
    return child;
  }
  ln_inport subscribe(const std::string& topic, ln_client client = nullptr) {
    ln_inport port = nullptr;
    client = client != nullptr ? client : client_;
    EXPECT_EQ(ln_subscribe_with_buffers(client, topic.c_str(), "test/p64", &port, -1, 0, 16), 0)
        << ln_get_error_message(client);
    return port;
  }

  ScopedEnv no_topic_map_{"LN_MAP_TOPICS", std::nullopt};
  InProcessManager manager_;
  ln_client client_ = nullptr;
};

TEST_F(ProcessTopicTest, CPublisherToCppSubscriber) {
  ChildProcess subscriber({LN_TEST_SUBSCRIBER, "p.c_to_cpp", "300", "20"}, manager_.address());
  ASSERT_NE(subscriber.wait_for_line("subscribed"), "");
  auto publisher_process = publisher("p.c_to_cpp", "300", "500", true);
  const std::string result = subscriber.wait_for_line("received", 20s);
  EXPECT_NE(result.find("last 300 gaps 0 torn 0"), std::string::npos) << result;
  EXPECT_EQ(subscriber.wait(), 0) << result;
  EXPECT_NE(publisher_process->wait_for_line("published 300"), "");
  EXPECT_EQ(publisher_process->wait(), 0);
}

// The publisher waits for has_subscriber and then writes 200 packets back to
// back: a subscriber with 256 buffers gets every one of them, whether it
// subscribed before the publisher started or after. (The publisher lingers
// until the subscriber is done: this is about joining, not about a
// publisher that leaves before its subscriber attached.)
TEST_F(ProcessTopicTest, WaitingPublisherLosesNothingToAnEarlierSubscriber) {
  ChildProcess subscriber({LN_TEST_SUBSCRIBER, "p.join_first", "200", "5"}, manager_.address());
  ASSERT_NE(subscriber.wait_for_line("subscribed"), "");
  auto publisher_process = publisher("p.join_first", "200", "0", true, true);
  const std::string result = subscriber.wait_for_line("received", 20s);
  EXPECT_NE(result.find("received 200 last 200 gaps 0 torn 0 first 1"), std::string::npos) << result;
  EXPECT_EQ(subscriber.wait(), 0) << result;
  EXPECT_NE(publisher_process->wait_for_line("published 200"), "");
  EXPECT_EQ(publisher_process->wait(), 0);
}

TEST_F(ProcessTopicTest, WaitingPublisherLosesNothingToALaterSubscriber) {
  auto publisher_process = publisher("p.join_later", "200", "0", true, true);
  ChildProcess subscriber({LN_TEST_SUBSCRIBER, "p.join_later", "200", "5"}, manager_.address());
  const std::string result = subscriber.wait_for_line("received", 20s);
  EXPECT_NE(result.find("received 200 last 200 gaps 0 torn 0 first 1"), std::string::npos) << result;
  EXPECT_EQ(subscriber.wait(), 0) << result;
  EXPECT_NE(publisher_process->wait_for_line("published 200"), "");
  EXPECT_EQ(publisher_process->wait(), 0);
}

TEST_F(ProcessTopicTest, PublisherKilledMidStreamAndReplaced) {
  auto first = publisher("p.killed", "0", "1000");
  ln_inport in = subscribe("p.killed");
  P64 received{};
  ASSERT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 5.0), 1);
  first->kill(SIGKILL);
  EXPECT_EQ(first->wait(), 128 + SIGKILL);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 0; }));
  // Reads neither hang nor fail: there is just nothing new.
  while (ln_read(in, &received, sizeof received, nullptr, 0) == 1) {
  }
  EXPECT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 0.05), 0);

  auto second = publisher("p.killed", "0", "1000");
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
  ln_sample_info info{};
  ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 5.0), 1);
  EXPECT_EQ(info.lost, 0u);
  EXPECT_LT(received.seq, 5000u);  // the new publisher's count
}

TEST_F(ProcessTopicTest, ManagerRestartWhileProcessesRun) {
  auto publisher_process = publisher("p.restart", "0", "1000");
  ln_inport in = subscribe("p.restart");
  P64 received{};
  ASSERT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 5.0), 1);

  manager_.stop();
  // Data keeps flowing without the manager.
  uint32_t last = received.seq;
  for (int i = 0; i < 20; ++i) {
    ASSERT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 2.0), 1);
    EXPECT_GT(received.seq, last);
    last = received.seq;
  }

  manager_.restart();
  // The publisher process registered again: a brand-new client finds it.
  ln_client late = nullptr;
  ASSERT_TRUE(wait_until([&] { return ln_init_to_manager(&late, "late", manager_.address().c_str()) == 0; }));
  ln_inport late_in = subscribe("p.restart", late);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(late_in) == 1; }));
  ASSERT_EQ(ln_read_timeout(late_in, &received, sizeof received, nullptr, 5.0), 1);
  ln_sample_info info{};
  ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 2.0), 1);
  EXPECT_GT(received.seq, last);
  ln_deinit(&late);
}

// The subscriber process pretends to run on another host: the publisher
// process sends it every packet over TCP (reliable) or UDP.
TEST_F(ProcessTopicTest, SubscriberOnAnotherHost) {
  for (const char* transport : {"reliable", "udp"}) {
    const std::string topic = std::string("p.remote.") + transport;
    ChildProcess subscriber({LN_TEST_SUBSCRIBER, topic, "300", "20", transport}, manager_.address(),
                            {"LN_CORE_HOST_ID=another-host/1"});
    ASSERT_NE(subscriber.wait_for_line("subscribed"), "");
    auto publisher_process = publisher(topic, "300", "1000", true);
    const std::string result = subscriber.wait_for_line("received", 20s);
    EXPECT_NE(result.find("last 300 gaps 0 torn 0"), std::string::npos) << transport << ": " << result;
    EXPECT_EQ(subscriber.wait(), 0);
    EXPECT_EQ(publisher_process->wait(), 0);
  }
}

TEST_F(ProcessTopicTest, DebugOutputOnlyWithLnDebug) {
  ChildProcess quiet({LN_TEST_PUBLISHER, "p.debug", "1", "0"}, manager_.address());
  EXPECT_NE(quiet.wait_for_line("published 1"), "");
  EXPECT_EQ(quiet.wait(), 0);
  EXPECT_EQ(quiet.wait_for_line("", 100ms), "");  // nothing else was printed

  ChildProcess debugging({LN_TEST_PUBLISHER, "p.debug", "1", "0"}, manager_.address(), {"LN_DEBUG=1"});
  const std::string line = debugging.wait_for_line("ln_debug");
  EXPECT_NE(line.find("c_publisher"), std::string::npos) << line;
  EXPECT_EQ(debugging.wait(), 0);
}

TEST_F(ProcessTopicTest, NothingIsLeftInDevShm) {
  const std::set<std::string> before = dev_shm_entries();
  {
    ChildProcess subscriber({LN_TEST_SUBSCRIBER, "p.shm", "100", "20"}, manager_.address());
    ASSERT_NE(subscriber.wait_for_line("subscribed"), "");
    auto publisher_process = publisher("p.shm", "100", "200", true);
    ln_inport in = subscribe("p.shm");
    (void)in;
    EXPECT_EQ(subscriber.wait(20s), 0);
    EXPECT_EQ(publisher_process->wait(), 0);
  }
  ln_deinit(&client_);
  EXPECT_EQ(dev_shm_entries(), before);
}

TEST_F(ProcessTopicTest, BenchmarkProgramsRun) {
  ChildProcess pong({LN_BENCH_PINGPONG, "pong"}, manager_.address());
  ChildProcess ping({LN_BENCH_PINGPONG, "ping", "200"}, manager_.address());
  const std::string rtt = ping.wait_for_line("{", 30s);
  EXPECT_NE(rtt.find("\"median_us\""), std::string::npos) << rtt;
  EXPECT_EQ(ping.wait(), 0);
  EXPECT_EQ(pong.wait(), 0);

  ChildProcess sub({LN_BENCH_RATE, "sub", "256"}, manager_.address());
  ChildProcess pub({LN_BENCH_RATE, "pub", "0.2", "256"}, manager_.address());
  const std::string sent = pub.wait_for_line("{", 30s);
  const std::string got = sub.wait_for_line("{", 30s);
  EXPECT_NE(sent.find("\"writes_per_s\""), std::string::npos) << sent;
  EXPECT_NE(got.find("\"torn\": 0}"), std::string::npos) << got;
  EXPECT_EQ(pub.wait(), 0);
  EXPECT_EQ(sub.wait(), 0);
}

}  // namespace
