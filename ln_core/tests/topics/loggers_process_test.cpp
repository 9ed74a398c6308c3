// Topic loggers across processes: the manager keeps what a publisher wrote
// after the publisher was killed (LN 2.9's manager loses it: tests/
// ln29_behaviour/test_ln29b_loggers.py).
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <signal.h>

#include <atomic>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

struct P64 {
  uint32_t seq;
  uint8_t pad[60];
};

/// The packet numbers of a logger's first topic.
std::vector<uint32_t> recorded(ln_logger logger) {
  ln_logger_data data = nullptr;
  EXPECT_EQ(ln_logger_download(logger, &data), 0);
  logger_topic* topic = nullptr;
  EXPECT_EQ(ln_logger_data_get_topic(data, 0, &topic), 0);
  std::vector<uint32_t> seqs;
  for (uint32_t i = 0; topic != nullptr && i < topic->n_samples; ++i) {
    P64 packet;
    std::memcpy(&packet, reinterpret_cast<const unsigned char*>(topic->samples) + i * topic->sample_size + 20,
                sizeof packet);
    seqs.push_back(packet.seq);
  }
  return seqs;
}

TEST(ProcessLoggerTest, WhatAKilledPublisherWroteStaysRecorded) {
  ScopedEnv no_topic_map("LN_MAP_TOPICS", std::nullopt);
  InProcessManager manager;
  ln_client client = nullptr;
  ASSERT_EQ(ln_init_to_manager(&client, "driver", manager.address().c_str()), 0);
  ln_logger logger = nullptr;
  ASSERT_EQ(ln_client_get_logger(client, &logger, "crash"), 0);
  ASSERT_EQ(ln_logger_add_topic(logger, "p.crash", 100000, 1), 0);
  ASSERT_EQ(ln_logger_enable(logger), 0);
  // A subscriber of our own reads along, to know how far the stream got.
  ln_inport in = nullptr;
  ASSERT_EQ(ln_subscribe_with_buffers(client, "p.crash", "test/p64", &in, -1, 0, 1000), 0);
  std::atomic<uint32_t> last_read{0};
  std::atomic<bool> stop_reading{false};
  std::thread reader([&] {
    P64 packet{};
    const double deadline = ln_get_monotonic_time() + 30;
    while (!stop_reading.load() && ln_get_monotonic_time() < deadline)
      if (ln_read_timeout(in, &packet, sizeof packet, nullptr, 0.05) == 1) last_read.store(packet.seq);
  });

  ChildProcess publisher({LN_TEST_PUBLISHER, "p.crash", "0", "1000"}, manager.address());
  ASSERT_NE(publisher.wait_for_line("publishing"), "");
  EXPECT_TRUE(wait_until([&] { return recorded(logger).size() >= 50 && last_read.load() > 0; }, 10s));
  publisher.kill(SIGKILL);
  EXPECT_NE(publisher.wait(), 0);
  // The manager learns of the death when the publisher's connection drops.
  ASSERT_TRUE(wait_until([&] {
    ln_topic_info* topics = nullptr;
    unsigned count = 0;
    if (ln_list_topics(client, &topics, &count) != 0) return false;
    const bool gone = count == 1 && topics[0].publisher[0] == '\0';
    ln_free_list(topics);
    return gone;
  }));
  stop_reading.store(true);
  reader.join();
  const std::vector<uint32_t> seqs = recorded(logger);
  ASSERT_FALSE(seqs.empty());
  EXPECT_GE(seqs.back(), last_read.load());  // the recorder drained the dead publisher's segment
  for (std::size_t i = 1; i < seqs.size(); ++i) ASSERT_EQ(seqs[i], seqs[i - 1] + 1) << "at " << i;
  EXPECT_EQ(recorded(logger), seqs);  // and stays
  ASSERT_EQ(ln_logger_disable(logger), 0);
  ln_deinit(&client);
}

}  // namespace
