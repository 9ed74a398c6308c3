// White-box tests of the multi-waiter without a manager: segments are handed
// to the ports as the I/O thread would (see ports_test.cpp), and the
// publishers are ShmWriters in this process, written from this thread while
// another one waits. Waiting for the other side is a condition with a
// deadline, never a fixed sleep.
#include "client/multi_waiter.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>

#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "client/error_slot.hpp"
#include "client/ports.hpp"
#include "client/test_waiting.hpp"

namespace ln::clientlib {
namespace {

using namespace std::chrono_literals;
using clienttest::Clock;
using clienttest::ThreadUsage;
using clienttest::wait_until;

#ifndef SYS_futex_waitv
#define SYS_futex_waitv 449
#endif

// Whether this kernel has futex_waitv (Linux >= 5.16, not filtered by
// seccomp): an empty call answers EINVAL there, ENOSYS elsewhere. Without it
// the waiter polls, so the tests that watch it sleep on the segments' futexes
// do not apply.
bool kernel_has_futex_waitv() {
  errno = 0;
  return !(::syscall(SYS_futex_waitv, nullptr, 0u, 0u, nullptr, CLOCK_MONOTONIC) < 0 && errno == ENOSYS);
}
constexpr const char* kNoFutexWaitv = "this kernel has no futex_waitv (Linux < 5.16): the waiter polls";

struct Packet {
  std::uint32_t seq;
  std::uint8_t pad[60];
};

// A publisher in this process: one segment at a time, handed to one port.
struct Publisher {
  explicit Publisher(std::string peer_socket) : socket(std::move(peer_socket)) {}
  std::string socket;
  std::int64_t generation = 0;
  std::optional<transport::ShmWriter> writer;

  void start(InPort& port, std::uint64_t first_sequence = 1) {
    writer.emplace(transport::ShmWriter::create({sizeof(Packet), 4, 1, first_sequence, "multi_waiter_test"}));
    offer(port);
  }
  void offer(InPort& port, std::optional<std::uint64_t> written_before = std::nullopt) {
    port.offer_segment(UniqueFd(::fcntl(writer->fd(), F_DUPFD_CLOEXEC, 0)), {socket, ++generation}, 4,
                       written_before.value_or(writer->last_sequence()));
  }
  void write(std::uint32_t seq) {
    Packet packet{};
    packet.seq = seq;
    ASSERT_EQ(writer->write(&packet, sizeof packet), transport::WriteStatus::ok);
  }
  bool waiter_asleep() const { return writer && writer->sleeping_readers() > 0; }
};

class MultiWaiterTest : public ::testing::Test {
 protected:
  static constexpr int kPorts = 3;

  MultiWaiterTest() {
    for (int i = 0; i < kPorts; ++i) {
      ports_.push_back(std::make_unique<InPort>(errors_, "t.mw." + std::to_string(i), "test/p64", -1, 1, false));
      publishers_.emplace_back("peer" + std::to_string(i));
    }
  }
  void TearDown() override { MultiWaiter::simulate_missing_futex_waitv(false); }

  void add_all() {
    for (auto& port : ports_) waiter_->add_port(port.get());
  }
  // Starts a wait with `timeout` in another thread.
  std::future<int> wait_async(double timeout) {
    return std::async(std::launch::async, [this, timeout] { return waiter_->wait(timeout); });
  }
  // Sequence number of the next packet on port i, or 0.
  std::uint32_t read(int i) {
    Packet packet{};
    return ports_[i]->read(&packet, sizeof packet, nullptr, 0) == 1 ? packet.seq : 0;
  }
  // What a wait (or read) in another thread returned; kNoResult if it did not return within 10 s.
  static constexpr int kNoResult = -1000;
  static int result(std::future<int>& wait) {
    return wait.wait_for(10s) == std::future_status::ready ? wait.get() : kNoResult;
  }
  // True once the pipe notifier's descriptor is readable (within 10 s).
  static bool notified(int fd) {
    pollfd readable{fd, POLLIN, 0};
    return ::poll(&readable, 1, 10000) == 1;
  }
  // Destroys the waiter, which stops its notifier thread; false if that took a second or more.
  bool destroyed_promptly() {
    const auto start = Clock::now();
    waiter_.reset();
    return Clock::now() - start < 1s;
  }

  ErrorSlot errors_;
  std::vector<std::unique_ptr<InPort>> ports_;
  std::vector<Publisher> publishers_;
  std::unique_ptr<MultiWaiter> waiter_ = std::make_unique<MultiWaiter>(nullptr);
};

TEST_F(MultiWaiterTest, UsesFutexWaitvHere) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  EXPECT_TRUE(MultiWaiter::event_driven());
}

TEST_F(MultiWaiterTest, WakesOnAPacketOnAnyPort) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  for (int i = 0; i < kPorts; ++i) publishers_[i].start(*ports_[i]);
  add_all();
  EXPECT_EQ(waiter_->wait(0), 0);
  for (int round = 0; round < 3 * kPorts; ++round) {
    const int i = round % kPorts;
    std::future<int> wait = wait_async(20);
    // Asleep on every segment (or about to be: the protocol covers that too).
    ASSERT_TRUE(wait_until([&] {
      for (const Publisher& publisher : publishers_)
        if (!publisher.waiter_asleep()) return false;
      return true;
    }));
    publishers_[i].write(100 + round);
    EXPECT_EQ(result(wait), 1) << "round " << round;
    for (int j = 0; j < kPorts; ++j) EXPECT_EQ(waiter_->can_read(ports_[j].get()), j == i);
    EXPECT_EQ(read(i), static_cast<std::uint32_t>(100 + round));
  }
  for (const Publisher& publisher : publishers_) EXPECT_EQ(publisher.writer->sleeping_readers(), 0u);
}

TEST_F(MultiWaiterTest, CountsEveryReadablePort) {
  for (int i = 0; i < kPorts; ++i) publishers_[i].start(*ports_[i]);
  add_all();
  publishers_[0].write(1);
  publishers_[2].write(1);
  EXPECT_EQ(waiter_->wait(0), 2);
  EXPECT_EQ(waiter_->wait(5), 2);
  EXPECT_EQ(waiter_->wait(-1), 2);
}

// A port without a publisher: only the hand-over of a segment can wake the
// waiter (the packet was written before, nothing is written after).
TEST_F(MultiWaiterTest, WakesWhenAPortWithoutSegmentGetsOne) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  add_all();
  std::future<int> wait = wait_async(20);
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep(); }));
  Publisher& late = publishers_[1];
  late.writer.emplace(transport::ShmWriter::create({sizeof(Packet), 4, 1, 1, "multi_waiter_test"}));
  late.write(7);
  late.offer(*ports_[1], 0);
  EXPECT_EQ(result(wait), 1);
  EXPECT_EQ(read(1), 7u);
}

// The same publisher moves to a bigger segment (see "Switching segments" in
// shm_ring.hpp): a port that is only watched, never read, must follow it,
// whichever of the hand-over and the close comes first.
TEST_F(MultiWaiterTest, FollowsThePublisherToItsNextSegment) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  for (const bool offer_first : {true, false}) {
    SCOPED_TRACE(offer_first ? "offered before the close" : "offered after the close");
    InPort port(errors_, "t.mw.switch", "test/p64", -1, 1, false);
    Publisher publisher("switching");
    publisher.start(port);
    MultiWaiter waiter(nullptr);
    waiter.add_port(&port);
    publisher.write(1);
    ASSERT_EQ(waiter.wait(0), 1);
    Packet packet{};
    ASSERT_EQ(port.read(&packet, sizeof packet, nullptr, 0), 1);

    std::future<int> wait = std::async(std::launch::async, [&] { return waiter.wait(20); });
    ASSERT_TRUE(wait_until([&] { return publisher.waiter_asleep(); }));
    transport::ShmWriter old = std::move(*publisher.writer);
    publisher.writer.emplace(
        transport::ShmWriter::create({sizeof(Packet), 8, 1, old.last_sequence() + 1, "multi_waiter_test"}));
    if (offer_first) publisher.offer(port);
    old.close_replaced();
    if (!offer_first) {
      // The waiter wakes for the close, finds nothing new and sleeps again
      // (most likely within this time; the test holds either way).
      EXPECT_NE(wait.wait_for(20ms), std::future_status::ready);
      publisher.offer(port);
    }
    publisher.write(2);
    EXPECT_EQ(result(wait), 1);
    ASSERT_EQ(port.read(&packet, sizeof packet, nullptr, 0), 1);
    EXPECT_EQ(packet.seq, 2u);
  }
}

// A publisher that closes and comes back as another peer with a new segment.
TEST_F(MultiWaiterTest, WakesForARestartedPublisher) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  waiter_->add_port(ports_[0].get());
  std::future<int> wait = wait_async(20);
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep(); }));
  publishers_[0].writer->close();
  publishers_[0].writer.reset();
  Publisher restarted("peer0-restarted");
  restarted.start(*ports_[0]);
  ASSERT_TRUE(wait_until([&] { return restarted.waiter_asleep(); }));
  EXPECT_NE(wait.wait_for(0s), std::future_status::ready);
  restarted.write(1);
  EXPECT_EQ(result(wait), 1);
  EXPECT_EQ(read(0), 1u);
}

// An idle wait sleeps in the kernel: the old polling waiter woke up every
// millisecond (about 300 times here) and spent several ms of CPU.
TEST_F(MultiWaiterTest, IdleWaitDoesNotPoll) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  publishers_[1].start(*ports_[1]);
  add_all();  // port 2 has no segment
  const ThreadUsage before = ThreadUsage::now();
  const auto start = Clock::now();
  EXPECT_EQ(waiter_->wait(0.3), 0);
  const auto elapsed = Clock::now() - start;
  const ThreadUsage used = ThreadUsage::now() - before;
  EXPECT_GE(elapsed, 295ms);
  EXPECT_LT(elapsed, 5s);
  EXPECT_LE(used.wakeups, 10) << "the wait woke up " << used.wakeups << " times";
  EXPECT_LT(used.cpu, 2ms) << "the wait used " << used.cpu.count() << " ns of CPU";
}

TEST_F(MultiWaiterTest, AddingAReadablePortWakesAWait) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  publishers_[1].start(*ports_[1]);
  waiter_->add_port(ports_[0].get());
  std::future<int> wait = wait_async(20);
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep(); }));
  publishers_[1].write(3);
  waiter_->add_port(ports_[1].get());
  EXPECT_EQ(result(wait), 1);
}

TEST_F(MultiWaiterTest, RemovingAPortStopsWatchingItsSegment) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  publishers_[1].start(*ports_[1]);
  add_all();
  std::future<int> wait = wait_async(20);
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep() && publishers_[1].waiter_asleep(); }));
  EXPECT_TRUE(waiter_->remove_port(ports_[0].get()));
  EXPECT_TRUE(wait_until([&] { return !publishers_[0].waiter_asleep(); }));
  publishers_[0].write(1);  // not watched any more
  EXPECT_NE(wait.wait_for(50ms), std::future_status::ready);
  publishers_[1].write(1);
  EXPECT_EQ(result(wait), 1);
}

// While another thread reads a port, the waiter cannot check it: it falls
// back to short sleeps and still sees packets on the other ports at once.
TEST_F(MultiWaiterTest, APortReadByAnotherThreadCountsAsNotReadable) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  publishers_[1].start(*ports_[1]);
  add_all();
  std::future<int> reading = std::async(std::launch::async, [&] {
    Packet packet{};
    return ports_[0]->read(&packet, sizeof packet, nullptr, 20);
  });
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep(); }));  // the blocked read
  EXPECT_EQ(waiter_->wait(0.05), 0);
  std::future<int> wait = wait_async(20);
  ASSERT_TRUE(wait_until([&] { return publishers_[1].waiter_asleep(); }));
  publishers_[1].write(1);
  EXPECT_EQ(result(wait), 1);
  publishers_[0].write(1);
  EXPECT_EQ(result(reading), 1);
}

TEST_F(MultiWaiterTest, PipeNotifierNotifiesOnceAndStopsPromptly) {
  if (!kernel_has_futex_waitv()) GTEST_SKIP() << kNoFutexWaitv;
  publishers_[0].start(*ports_[0]);
  publishers_[1].start(*ports_[1]);
  add_all();
  const int fd = waiter_->start_pipe_notifier();
  ASSERT_GE(fd, 0);
  EXPECT_EQ(waiter_->start_pipe_notifier(), fd);
  pollfd readable{fd, POLLIN, 0};
  EXPECT_EQ(::poll(&readable, 1, 50), 0);
  ASSERT_TRUE(wait_until([&] { return publishers_[1].waiter_asleep(); }));
  publishers_[1].write(1);
  ASSERT_TRUE(notified(fd));
  // One notification until acknowledged, even with more packets.
  publishers_[0].write(1);
  EXPECT_EQ(read(1), 1u);
  EXPECT_EQ(waiter_->acknowledge(), 0);
  ASSERT_TRUE(notified(fd));  // port 0 is still readable
  EXPECT_EQ(read(0), 1u);
  EXPECT_EQ(waiter_->acknowledge(), 0);

  // Idle, asleep without a time limit: destruction wakes it.
  ASSERT_TRUE(wait_until([&] { return publishers_[0].waiter_asleep() && publishers_[1].waiter_asleep(); }));
  EXPECT_TRUE(destroyed_promptly());
  EXPECT_FALSE(publishers_[0].waiter_asleep());
}

TEST_F(MultiWaiterTest, PipeNotifierStopsPromptlyWhileWaitingForItsAcknowledgement) {
  publishers_[0].start(*ports_[0]);
  waiter_->add_port(ports_[0].get());
  const int fd = waiter_->start_pipe_notifier();
  publishers_[0].write(1);
  ASSERT_TRUE(notified(fd));
  EXPECT_TRUE(destroyed_promptly());
}

// Without futex_waitv (ENOSYS), waits poll: they still see every packet, and
// they wake up often while idle, which shows that the fallback runs.
TEST_F(MultiWaiterTest, PollsWhereFutexWaitvIsMissing) {
  MultiWaiter::simulate_missing_futex_waitv(true);
  for (int i = 0; i < kPorts; ++i) publishers_[i].start(*ports_[i]);
  add_all();
  const ThreadUsage before = ThreadUsage::now();
  EXPECT_EQ(waiter_->wait(0.1), 0);
  const ThreadUsage used = ThreadUsage::now() - before;
  EXPECT_FALSE(MultiWaiter::event_driven());
  EXPECT_GT(used.wakeups, 20);
  for (int i = 0; i < kPorts; ++i) {
    std::future<int> wait = wait_async(20);
    EXPECT_NE(wait.wait_for(5ms), std::future_status::ready);
    publishers_[i].write(1);
    EXPECT_EQ(result(wait), 1);
    EXPECT_EQ(read(i), 1u);
  }
  const int fd = waiter_->start_pipe_notifier();
  publishers_[2].write(2);
  ASSERT_TRUE(notified(fd));
  EXPECT_TRUE(destroyed_promptly());

  MultiWaiter::simulate_missing_futex_waitv(false);
  EXPECT_TRUE(MultiWaiter::event_driven());
}

}  // namespace
}  // namespace ln::clientlib
