// Topic semantics through the public API of libln.so: several clients in this
// process against an in-process manager (the cross-process cases live in
// tests/topics).
#include <dirent.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ln/ln.h>
#include <poll.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <future>
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
static_assert(sizeof(P64) == 64, "test/p64 is 64 bytes");

P64 packet(uint32_t seq) {
  P64 p{};
  p.seq = seq;
  std::memset(p.pad, static_cast<int>(seq & 0xff), sizeof p.pad);
  return p;
}

class TopicTest : public OwnManagerTest {
 protected:
  void SetUp() override {
    publisher_ = connect("publisher");
    subscriber_ = connect("subscriber");
  }
  void TearDown() override { deinit_clients({&publisher_, &subscriber_}); }
  ln_outport publish(const char* topic, unsigned buffers = 1, ln_client client = nullptr) {
    ln_outport port = nullptr;
    client = client != nullptr ? client : publisher_;
    EXPECT_EQ(ln_publish_with_buffers(client, topic, "test/p64", buffers, &port), 0) << ln_get_error_message(client);
    return port;
  }
  ln_inport subscribe(const char* topic, unsigned buffers = 1, double rate = RATE_AS_PUBLISHED) {
    ln_inport port = nullptr;
    EXPECT_EQ(ln_subscribe_with_buffers(subscriber_, topic, "test/p64", &port, rate, 0, buffers), 0)
        << ln_get_error_message(subscriber_);
    return port;
  }
  // Writes until the subscriber reads a packet (a subscriber only sees packets
  // written after it attached), then returns the sequence number it read.
  uint32_t handshake(ln_outport out, ln_inport in) {
    P64 received{};
    for (uint32_t seq = 1000000; seq < 1000000 + 5000; ++seq) {
      P64 p = packet(seq);
      EXPECT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
      if (ln_read_timeout(in, &received, sizeof received, nullptr, 0.002) == 1) {
        while (ln_read(in, &received, sizeof received, nullptr, 0) == 1) {
        }
        return received.seq;
      }
    }
    ADD_FAILURE() << "no packet got through";
    return 0;
  }

  ln_client publisher_ = nullptr;
  ln_client subscriber_ = nullptr;
};

TEST_F(TopicTest, PublishSubscribeWriteRead) {
  ln_outport out = publish("t.basic");
  ln_inport in = subscribe("t.basic");
  ASSERT_TRUE(out && in);
  EXPECT_EQ(ln_get_message_size(out), 64);
  EXPECT_EQ(ln_get_message_size(in), 64);
  EXPECT_STREQ(ln_get_msg_def_hash(in), ln_get_msg_def_hash(out));
  EXPECT_EQ(std::strlen(ln_get_msg_def_hash(in)), 64u);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1 && ln_has_subscriber(out) == 1; }));
  handshake(out, in);

  P64 p = packet(7);
  double ts = 1234.5;
  ASSERT_EQ(ln_write(out, &p, sizeof p, &ts), 0);
  P64 received{};
  double received_ts = 0;
  ASSERT_EQ(ln_read(in, &received, sizeof received, &received_ts, 1), 1);
  EXPECT_EQ(received.seq, 7u);
  EXPECT_EQ(received.pad[59], 7);
  EXPECT_EQ(received_ts, 1234.5);

  // NULL timestamp: stamped with ln_get_time()
  const double before = ln_get_time();
  ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
  ASSERT_EQ(ln_read(in, &received, sizeof received, &received_ts, 1), 1);
  EXPECT_GE(received_ts, before);
  EXPECT_LE(received_ts, ln_get_time());

  // Nothing new: a non-blocking read returns 0 and leaves the buffer alone.
  P64 untouched = packet(99);
  EXPECT_EQ(ln_read(in, &untouched, sizeof untouched, nullptr, 0), 0);
  EXPECT_EQ(untouched.seq, 99u);
  const auto start = Clock::now();
  EXPECT_EQ(ln_read_timeout(in, &untouched, sizeof untouched, nullptr, 0.05), 0);
  EXPECT_GE(Clock::now() - start, 45ms);
  EXPECT_EQ(untouched.seq, 99u);

  EXPECT_EQ(ln_unsubscribe(&in), 0);
  EXPECT_EQ(in, nullptr);
  EXPECT_TRUE(wait_until([&] { return ln_has_subscriber(out) == 0; }));
  EXPECT_EQ(ln_unpublish(&out), 0);
  EXPECT_EQ(out, nullptr);
}

// The segment of `topic` as this process maps it (the publisher's and the
// subscriber's descriptors name the same memory file), writable: what a
// subscriber that scribbles over its mapping can reach.
struct WritableSegment {
  explicit WritableSegment(const std::string& topic) {
    DIR* fds = ::opendir("/proc/self/fd");
    while (const dirent* entry = fds ? ::readdir(fds) : nullptr) {
      char target[256] = {};
      const std::string link = std::string("/proc/self/fd/") + entry->d_name;
      if (::readlink(link.c_str(), target, sizeof target - 1) <= 0) continue;
      if (std::string(target).rfind("/memfd:ln:" + topic + " ", 0) != 0) continue;
      const int fd = ::open(link.c_str(), O_RDWR | O_CLOEXEC);
      size = static_cast<std::size_t>(::lseek(fd, 0, SEEK_END));
      base = static_cast<unsigned char*>(::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0));
      ::close(fd);
      break;
    }
    if (fds) ::closedir(fds);
  }
  ~WritableSegment() {
    if (base != nullptr && base != MAP_FAILED) ::munmap(base, size);
  }
  // The ring names slots that do not exist: readers fail with corrupt_segment.
  void scribble_over_ring() {
    std::uint64_t ring_offset = 0;
    std::memcpy(&ring_offset, base + 24, sizeof ring_offset);  // SegmentInfo::ring_offset
    std::memset(base + ring_offset, 0xff, 16);
  }
  // Everything readers may write set to ones: every spare slot looks pinned.
  void scribble_over_reader_area() {
    std::uint64_t shared_offset = 0;
    std::memcpy(&shared_offset, base + 48, sizeof shared_offset);  // SegmentInfo::shared_offset
    std::memset(base + shared_offset, 0xff, size - shared_offset);
  }
  unsigned char* base = nullptr;
  std::size_t size = 0;
};

// A publisher and a subscriber of `topic` that exchanged packets; then
// `damage` plays a subscriber that writes where it must not.
class DamagedSegmentTest : public TopicTest {
 protected:
  void exchange_then_damage(const char* topic, void (WritableSegment::*damage)()) {
    out = publish(topic, 4);
    in = subscribe(topic, 4);
    ASSERT_TRUE(out && in);
    EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1 && ln_has_subscriber(out) == 1; }));
    handshake(out, in);
    WritableSegment segment(topic);
    ASSERT_NE(segment.base, nullptr);
    ASSERT_NE(segment.base, MAP_FAILED);
    (segment.*damage)();
  }
  ln_outport out = nullptr;
  ln_inport in = nullptr;
};

TEST_F(DamagedSegmentTest, ACorruptedSegmentIsReplacedAndSubscribersFollow) {
  ASSERT_NO_FATAL_FAILURE(exchange_then_damage("t.corrupt", &WritableSegment::scribble_over_reader_area));
  // The publisher's writes succeed (into a new segment) and the subscriber
  // gets every one of them.
  for (uint32_t seq = 1; seq <= 3; ++seq) {
    P64 p = packet(seq);
    ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0) << ln_get_error_message(publisher_);
  }
  ln_sample_info info{};
  for (uint32_t seq = 1; seq <= 3; ++seq) {
    P64 received{};
    ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 5), 1) << ln_get_error_message(subscriber_);
    EXPECT_EQ(received.seq, seq);
    EXPECT_EQ(info.lost, 0u);
  }
  EXPECT_TRUE(
      manager_.wait_for_log("found the shared-memory segment of topic 't.corrupt' corrupted and replaced it "
                            "(1 times so far)"));
}

TEST_F(DamagedSegmentTest, AnOverwrittenRingIsNoticedByThePublisherAndReplaced) {
  ASSERT_NO_FATAL_FAILURE(exchange_then_damage("t.ring", &WritableSegment::scribble_over_ring));
  // Readers of the damaged segment fail; the publisher notices within about
  // a second, replaces it, and the subscriber reads the new one.
  bool read_after_replacement = false;
  const auto deadline = Clock::now() + 10s;
  for (uint32_t seq = 1; !read_after_replacement && Clock::now() < deadline; ++seq) {
    P64 p = packet(seq);
    ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
    P64 received{};
    read_after_replacement = ln_read_timeout(in, &received, sizeof received, nullptr, 0.02) == 1;
  }
  EXPECT_TRUE(read_after_replacement);
  EXPECT_TRUE(manager_.wait_for_log("found the shared-memory segment of topic 't.ring' corrupted and replaced it"));
}

TEST_F(TopicTest, BuffersMustBeAtLeastOneAndWithinTheLimit) {
  ln_outport out = nullptr;
  EXPECT_EQ(ln_publish_with_buffers(publisher_, "t.zero", "test/p64", 0, &out), -LNE_INVALID_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(publisher_)).find("buffers must be at least 1"), std::string::npos);
  ln_inport in = nullptr;
  EXPECT_EQ(ln_subscribe_with_buffers(subscriber_, "t.zero", "test/p64", &in, RATE_AS_PUBLISHED, 0, 0),
            -LNE_INVALID_PARAMETER);
  // 4096 buffers of test/big (1 MiB packets) would need 4 GiB: refused, naming the limit.
  EXPECT_EQ(ln_subscribe_with_buffers(subscriber_, "t.huge", "test/big", &in, RATE_AS_PUBLISHED, 0, 4096),
            -LNE_SHM_IS_TOO_BIG);
  EXPECT_NE(std::string(ln_get_error_message(subscriber_)).find("(max_topic_shm 256 MiB)"), std::string::npos)
      << ln_get_error_message(subscriber_);
}

TEST_F(TopicTest, SampleInfoCountsSequenceAndLoss) {
  ln_outport out = publish("t.info");
  ln_inport in = subscribe("t.info");
  handshake(out, in);
  for (uint32_t seq = 1; seq <= 5; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
  }
  P64 received{};
  ln_sample_info info{};
  ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 1.0), 1);
  EXPECT_EQ(received.seq, 5u);  // one buffer: only the newest
  EXPECT_EQ(info.lost, 4u);
  const uint64_t sequence = info.sequence;
  P64 p = packet(6);
  ln_write(out, &p, sizeof p, nullptr);
  ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 1.0), 1);
  EXPECT_EQ(info.sequence, sequence + 1);
  EXPECT_EQ(info.lost, 0u);
}

TEST_F(TopicTest, BuffersLetASlowReaderCatchUpInOrder) {
  ln_outport out = publish("t.buffers");
  ln_inport in = subscribe("t.buffers", 5);
  handshake(out, in);
  for (uint32_t seq = 1; seq <= 5; ++seq) {
    P64 p = packet(seq);
    ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
  }
  for (uint32_t seq = 1; seq <= 5; ++seq) {
    P64 received{};
    ASSERT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 1);
    EXPECT_EQ(received.seq, seq);
  }
  // Falling further behind than the buffers skips to the newest.
  for (uint32_t seq = 10; seq <= 30; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
  }
  P64 received{};
  ASSERT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 1);
  EXPECT_EQ(received.seq, 30u);
}

TEST_F(TopicTest, SubscribeBeforePublishBlocksUntilData) {
  ln_inport in = subscribe("t.late");
  EXPECT_EQ(ln_has_publisher(in), 0);
  P64 received{};
  EXPECT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 0);
  EXPECT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 0.02), 0);
  std::atomic<int> result{-100};
  std::thread reader([&] { result = ln_read_timeout(in, &received, sizeof received, nullptr, 10.0); });
  ln_outport out = publish("t.late");
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
  for (uint32_t seq = 1; result == -100 && seq < 10000; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
    std::this_thread::sleep_for(1ms);
  }
  reader.join();
  EXPECT_EQ(result, 1);
  EXPECT_GE(received.seq, 1u);
}

TEST_F(TopicTest, OversizeWriteIsRefused) {
  ln_outport out = publish("t.oversize");
  std::vector<char> big(65, 'x');
  EXPECT_EQ(ln_write(out, big.data(), 65, nullptr), -LNE_PACKET_TOO_LARGE);
  EXPECT_NE(std::string(ln_get_error_message(publisher_)).find("65"), std::string::npos);
  EXPECT_EQ(ln_write(out, big.data(), 10, nullptr), 0);  // shorter packets are fine
}

TEST_F(TopicTest, SecondPublisherAndDefinitionMismatchAreRefused) {
  ln_outport out = publish("t.owned");
  ln_outport second = nullptr;
  EXPECT_EQ(ln_publish(subscriber_, "t.owned", "test/p64", &second), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(subscriber_)).find("already published"), std::string::npos)
      << ln_get_error_message(subscriber_);
  ln_inport wrong = nullptr;
  EXPECT_EQ(ln_subscribe(subscriber_, "t.owned", "test/other64", &wrong, -1, 0), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(subscriber_)).find("test/other64"), std::string::npos);
  EXPECT_EQ(ln_subscribe(subscriber_, "t.dyn", "test/dynamic", &wrong, -1, 0), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_subscribe(subscriber_, "t.x", "test/p64|0000", &wrong, -1, 0), -LNE_WRONG_MD_HASH);
  (void)out;
}

TEST_F(TopicTest, RateLimitDropsPacketsByPublisherTimestamp) {
  ln_outport out = publish("t.rate");
  ln_inport in = subscribe("t.rate", 64, 10.0);  // at most 10 per second
  handshake(out, in);
  // Timestamps a little over 0.01 s apart: every 10th packet passes.
  for (uint32_t i = 0; i < 40; ++i) {
    P64 p = packet(i);
    double ts = 100.0 + i * 0.0100001;
    ASSERT_EQ(ln_write(out, &p, sizeof p, &ts), 0);
  }
  std::vector<uint32_t> seen;
  ln_sample_info info{};
  P64 received{};
  while (ln_read_with_info(in, &received, sizeof received, &info, 0) == 1) seen.push_back(received.seq);
  EXPECT_EQ(seen, (std::vector<uint32_t>{0, 10, 20, 30})) << seen.size();
}

TEST_F(TopicTest, OnRequestReadsReturnTheNewestPacket) {
  // RATE_ON_REQUEST_NEXT is served as RATE_ON_REQUEST_LAST, as by LN 2.9.
  for (const double rate : {RATE_ON_REQUEST_LAST, RATE_ON_REQUEST_NEXT}) {
    SCOPED_TRACE(rate);
    const std::string topic = "t.onrequest" + std::to_string(static_cast<int>(-rate));
    ln_outport out = publish(topic.c_str());
    ln_inport in = subscribe(topic.c_str(), 1, rate);
    EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
    P64 received{};
    EXPECT_TRUE(wait_until([&] {
      P64 p = packet(1);
      ln_write(out, &p, sizeof p, nullptr);
      return ln_read(in, &received, sizeof received, nullptr, 0) == 1;
    }));
    for (uint32_t seq = 2; seq <= 9; ++seq) {
      P64 p = packet(seq);
      ln_write(out, &p, sizeof p, nullptr);
    }
    ASSERT_EQ(ln_read(in, &received, sizeof received, nullptr, 1), 1);
    EXPECT_EQ(received.seq, 9u);
    received.seq = 0;
    ASSERT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 1);  // again the newest
    EXPECT_EQ(received.seq, 9u);
  }
}

TEST_F(TopicTest, UnblockEndsABlockedRead) {
  ln_outport out = publish("t.unblock");
  ln_inport in = subscribe("t.unblock");
  handshake(out, in);
  std::atomic<int> result{-100};
  std::atomic<pid_t> reader_id{0};
  std::thread reader([&] {
    reader_id = ln::test::current_thread_id();
    P64 received{};
    result = ln_read(in, &received, sizeof received, nullptr, 1);
  });
  EXPECT_TRUE(wait_until([&] { return ln::test::thread_sleeps(reader_id); }));  // blocked in the read
  EXPECT_EQ(result, -100);
  EXPECT_EQ(ln_unblock(in), 0);
  reader.join();
  EXPECT_EQ(result, -LNE_PORT_UNBLOCKED);

  // Also while waiting for a publisher that does not exist yet.
  ln_inport lonely = subscribe("t.nobody");
  result = -100;
  std::atomic<pid_t> waiter_id{0};
  std::thread waiter([&] {
    waiter_id = ln::test::current_thread_id();
    P64 received{};
    result = ln_read(lonely, &received, sizeof received, nullptr, 1);
  });
  EXPECT_TRUE(wait_until([&] { return ln::test::thread_sleeps(waiter_id); }));
  ln_unblock(lonely);
  waiter.join();
  EXPECT_EQ(result, -LNE_PORT_UNBLOCKED);
}

TEST_F(TopicTest, ZeroCopyWriteAndBorrowedRead) {
  ln_outport out = publish("t.zero");
  ln_inport in = subscribe("t.zero");
  handshake(out, in);
  void* buffer = nullptr;
  unsigned length = 0;
  ASSERT_EQ(ln_outport_get_next_buffer(out, &buffer, &length), 0);
  EXPECT_EQ(length, 64u);
  static_cast<P64*>(buffer)->seq = 4242;
  ASSERT_EQ(ln_write(out, buffer, 64, nullptr), 0);

  const void* lent = nullptr;
  unsigned size = 0;
  ln_sample_info info{};
  ASSERT_EQ(ln_read_borrow(in, &lent, &size, &info, 1.0), 1);
  EXPECT_EQ(size, 64u);
  EXPECT_EQ(static_cast<const P64*>(lent)->seq, 4242u);
  // The loan stays intact however much the publisher writes.
  for (uint32_t seq = 0; seq < 50; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
  }
  EXPECT_EQ(static_cast<const P64*>(lent)->seq, 4242u);
  EXPECT_EQ(ln_read_borrow(in, &lent, &size, &info, 0), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_read_release(in), 0);
  EXPECT_EQ(ln_read_release(in), -LNE_INVALID_PARAMETER);
}

TEST_F(TopicTest, MultiWaiterAndPipeNotifier) {
  ln_outport out_a = publish("t.mw.a");
  ln_outport out_b = publish("t.mw.b");
  ln_inport in_a = subscribe("t.mw.a");
  ln_inport in_b = subscribe("t.mw.b");
  handshake(out_a, in_a);
  handshake(out_b, in_b);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(subscriber_, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_a), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_b), 0);
  EXPECT_EQ(ln_multi_waiter_wait(waiter, 0.02), 0);
  const pid_t waiting_thread = ln::test::current_thread_id();
  std::thread writer([&] {
    wait_until([&] { return ln::test::thread_sleeps(waiting_thread); });  // once the wait below sleeps
    P64 p = packet(5);
    ln_write(out_b, &p, sizeof p, nullptr);
  });
  EXPECT_EQ(ln_multi_waiter_wait(waiter, 5.0), 1);
  writer.join();
  EXPECT_EQ(ln_multi_waiter_can_read(waiter, in_a), 0);
  EXPECT_EQ(ln_multi_waiter_can_read(waiter, in_b), 1);
  P64 received{};
  ASSERT_EQ(ln_read(in_b, &received, sizeof received, nullptr, 0), 1);

  ln_pipe_fd_t fd = -1;
  ASSERT_EQ(ln_multi_waiter_start_pipe_notifier_thread(waiter, &fd), 0);
  P64 p = packet(6);
  ln_write(out_a, &p, sizeof p, nullptr);
  pollfd readable{fd, POLLIN, 0};
  ASSERT_EQ(::poll(&readable, 1, 5000), 1);
  ASSERT_EQ(ln_read(in_a, &received, sizeof received, nullptr, 0), 1);
  EXPECT_EQ(received.seq, 6u);
  EXPECT_EQ(ln_multi_waiter_ack_pipe_notification(waiter), 0);
  EXPECT_EQ(ln_multi_waiter_remove_port(waiter, in_a), 0);
  EXPECT_EQ(ln_multi_waiter_remove_port(waiter, in_a), -LNE_PORT_NOT_FOUND);
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
}

// ---- multi-waiter: it sleeps until a port's segment (or the set of
// segments) changes; multi_waiter_test.cpp checks its protocol white-box.

// Starts ln_multi_waiter_wait(waiter, timeout) in another thread; returns once it runs.
std::future<int> wait_async(ln_multi_waiter waiter, double timeout) {
  std::promise<void> started;
  std::future<void> running = started.get_future();
  std::future<int> result = std::async(std::launch::async, [waiter, timeout, &started] {
    started.set_value();
    return ln_multi_waiter_wait(waiter, timeout);
  });
  running.wait();
  return result;
}

// Writes a packet every 2 ms (a subscriber sees only what comes after it
// attached) until `wait` returns; false if it did not within 10 s.
bool write_until_ready(ln_outport out, std::future<int>& wait) {
  const auto deadline = Clock::now() + 10s;
  for (uint32_t seq = 1; Clock::now() < deadline; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
    if (wait.wait_for(2ms) == std::future_status::ready) return true;
  }
  return false;
}

TEST_F(TopicTest, MultiWaiterWakesForAPublisherThatComesLater) {
  ln_outport out_a = publish("t.mw.late.a");
  ln_inport in_a = subscribe("t.mw.late.a");
  ln_inport in_b = subscribe("t.mw.late.b");
  handshake(out_a, in_a);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(subscriber_, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_a), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_b), 0);
  std::future<int> wait = wait_async(waiter, 30);
  EXPECT_NE(wait.wait_for(20ms), std::future_status::ready);
  ln_client late = connect("late_publisher");
  ln_outport out_b = publish("t.mw.late.b", 1, late);
  ASSERT_TRUE(write_until_ready(out_b, wait));
  EXPECT_EQ(wait.get(), 1);
  EXPECT_EQ(ln_multi_waiter_can_read(waiter, in_a), 0);
  EXPECT_EQ(ln_multi_waiter_can_read(waiter, in_b), 1);
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
  ln_deinit(&late);
}

TEST_F(TopicTest, MultiWaiterWakesAfterAPublisherRestart) {
  ln_client first = connect("restarting_publisher");
  ln_outport out = publish("t.mw.restart", 1, first);
  ln_inport in = subscribe("t.mw.restart");
  handshake(out, in);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(subscriber_, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in), 0);
  std::future<int> wait = wait_async(waiter, 30);
  ln_deinit(&first);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 0; }));
  EXPECT_NE(wait.wait_for(0s), std::future_status::ready);
  ln_client second = connect("restarting_publisher");
  ln_outport again = publish("t.mw.restart", 1, second);
  ASSERT_TRUE(write_until_ready(again, wait));
  EXPECT_EQ(wait.get(), 1);
  P64 received{};
  EXPECT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 1);
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
  ln_deinit(&second);
}

// A subscriber with more buffers makes the publisher switch to a bigger
// segment: a port that is only watched follows it.
TEST_F(TopicTest, MultiWaiterFollowsASegmentSwitch) {
  ln_outport out = publish("t.mw.grow", 1);
  ln_inport small = subscribe("t.mw.grow", 1);
  handshake(out, small);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(subscriber_, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, small), 0);
  std::future<int> wait = wait_async(waiter, 30);
  ln_inport big = subscribe("t.mw.grow", 8);
  ASSERT_TRUE(big != nullptr);
  EXPECT_TRUE(wait_until([&] { return ln_has_subscriber(out) == 2; }));
  ASSERT_TRUE(write_until_ready(out, wait));
  EXPECT_EQ(wait.get(), 1);
  // Until what was left in the old segment is read, the waiter sees that;
  // then the new segment's packets.
  P64 p = packet(77);
  ln_write(out, &p, sizeof p, nullptr);
  P64 received{};
  while (ln_multi_waiter_wait(waiter, 5.0) == 1 && ln_read(small, &received, sizeof received, nullptr, 0) == 1 &&
         received.seq != 77) {
  }
  EXPECT_EQ(received.seq, 77u);
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
}

// The old waiter polled: it woke up every millisecond (about 300 times here).
TEST_F(TopicTest, MultiWaiterIdleWaitDoesNotPoll) {
  ln_outport out_a = publish("t.mw.idle.a");
  ln_inport in_a = subscribe("t.mw.idle.a");
  ln_inport in_b = subscribe("t.mw.idle.b");  // no publisher
  handshake(out_a, in_a);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(subscriber_, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_a), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in_b), 0);
  const ThreadUsage before = ThreadUsage::now();
  const auto start = Clock::now();
  EXPECT_EQ(ln_multi_waiter_wait(waiter, 0.3), 0);
  const auto elapsed = Clock::now() - start;
  const ThreadUsage used = ThreadUsage::now() - before;
  EXPECT_GE(elapsed, 295ms);
  EXPECT_LE(used.wakeups, 10) << "the wait woke up " << used.wakeups << " times";
  EXPECT_LT(used.cpu, 2ms) << "the wait used " << used.cpu.count() << " ns of CPU";
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
}

TEST_F(TopicTest, NewPublisherTakesOverAfterUnpublish) {
  ln_outport out = publish("t.takeover");
  ln_inport in = subscribe("t.takeover");
  handshake(out, in);
  ASSERT_EQ(ln_unpublish(&out), 0);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 0; }));
  P64 received{};
  EXPECT_EQ(ln_read(in, &received, sizeof received, nullptr, 0), 0);
  ln_client other = connect("other_publisher");
  ln_outport again = publish("t.takeover", 1, other);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
  ln_sample_info info{};
  bool got = false;
  for (uint32_t seq = 1; !got && seq < 5000; ++seq) {
    P64 p = packet(seq);
    ln_write(again, &p, sizeof p, nullptr);
    got = ln_read_with_info(in, &received, sizeof received, &info, 0.002) == 1;
  }
  EXPECT_TRUE(got);
  EXPECT_EQ(info.lost, 0u);  // a new publisher starts a new count
  ln_deinit(&other);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 0; }));
}

TEST_F(TopicTest, SegmentGrowsForASubscriberWithMoreBuffers) {
  ln_outport out = publish("t.grow", 1);
  ln_inport small = subscribe("t.grow", 1);
  handshake(out, small);
  ln_inport big = subscribe("t.grow", 8);
  // The publisher moves to a bigger segment; both subscribers follow.
  P64 received{};
  bool got = false;
  for (uint32_t seq = 1; !got && seq < 5000; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
    got = ln_read_timeout(big, &received, sizeof received, nullptr, 0.002) == 1;
  }
  ASSERT_TRUE(got);
  while (ln_read(big, &received, sizeof received, nullptr, 0) == 1) {
  }
  for (uint32_t seq = 1; seq <= 8; ++seq) {
    P64 p = packet(seq);
    ln_write(out, &p, sizeof p, nullptr);
  }
  for (uint32_t seq = 1; seq <= 8; ++seq) {
    ASSERT_EQ(ln_read(big, &received, sizeof received, nullptr, 0), 1) << seq;
    EXPECT_EQ(received.seq, seq);
  }
  // The one-buffer subscriber follows the switch: after what was left in the
  // old segment it sees the newest packet of the new one.
  received.seq = 0;
  while (received.seq != 8 && ln_read_timeout(small, &received, sizeof received, nullptr, 1.0) == 1) {
  }
  EXPECT_EQ(received.seq, 8u);
}

// A publisher that waits for ln_has_subscriber() and then writes at once
// must not lose the first packets at a local subscriber whose buffers hold
// them all: has_subscriber may turn true before the subscriber has the
// segment, so the publisher has to hand it over from that point on.
class WaitingPublisherTest : public TopicTest {
 protected:
  static constexpr uint32_t kCount = 200;
  static constexpr unsigned kBuffers = 256;

  // Waits (bounded) for has_subscriber, writes kCount packets first.. back to
  // back, and expects the subscriber to read exactly these, in order.
  void write_after_has_subscriber_and_read_all(ln_outport out, ln_inport in, uint32_t first) {
    ASSERT_TRUE(wait_until([&] { return ln_has_subscriber(out) > 0; }));
    for (uint32_t seq = first; seq < first + kCount; ++seq) {
      P64 p = packet(seq);
      ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
    }
    std::vector<uint32_t> received;
    for (uint32_t i = 0; i < kCount; ++i) {
      P64 p{};
      if (ln_read_timeout(in, &p, sizeof p, nullptr, 2.0) != 1) break;
      received.push_back(p.seq);
    }
    std::vector<uint32_t> expected(kCount);
    for (uint32_t i = 0; i < kCount; ++i) expected[i] = first + i;
    ASSERT_FALSE(received.empty()) << "nothing received";
    EXPECT_EQ(received.front(), first) << "the first " << received.front() - first << " packets were lost";
    EXPECT_EQ(received, expected);
    P64 extra{};
    EXPECT_EQ(ln_read(in, &extra, sizeof extra, nullptr, 0), 0) << "unexpected packet " << extra.seq;
  }
};

TEST_F(WaitingPublisherTest, LosesNothingToASubscriberThatCameFirst) {
  ln_inport in = subscribe("t.join.first", kBuffers);
  ln_outport out = publish("t.join.first", 1);
  ASSERT_TRUE(in && out);
  write_after_has_subscriber_and_read_all(out, in, 1);
}

TEST_F(WaitingPublisherTest, LosesNothingToASubscriberThatCameLater) {
  ln_outport out = publish("t.join.later", 1);  // grows to the subscriber's buffers
  ln_inport in = subscribe("t.join.later", kBuffers);
  ASSERT_TRUE(in && out);
  write_after_has_subscriber_and_read_all(out, in, 1);
}

// As in the benchmark that found the loss: the publisher has written before
// (so its newest sequence is not 0). The subscriber gets nothing from before
// has_subscriber turned true (no latched value), and everything after.
TEST_F(WaitingPublisherTest, LosesNothingAfterEarlierWritesAndGetsNoneOfThem) {
  ln_outport out = publish("t.join.written", kBuffers);
  ASSERT_TRUE(out);
  for (uint32_t seq = 1; seq <= 64; ++seq) {
    P64 p = packet(seq);
    ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
  }
  ln_inport in = subscribe("t.join.written", kBuffers);
  ASSERT_TRUE(in);
  write_after_has_subscriber_and_read_all(out, in, 1001);
}

// A second subscriber joins while the first one already reads: the
// publisher's count going from 1 to 2 is what "has a subscriber" means for
// the newcomer, and everything written after it must reach it.
TEST_F(WaitingPublisherTest, ASecondSubscriberGetsEverythingAfterTheCountRose) {
  ln_outport out = publish("t.join.second", 1);
  ln_inport first = subscribe("t.join.second", 1);
  ASSERT_TRUE(out && first);
  handshake(out, first);
  ln_client other = connect("second");
  ln_inport in = nullptr;
  ASSERT_EQ(ln_subscribe_with_buffers(other, "t.join.second", "test/p64", &in, RATE_AS_PUBLISHED, 0, kBuffers), 0);
  ASSERT_TRUE(wait_until([&] { return ln_has_subscriber(out) == 2; }));
  write_after_has_subscriber_and_read_all(out, in, 1);
  ln_deinit(&other);
}

// The other side of the same hand-over: a subscriber gets its first packet
// only once the publisher counts it, also when both are one client (whose
// I/O thread may serve the subscriber's open_segment before the manager's
// subscribers_changed).
TEST_F(WaitingPublisherTest, NoPacketArrivesBeforeThePublisherCountsTheSubscriber) {
  for (int round = 0; round < 10; ++round) {
    for (ln_client subscribing : {publisher_, subscriber_}) {
      const std::string topic = "t.join.counted." + std::to_string(round) + (subscribing == publisher_ ? "a" : "b");
      ln_outport out = publish(topic.c_str(), 1);
      ln_inport in = nullptr;
      ASSERT_EQ(ln_subscribe_with_buffers(subscribing, topic.c_str(), "test/p64", &in, RATE_AS_PUBLISHED, 0, 4), 0);
      bool got = false;
      for (uint32_t seq = 1; !got && seq < 2000; ++seq) {
        P64 p = packet(seq);
        ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
        got = ln_read_timeout(in, &p, sizeof p, nullptr, 0.005) == 1;
      }
      ASSERT_TRUE(got) << topic;
      EXPECT_EQ(ln_has_subscriber(out), 1) << topic;
      EXPECT_EQ(ln_unsubscribe(&in), 0);
      EXPECT_EQ(ln_unpublish(&out), 0);
    }
  }
}

TEST_F(TopicTest, TopicNameMappingFromArguments) {
  const std::string address = manager_.address();
  std::vector<const char*> argv = {"prog",           "--ln-manager", address.c_str(),
                                   "--ln-map-topic", "^sensor.",     "robot2.sensor."};
  ln_client mapped = nullptr;
  ASSERT_EQ(ln_init(&mapped, "mapped", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  ln_outport out = publish("sensor.temp", 1, mapped);
  ln_inport in = subscribe("robot2.sensor.temp");
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
  handshake(out, in);
  ln_deinit(&mapped);
}

// LN 2.9's order (tests/ln29_behaviour/test_ln29b_services.py checks it).
TEST_F(TopicTest, TopicNameMappingFromArgumentsThenEnvironment) {
  ScopedEnv mapping("LN_MAP_TOPICS", std::string(".left$|.front|nothing|matters"));
  const std::string address = manager_.address();
  std::vector<const char*> argv = {"prog", "--ln-manager", address.c_str(), "-ln_map_topic", "^cam$", "camera.left"};
  ln_client mapped = nullptr;
  ASSERT_EQ(ln_init(&mapped, "env_mapped", static_cast<int>(argv.size()), const_cast<char**>(argv.data())), 0);
  ln_outport out = publish("cam", 1, mapped);  // cam -> camera.left -> camera.front
  ln_inport in = subscribe("camera.front");
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(in) == 1; }));
  handshake(out, in);
  char* md_name = nullptr;
  char* text = nullptr;
  unsigned size = 0;
  ASSERT_EQ(ln_get_message_definition_for_topic(mapped, "cam", &md_name, &text, &size), 0);
  EXPECT_STREQ(md_name, "test/p64");
  std::free(md_name);
  std::free(text);
  ln_deinit(&mapped);
}

// A client that believes it is on another host (LN_CORE_HOST_ID) receives
// over the network (loopback here): UDP, or TCP when it asks for reliability.
class RemoteTopicTest : public TopicTest {
 protected:
  ln_client remote_client() {
    ScopedEnv elsewhere("LN_CORE_HOST_ID", std::string("another-host/1"));
    return connect("remote_subscriber");
  }
  /// `remote`'s subscription of `topic` over TCP (`reliable` 1) or UDP (0), at most `rate` packets
  /// per second (-1: all).
  static ln_inport subscribe_remote(ln_client remote, const char* topic, int reliable, unsigned buffers,
                                    double rate = -1, const char* definition = "test/p64") {
    ln_inport in = nullptr;
    EXPECT_EQ(ln_subscribe_with_buffers(remote, topic, definition, &in, rate, reliable, buffers), 0)
        << ln_get_error_message(remote);
    return in;
  }
  void expect_in_order(ln_outport out, ln_inport in, uint32_t count) {
    P64 received{};
    // Packets sent before the publisher knew this subscriber are not delivered.
    bool flowing = false;
    for (uint32_t seq = 1000000; !flowing && seq < 1000000 + 5000; ++seq) {
      P64 p = packet(seq);
      ln_write(out, &p, sizeof p, nullptr);
      flowing = ln_read_timeout(in, &received, sizeof received, nullptr, 0.002) == 1;
    }
    ASSERT_TRUE(flowing);
    while (ln_read_timeout(in, &received, sizeof received, nullptr, 0.05) == 1) {
    }
    for (uint32_t seq = 1; seq <= count; ++seq) {
      P64 p = packet(seq);
      ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
      if (seq % 32 == 0) std::this_thread::sleep_for(1ms);  // UDP: stay within the socket buffers
    }
    for (uint32_t seq = 1; seq <= count; ++seq) {
      ASSERT_EQ(ln_read_timeout(in, &received, sizeof received, nullptr, 5.0), 1) << seq;
      ASSERT_EQ(received.seq, seq);
      ASSERT_EQ(received.pad[59], seq & 0xff);
    }
  }
};

TEST_F(RemoteTopicTest, UdpAndTcpDeliverInOrder) {
  ln_client remote = remote_client();
  ln_outport out = publish("r.data", 1);
  ln_inport over_udp = subscribe_remote(remote, "r.data", 0, 256);
  ln_inport over_tcp = subscribe_remote(remote, "r.data", 1, 256);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(over_udp) == 1 && ln_has_subscriber(out) == 2; }));
  expect_in_order(out, over_tcp, 200);
  expect_in_order(out, over_udp, 200);
  EXPECT_EQ(ln_unpublish(&out), 0);
  EXPECT_TRUE(wait_until([&] { return ln_has_publisher(over_tcp) == 0; }));
  ln_deinit(&remote);
}

// A remote publisher's packets come through the subscription's inbox ring.
TEST_F(RemoteTopicTest, MultiWaiterWakesForRemotePackets) {
  ln_client remote = remote_client();
  ln_outport out = publish("r.mw", 1);
  ln_inport in = subscribe_remote(remote, "r.mw", 1, 4);
  ln_multi_waiter waiter = nullptr;
  ASSERT_EQ(ln_multi_waiter_init(remote, &waiter), 0);
  ASSERT_EQ(ln_multi_waiter_add_port(waiter, in), 0);
  std::future<int> wait = wait_async(waiter, 30);
  ASSERT_TRUE(write_until_ready(out, wait));
  EXPECT_EQ(wait.get(), 1);
  EXPECT_EQ(ln_multi_waiter_can_read(waiter, in), 1);
  EXPECT_EQ(ln_multi_waiter_deinit(&waiter), 0);
  ln_deinit(&remote);
}

TEST_F(RemoteTopicTest, LargePacketsAreFragmentedAndReassembled) {
  ln_client remote = remote_client();
  ln_outport out = nullptr;
  ASSERT_EQ(ln_publish(publisher_, "r.big", "test/big", &out), 0);
  ln_inport over_udp = subscribe_remote(remote, "r.big", 0, 4, -1, "test/big");
  ln_inport over_tcp = subscribe_remote(remote, "r.big", 1, 4, -1, "test/big");
  std::vector<uint8_t> sent(1 << 20), received(1 << 20);
  for (size_t i = 0; i < sent.size(); ++i) sent[i] = static_cast<uint8_t>(i * 7);
  for (ln_inport in : {over_tcp, over_udp}) {
    bool got = false;
    for (int attempt = 0; !got && attempt < 200; ++attempt) {
      ln_write(out, sent.data(), static_cast<unsigned>(sent.size()), nullptr);
      got = ln_read_timeout(in, received.data(), static_cast<unsigned>(received.size()), nullptr, 0.05) == 1;
    }
    ASSERT_TRUE(got);
    EXPECT_EQ(received, sent);
  }
  ln_deinit(&remote);
}

TEST_F(RemoteTopicTest, RateLimitAppliesToRemoteSubscribers) {
  ln_client remote = remote_client();
  ln_outport out = publish("r.rate", 64);
  ln_inport in = subscribe_remote(remote, "r.rate", 1, 64, 10.0);
  P64 received{};
  bool flowing = false;
  for (uint32_t i = 0; !flowing && i < 5000; ++i) {
    P64 p = packet(1000000 + i);
    double ts = 50.0 + i * 1.0;  // far apart: all pass
    ln_write(out, &p, sizeof p, &ts);
    flowing = ln_read_timeout(in, &received, sizeof received, nullptr, 0.002) == 1;
  }
  ASSERT_TRUE(flowing);
  while (ln_read_timeout(in, &received, sizeof received, nullptr, 0.05) == 1) {
  }
  for (uint32_t i = 0; i < 40; ++i) {
    P64 p = packet(i);
    double ts = 100000.0 + i * 0.0100001;
    ASSERT_EQ(ln_write(out, &p, sizeof p, &ts), 0);
  }
  std::vector<uint32_t> seen;
  while (ln_read_timeout(in, &received, sizeof received, nullptr, 0.3) == 1) seen.push_back(received.seq);
  EXPECT_EQ(seen, (std::vector<uint32_t>{0, 10, 20, 30}));
  ln_deinit(&remote);
}

TEST_F(RemoteTopicTest, RemoteSubscriptionSurvivesManagerRestart) {
  ln_client remote = remote_client();
  ln_outport out = publish("r.restart", 1);
  ln_inport in = subscribe_remote(remote, "r.restart", 1, 64);
  expect_in_order(out, in, 20);
  manager_.restart();
  EXPECT_TRUE(wait_until([&] { return ln_ping(remote, 1.0, nullptr) == 0 && ln_ping(publisher_, 1.0, nullptr) == 0; }));
  // Subscription ids are new now; the data finds its way again.
  expect_in_order(out, in, 20);
  ln_deinit(&remote);
}

TEST_F(TopicTest, ManagerRestartKeepsDataFlowingAndReconnects) {
  ln_outport out = publish("t.restart");
  ln_inport in = subscribe("t.restart");
  handshake(out, in);
  manager_.stop();

  // Set-up fails fast while the manager is away; data keeps flowing.
  EXPECT_TRUE(wait_until([&] { return ln_ping(publisher_, 0, nullptr) == -LNE_LOST_CONNECTION; }));
  ln_inport refused = nullptr;
  const auto start = Clock::now();
  EXPECT_EQ(ln_subscribe(subscriber_, "t.other", "test/p64", &refused, -1, 0), -LNE_LOST_CONNECTION);
  EXPECT_LT(Clock::now() - start, 1s);  // at once (room for a loaded machine), no waiting for the manager
  EXPECT_NE(std::string(ln_get_error_message(subscriber_)).find("ln_manager"), std::string::npos);
  P64 p = packet(77), received{};
  ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
  ASSERT_EQ(ln_read(in, &received, sizeof received, nullptr, 1), 1);
  EXPECT_EQ(received.seq, 77u);

  manager_.restart();
  EXPECT_TRUE(
      wait_until([&] { return ln_ping(publisher_, 1.0, nullptr) == 0 && ln_ping(subscriber_, 1.0, nullptr) == 0; }));
  char* name = nullptr;
  ln_client_get_name(publisher_, &name);
  EXPECT_STREQ(name, "publisher");  // the old name is granted again
  EXPECT_TRUE(wait_until([&] { return ln_has_subscriber(out) == 1 && ln_has_publisher(in) == 1; }));

  // No gap on the old subscription, and new subscriptions work.
  p = packet(78);
  ASSERT_EQ(ln_write(out, &p, sizeof p, nullptr), 0);
  ln_sample_info info{};
  ASSERT_EQ(ln_read_with_info(in, &received, sizeof received, &info, 1.0), 1);
  EXPECT_EQ(received.seq, 78u);
  EXPECT_EQ(info.lost, 0u);
  ln_client late = connect("late");
  ln_inport late_in = nullptr;
  ASSERT_EQ(ln_subscribe(late, "t.restart", "test/p64", &late_in, -1, 0), 0) << ln_get_error_message(late);
  handshake(out, late_in);
  ln_deinit(&late);
}

}  // namespace
