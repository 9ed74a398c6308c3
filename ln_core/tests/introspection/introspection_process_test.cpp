// Introspection across processes: what ln_list_topics(), ln_list_clients(),
// ln_list_services() and ln_get_manager_status() (and the C++ wrapper)
// report about LN 2.9-style programs started with posix_spawn, topic rates
// measured by the publishers, and publisher availability handlers driven by
// the manager's notifications -- against a manager in this process.
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

std::vector<std::string> names(const char* const* list) {
  std::vector<std::string> out;
  for (; list != nullptr && *list != nullptr; ++list) out.emplace_back(*list);
  return out;
}

/// A result of the ln_list_* functions, released at the end of the scope.
template <typename Row>
struct Listing {
  Row* rows = nullptr;
  unsigned int count = 0;
  Listing() = default;
  Listing(const Listing&) = delete;
  Listing& operator=(const Listing&) = delete;
  ~Listing() { ln_free_list(rows); }
  const Row* find(const std::string& name) const {
    for (unsigned int i = 0; i < count; ++i)
      if (name == rows[i].name) return &rows[i];
    return nullptr;
  }
};

/// Records what an availability handler was told.
struct AvailabilityLog {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<int> states;

  static void handler(ln_client, const char*, int available, void* self) {
    auto* log = static_cast<AvailabilityLog*>(self);
    std::lock_guard<std::mutex> lock(log->mutex);
    log->states.push_back(available);
    log->changed.notify_all();
  }
  /// True once the handler was called `calls` times.
  bool wait_for_calls(std::size_t calls, std::chrono::milliseconds timeout = 10s) {
    std::unique_lock<std::mutex> lock(mutex);
    return changed.wait_for(lock, timeout, [&] { return states.size() >= calls; });
  }
  /// True once the latest state is `state`.
  bool wait_for_state(int state, std::chrono::milliseconds timeout = 10s) {
    std::unique_lock<std::mutex> lock(mutex);
    return changed.wait_for(lock, timeout, [&] { return !states.empty() && states.back() == state; });
  }
  std::vector<int> seen() {
    std::lock_guard<std::mutex> lock(mutex);
    return states;
  }
};

class IntrospectionProcessTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(ln_init_to_manager(&client_, "driver", manager_.address().c_str()), 0); }
  void TearDown() override {
    if (client_ != nullptr) ln_deinit(&client_);
  }

  std::unique_ptr<ChildProcess> publisher(const std::string& topic, const std::string& count,
                                          const std::string& period_us) {
    auto child = std::make_unique<ChildProcess>(std::vector<std::string>{LN_TEST_PUBLISHER, topic, count, period_us},
                                                manager_.address());
    EXPECT_NE(child->wait_for_line("publishing"), "");
    return child;
  }

  /// Polls the topic listing (at a pace that spares the manager) until
  /// `condition` holds for `topic`'s row; false after `timeout`.
  bool wait_for_topic(const std::string& topic, const std::function<bool(const ln_topic_info&)>& condition,
                      std::chrono::milliseconds timeout = 20s) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      Listing<ln_topic_info> topics;
      if (ln_list_topics(client_, &topics.rows, &topics.count) == 0) {
        const ln_topic_info* row = topics.find(topic);
        if (row != nullptr && condition(*row)) return true;
      }
      if (Clock::now() >= deadline) return false;
      std::this_thread::sleep_for(20ms);
    }
  }

  double rate_of(const std::string& topic) {
    Listing<ln_topic_info> topics;
    EXPECT_EQ(ln_list_topics(client_, &topics.rows, &topics.count), 0);
    const ln_topic_info* row = topics.find(topic);
    return row != nullptr ? row->rate : -1;
  }

  ScopedEnv no_topic_map_{"LN_MAP_TOPICS", std::nullopt};
  InProcessManager manager_{0, {LN_TEST_MD_DIR, LN_TEST_SERVICES_MD_DIR}};
  ln_client client_ = nullptr;
};

TEST_F(IntrospectionProcessTest, ListsWhatOtherProcessesPublishSubscribeAndProvide) {
  auto pub = publisher("i.topic", "0", "10000");
  ChildProcess sub({LN_TEST_SUBSCRIBER, "i.topic", "1000000", "60"}, manager_.address());
  ASSERT_NE(sub.wait_for_line("subscribed"), "");
  ChildProcess provider({LN_SVC_PROVIDER, "i.service"}, manager_.address());
  ASSERT_NE(provider.wait_for_line("ready"), "");
  ln_inport in = nullptr;
  ASSERT_EQ(ln_subscribe(client_, "i.topic", "test/p64", &in, RATE_AS_PUBLISHED, 0), 0)
      << ln_get_error_message(client_);

  Listing<ln_topic_info> topics;
  ASSERT_EQ(ln_list_topics(client_, &topics.rows, &topics.count), 0) << ln_get_error_message(client_);
  ASSERT_EQ(topics.count, 1u);
  const ln_topic_info& topic = topics.rows[0];
  EXPECT_STREQ(topic.name, "i.topic");
  EXPECT_STREQ(topic.message_definition, "test/p64");
  EXPECT_EQ(std::strlen(topic.hash), 64u);
  EXPECT_EQ(topic.message_size, 64u);
  EXPECT_STREQ(topic.publisher, "c_publisher");
  EXPECT_EQ(topic.subscribers, 2u);

  Listing<ln_client_info> clients;
  ASSERT_EQ(ln_list_clients(client_, &clients.rows, &clients.count), 0) << ln_get_error_message(client_);
  ASSERT_EQ(clients.count, 4u);
  const ln_client_info* driver = clients.find("driver");
  const ln_client_info* publishing = clients.find("c_publisher");
  const ln_client_info* subscribing = clients.find("cpp_subscriber");
  const ln_client_info* providing = clients.find("svc_provider");
  ASSERT_TRUE(driver && publishing && subscribing && providing);
  EXPECT_EQ(driver->pid, ::getpid());
  EXPECT_EQ(publishing->pid, pub->pid());
  EXPECT_EQ(providing->pid, provider.pid());
  EXPECT_STREQ(publishing->host_id, driver->host_id);
  EXPECT_STREQ(publishing->host, driver->host);
  EXPECT_NE(publishing->id, driver->id);
  EXPECT_EQ(names(publishing->published), std::vector<std::string>{"i.topic"});
  EXPECT_EQ(names(publishing->subscribed), std::vector<std::string>{});
  EXPECT_EQ(names(subscribing->subscribed), std::vector<std::string>{"i.topic"});
  EXPECT_EQ(names(driver->subscribed), std::vector<std::string>{"i.topic"});
  EXPECT_EQ(names(providing->services), std::vector<std::string>{"i.service"});
  EXPECT_EQ(names(driver->services), std::vector<std::string>{});

  Listing<ln_service_info> services;
  ASSERT_EQ(ln_list_services(client_, &services.rows, &services.count), 0) << ln_get_error_message(client_);
  ASSERT_EQ(services.count, 1u);
  EXPECT_STREQ(services.rows[0].name, "i.service");
  EXPECT_EQ(std::string(services.rows[0].interface).substr(0, 8), "svc/test");
  EXPECT_NE(std::strlen(services.rows[0].signature), 0u);
  EXPECT_STREQ(services.rows[0].provider, "svc_provider");
  EXPECT_STREQ(services.rows[0].group, "");

  ln_manager_status* status = nullptr;
  ASSERT_EQ(ln_get_manager_status(client_, &status), 0) << ln_get_error_message(client_);
  EXPECT_NE(std::string(status->version).find("ln_core"), std::string::npos);
  EXPECT_EQ(status->pid, ::getpid());
  EXPECT_EQ(status->address, manager_.address());
  EXPECT_GT(status->uptime, 0.0);
  EXPECT_EQ(status->clients, 4u);
  EXPECT_EQ(status->topics, 1u);
  EXPECT_EQ(status->services, 1u);
  const std::vector<std::string> dirs = names(status->message_definition_dirs);
  ASSERT_GE(dirs.size(), 2u);
  EXPECT_EQ(dirs[0], LN_TEST_MD_DIR);
  EXPECT_EQ(dirs[1], LN_TEST_SERVICES_MD_DIR);
  ln_free_list(status);

  // The C++ wrapper tells the same.
  ln::client cpp(client_);
  const std::vector<ln::topic_info> cpp_topics = cpp.list_topics();
  ASSERT_EQ(cpp_topics.size(), 1u);
  EXPECT_EQ(cpp_topics[0].publisher, "c_publisher");
  EXPECT_EQ(cpp_topics[0].message_size, 64u);
  const std::vector<ln::client_info> cpp_clients = cpp.list_clients();
  ASSERT_EQ(cpp_clients.size(), 4u);
  for (const ln::client_info& info : cpp_clients) {
    if (info.name == "svc_provider") {
      EXPECT_EQ(info.services, std::vector<std::string>{"i.service"});
    }
  }
  const std::vector<ln::service_info> cpp_services = cpp.list_services();
  ASSERT_EQ(cpp_services.size(), 1u);
  EXPECT_EQ(cpp_services[0].provider, "svc_provider");
  const ln::manager_status cpp_status = cpp.get_manager_status();
  EXPECT_EQ(cpp_status.address, manager_.address());
  EXPECT_EQ(cpp_status.message_definition_dirs, dirs);
}

TEST_F(IntrospectionProcessTest, RateOfAProcessWritingAt100HzThenStalled) {
  auto pub = publisher("i.rate", "0", "10000");
  EXPECT_TRUE(wait_for_topic("i.rate", [](const ln_topic_info& t) { return t.rate > 50 && t.rate < 150; }))
      << "rate " << rate_of("i.rate");
  EXPECT_GT(rate_of("i.rate"), 0);
  // A publisher that stops reporting (here: stopped as a whole) shows no rate.
  pub->kill(SIGSTOP);
  EXPECT_TRUE(wait_for_topic("i.rate", [](const ln_topic_info& t) { return t.rate == 0; })) << rate_of("i.rate");
  pub->kill(SIGCONT);
  EXPECT_TRUE(wait_for_topic("i.rate", [](const ln_topic_info& t) { return t.rate > 50 && t.rate < 150; }))
      << "rate " << rate_of("i.rate");
}

TEST_F(IntrospectionProcessTest, RateDropsToZeroWhenThePublisherStopsWriting) {
  ln_client writer_client = nullptr;
  ASSERT_EQ(ln_init_to_manager(&writer_client, "writer", manager_.address().c_str()), 0);
  ln_outport out = nullptr;
  ASSERT_EQ(ln_publish(writer_client, "i.burst", "test/p64", &out), 0) << ln_get_error_message(writer_client);
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> written{0};
  std::thread writer([&] {
    char packet[64] = {};
    while (!stop.load()) {
      if (ln_write(out, packet, sizeof packet, nullptr) == 0) ++written;
      ln_sleep_seconds(0.01);  // a writer at up to 100 Hz
    }
  });
  // (a loaded machine may run the writer at well below 100 Hz)
  EXPECT_TRUE(wait_for_topic("i.burst", [](const ln_topic_info& t) { return t.rate > 10 && t.rate < 150; }))
      << "rate " << rate_of("i.burst");
  stop = true;
  writer.join();
  const uint64_t total = written.load();
  // One more report with the final count, whose interval has no packets.
  EXPECT_TRUE(wait_for_topic("i.burst", [&](const ln_topic_info& t) { return t.packets == total && t.rate == 0; }))
      << "expected " << total << " packets at rate 0, rate " << rate_of("i.burst");
  Listing<ln_topic_info> topics;
  ASSERT_EQ(ln_list_topics(client_, &topics.rows, &topics.count), 0);
  ASSERT_NE(topics.find("i.burst"), nullptr);
  EXPECT_STREQ(topics.find("i.burst")->publisher, "writer") << "the publisher is still there";
  ln_deinit(&writer_client);
}

TEST_F(IntrospectionProcessTest, PublisherAvailabilityFollowsPublishUnpublishAndCrash) {
  AvailabilityLog log;
  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.avail", AvailabilityLog::handler, &log), 0);
  ASSERT_TRUE(log.wait_for_calls(1));
  {
    // Publishes 20 packets, then unpublishes and exits.
    ChildProcess finite({LN_TEST_PUBLISHER, "i.avail", "20", "20000"}, manager_.address());
    ASSERT_TRUE(log.wait_for_calls(3));
    EXPECT_EQ(finite.wait(), 0);
  }
  auto crashing = publisher("i.avail", "0", "1000");
  ASSERT_TRUE(log.wait_for_calls(4));
  crashing->kill(SIGKILL);
  EXPECT_EQ(crashing->wait(), 128 + SIGKILL);
  ASSERT_TRUE(log.wait_for_calls(5));
  EXPECT_EQ(log.seen(), (std::vector<int>{0, 1, 0, 1, 0}));

  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.avail", nullptr, nullptr), 0);
  auto unwatched = publisher("i.avail", "0", "1000");
  // The next publisher is seen by everyone but this handler: a new handler
  // learns of it right away, the removed one hears nothing.
  AvailabilityLog other;
  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.avail", AvailabilityLog::handler, &other), 0);
  ASSERT_TRUE(other.wait_for_state(1));
  EXPECT_EQ(log.seen().size(), 5u);
  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.avail", nullptr, nullptr), 0);
}

TEST_F(IntrospectionProcessTest, PublisherAvailabilityAcrossAManagerRestart) {
  AvailabilityLog log;
  auto first = publisher("i.restart", "0", "1000");
  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.restart", AvailabilityLog::handler, &log), 0);
  ASSERT_TRUE(log.wait_for_state(1));

  manager_.restart();
  // Both processes register again; the publisher's topic comes back.
  EXPECT_TRUE(wait_for_topic(
      "i.restart", [](const ln_topic_info& t) { return std::strlen(t.publisher) > 0; }, 15s));
  ASSERT_TRUE(log.wait_for_state(1));
  first->kill(SIGKILL);
  EXPECT_TRUE(log.wait_for_state(0)) << "the new manager's notification arrived";
  auto second = publisher("i.restart", "0", "1000");
  EXPECT_TRUE(log.wait_for_state(1));
  ASSERT_EQ(ln_set_publisher_availability_handler(client_, "i.restart", nullptr, nullptr), 0);
}

}  // namespace
