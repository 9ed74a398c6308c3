// The shared-memory ring across processes: descriptors passed over a
// socket, many subscribers, no torn copies under load, dead borrowers.
// Children arm alarm() as a last resort and are reaped by their test.
#include "transport/shm_ring_test_support.hpp"

namespace ln::transport {
namespace {

using namespace ringtest;

// ------------------------------------------------------------------ cross-process

TEST(ShmRingCrossProcess, DescriptorPassingOverSocketpair) {
  SocketPair sockets;
  ShmWriter writer = ShmWriter::create(config(128, 4));
  Child subscriber([&] {
    ReaderOptions options = with_buffers(4);
    ShmReader reader = ShmReader::attach(receive_fd(sockets.child.get()), options);
    send_byte(sockets.child.get(), 'a');
    std::vector<std::byte> buffer(128);
    SampleInfo info;
    for (std::uint64_t s = 1; s <= 3; ++s) {
      if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
      if (info.sequence != s || info.lost != 0 || buffer != packet(128, s)) return 3;
    }
    return 0;
  });
  send_fd(sockets.parent.get(), writer.fd());
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'a');
  write_packets(writer, 1, 3, 128);
  EXPECT_EQ(subscriber.wait(), 0);
}

TEST(ShmRingCrossProcess, ReceiveFdErrors) {
  {
    SocketPair sockets;
    send_byte(sockets.child.get());  // data without a descriptor
    EXPECT_THROW(receive_fd(sockets.parent.get()), ShmError);
  }
  {
    SocketPair sockets;
    sockets.child.reset();
    EXPECT_THROW(receive_fd(sockets.parent.get()), ShmError);
  }
}

TEST(ShmRingCrossProcess, ManySubscribersGetEveryPacketInOrder) {
  constexpr int kSubscribers = 4;
  constexpr std::uint64_t kPackets = 2000;
  ShmWriter writer = ShmWriter::create(config(96, kPackets, 0));
  std::vector<std::unique_ptr<SocketPair>> sockets;
  std::vector<std::unique_ptr<Child>> children;
  for (int i = 0; i < kSubscribers; ++i) {
    sockets.push_back(std::make_unique<SocketPair>());
    SocketPair& pair = *sockets.back();
    children.push_back(std::make_unique<Child>([&pair] {
      ReaderOptions options;
      options.buffers = static_cast<std::uint32_t>(kPackets);
      ShmReader reader = ShmReader::attach(receive_fd(pair.child.get()), options);
      send_byte(pair.child.get(), 'a');
      std::vector<std::byte> buffer(96);
      SampleInfo info;
      for (std::uint64_t s = 1; s <= kPackets; ++s) {
        if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
        if (info.sequence != s || info.lost != 0 || !pattern_intact(buffer.data(), 96, s)) return 3;
      }
      std::vector<std::byte> rest(96);
      return reader.read(rest.data(), rest.size(), info, 10s) == ReadStatus::publisher_gone ? 0 : 4;
    }));
  }
  for (auto& pair : sockets) {
    send_fd(pair->parent.get(), writer.fd());
    ASSERT_EQ(receive_byte(pair->parent.get(), 10s), 'a');
  }
  std::vector<std::byte> buffer(96);
  for (std::uint64_t s = 1; s <= kPackets; ++s) {
    fill_pattern(buffer.data(), buffer.size(), s);
    ASSERT_EQ(writer.write(buffer.data(), buffer.size()), WriteStatus::ok);
  }
  writer.close();
  for (auto& child : children) EXPECT_EQ(child->wait(), 0);
}

// A publisher child writes patterned packets as fast as it can until the
// parent has checked `target` packets (or 3 s passed); the parent checks
// every byte of everything it receives.

struct HammerResult {
  std::uint64_t received = 0;
  std::uint64_t torn = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t bad_loss_count = 0;
  ReaderStats stats;
};

HammerResult hammer(std::uint32_t message_size, std::uint32_t history, std::uint32_t borrow_slots, bool borrow,
                    bool zero_copy_writes, std::uint32_t optimistic_copies = 3, std::uint64_t target = 2000) {
  SocketPair sockets;
  Child publisher([&] {
    ShmWriter writer = ShmWriter::create(config(message_size, history, borrow_slots));
    send_fd(sockets.child.get(), writer.fd());
    if (receive_byte(sockets.child.get(), 10s) != 'a') return 2;
    std::vector<unsigned char> staging(message_size);
    const auto end = Clock::now() + 3s;
    while (Clock::now() < end) {
      if (writer.last_sequence() % 64 == 0 && receive_byte(sockets.child.get(), 0ms) == 's') break;
      const std::uint64_t sequence = writer.last_sequence() + 1;
      if (zero_copy_writes) {
        void* slot = writer.loan();
        if (slot == nullptr) return 3;
        fill_pattern(slot, message_size, sequence);
        if (writer.commit(message_size) != WriteStatus::ok) return 4;
      } else {
        fill_pattern(staging.data(), message_size, sequence);
        if (writer.write(staging.data(), message_size) != WriteStatus::ok) return 5;
      }
    }
    return 0;  // the destructor closes the segment
  });

  ReaderOptions options = with_buffers(history);
  options.on_lag = LagPolicy::keep_latest_window;
  options.optimistic_copies = optimistic_copies;
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()), options);
  UnblockAfter bound(reader, 30s);
  send_byte(sockets.parent.get(), 'a');
  HammerResult result;
  std::vector<unsigned char> buffer(message_size);
  std::uint64_t previous = 0;
  for (;;) {
    SampleInfo info;
    ReadStatus status;
    if (borrow) {
      BorrowedSample sample;
      status = reader.borrow(sample, 5s);
      if (status != ReadStatus::ok) break;
      info = sample.info();
      bool intact = pattern_intact(sample.data(), message_size, info.sequence);
      for (int i = 0; i < 2000; ++i) std::atomic_signal_fence(std::memory_order_seq_cst);  // hold it a moment
      intact = intact && pattern_intact(sample.data(), message_size, info.sequence);
      if (!intact) ++result.torn;
    } else {
      status = reader.read(buffer.data(), buffer.size(), info, kWaitForever);  // ends when the publisher closes
      if (status != ReadStatus::ok) break;
      if (!pattern_intact(buffer.data(), message_size, info.sequence)) ++result.torn;
    }
    if (++result.received == target) send_byte(sockets.parent.get(), 's');
    if (info.sequence <= previous) ++result.out_of_order;
    if (previous != 0 && info.lost != info.sequence - previous - 1) ++result.bad_loss_count;
    previous = info.sequence;
  }
  EXPECT_EQ(publisher.wait(), 0);
  result.stats = reader.stats();
  return result;
}

void expect_clean(const HammerResult& result) {
  EXPECT_GE(result.received, 50u);  // normally the target; a heavily loaded machine gets fewer
  EXPECT_EQ(result.torn, 0u);
  EXPECT_EQ(result.out_of_order, 0u);
  EXPECT_EQ(result.bad_loss_count, 0u);
  std::printf("    received %llu, torn copies retried %llu, pinned copies %llu, streamed copies %llu\n",
              static_cast<unsigned long long>(result.received),
              static_cast<unsigned long long>(result.stats.torn_copies),
              static_cast<unsigned long long>(result.stats.pinned_copies),
              static_cast<unsigned long long>(result.stats.streamed_copies));
}

TEST(ShmRingCrossProcess, NoTornCopiesSingleBufferLargePackets) { expect_clean(hammer(65536, 1, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornCopiesWithPinFallback) { expect_clean(hammer(65536, 1, 2, false, true)); }
TEST(ShmRingCrossProcess, NoTornPinnedCopies) {
  const HammerResult result = hammer(65536, 1, 2, false, false, 0);
  expect_clean(result);
  EXPECT_EQ(result.stats.torn_copies, 0u);  // pinned before copying: nothing to retry
  EXPECT_EQ(result.stats.pinned_copies, result.received);
}
// Streamed writes (>= 64 KiB) that lap their followers: the follower's final check must catch it.
TEST(ShmRingCrossProcess, NoTornStreamedCopiesSingleBuffer) { expect_clean(hammer(1 << 20, 1, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornStreamedCopiesManyBuffers) { expect_clean(hammer(256 << 10, 4, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornCopiesSmallPacketsManyBuffers) {
  expect_clean(hammer(64, 64, 2, false, false, 3, 200000));
}
TEST(ShmRingCrossProcess, NoTornBorrowsSingleBuffer) { expect_clean(hammer(16384, 1, 1, true, false)); }
TEST(ShmRingCrossProcess, NoTornBorrowsManyBuffers) { expect_clean(hammer(4096, 8, 4, true, true)); }

// A reader that dies while holding a borrow must not cost the segment a token.
TEST(ShmRingCrossProcess, DeadBorrowerTokenIsReclaimed) {
  ShmWriter writer = ShmWriter::create(config(64, 1, 1));
  SocketPair sockets;
  Child subscriber([&] {
    ShmReader reader = ShmReader::attach(receive_fd(sockets.child.get()));
    send_byte(sockets.child.get(), 'a');
    BorrowedSample sample;
    if (reader.borrow(sample, 10s) != ReadStatus::ok) return 2;
    send_byte(sockets.child.get(), 'b');
    if (receive_byte(sockets.child.get(), 10s) != 'k') return 3;
    ::kill(::getpid(), SIGKILL);  // die holding the pin and the token
    return 4;
  });
  send_fd(sockets.parent.get(), writer.fd());
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'a');
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'b');

  ShmReader reader = ShmReader::attach(writer.fd());
  ASSERT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::ok);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample), ReadStatus::borrow_limit);  // the only token is held by a live reader
  send_byte(sockets.parent.get(), 'k');
  EXPECT_EQ(subscriber.wait(), -2);
  write_packets(writer, 3, 20);
  ASSERT_EQ(reader.borrow(sample), ReadStatus::ok);  // token taken over from the dead reader
  EXPECT_EQ(sample.info().sequence, 20u);
  EXPECT_EQ(std::memcmp(sample.data(), packet(64, 20).data(), 64), 0);
  sample.release();
  // The stale pin was cleared: the writer has all its spares again.
  write_packets(writer, 21, 40);
}

}  // namespace
}  // namespace ln::transport
