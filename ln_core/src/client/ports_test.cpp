// White-box tests of an InPort taking over a publisher's segment, and of an
// OutPort's segments, without a manager: segments are handed to the port as
// the I/O thread would.
#include "client/ports.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <optional>
#include <thread>

#include "client/error_slot.hpp"

namespace ln::clientlib {
namespace {

struct Packet {
  std::uint32_t seq;
  std::uint8_t pad[60];
};

class HandOver : public ::testing::Test {
 protected:
  void write(std::uint32_t seq) {
    Packet packet{};
    packet.seq = seq;
    ASSERT_EQ(writer_.write(&packet, sizeof packet), transport::WriteStatus::ok);
  }
  void offer(std::optional<std::uint64_t> written_before) {
    port_.offer_segment(UniqueFd(::fcntl(writer_.fd(), F_DUPFD_CLOEXEC, 0)), {"peer", 1}, 4, written_before);
  }
  // The sequence numbers a polling reader gets now.
  std::vector<std::uint32_t> read_all() {
    std::vector<std::uint32_t> seqs;
    Packet packet{};
    ln_sample_info info{};
    while (port_.read(&packet, sizeof packet, &info, 0) == 1) seqs.push_back(packet.seq);
    return seqs;
  }

  transport::ShmWriter writer_ = transport::ShmWriter::create({sizeof(Packet), 4, 1, 1, "ports_test"});
  ErrorSlot errors_;
  InPort port_{errors_, "t.handover", "test/p64", -1, 4, false};
};

// Like LN, where a subscriber maps the segment when the manager hands it
// over: what the publisher writes after that reaches the subscriber, even
// before its first read.
TEST_F(HandOver, PacketsWrittenAfterTheHandOverReachTheFirstRead) {
  write(1);
  offer(writer_.last_sequence());
  write(2);
  write(3);
  EXPECT_EQ(read_all(), (std::vector<std::uint32_t>{2, 3}));
  write(4);
  EXPECT_EQ(read_all(), (std::vector<std::uint32_t>{4}));
}

// A publisher that had written nothing when its subscriber joined: 0 is a
// starting point too (everything), not "from the first read on".
TEST_F(HandOver, StartingPointZeroDeliversEveryPacket) {
  offer(0);
  write(1);
  write(2);
  EXPECT_EQ(read_all(), (std::vector<std::uint32_t>{1, 2}));
}

TEST_F(HandOver, WithoutAStartingPointOnlyPacketsAfterTheFirstReadCount) {
  offer(std::nullopt);
  write(1);
  EXPECT_TRUE(read_all().empty());
  write(2);
  EXPECT_EQ(read_all(), (std::vector<std::uint32_t>{2}));
}

// RATE_ON_REQUEST_LAST: LN 2.9 fetches the publisher's newest packet on each
// read, so a packet written before the hand-over is the answer.
TEST_F(HandOver, OnRequestReadsFindThePacketWrittenBeforeTheHandOver) {
  // The message size is what the manager's subscribe answer sets.
  struct SizedInPort : InPort {
    using InPort::InPort;
    void set_message_size(std::uint32_t size) { message_size_ = size; }
  } on_request{errors_, "t.handover.onrequest", "test/p64", RATE_ON_REQUEST_LAST, 1, false};
  on_request.set_message_size(sizeof(Packet));
  write(1);
  write(2);
  on_request.offer_segment(UniqueFd(::fcntl(writer_.fd(), F_DUPFD_CLOEXEC, 0)), {"peer", 1}, 4,
                           writer_.last_sequence());
  Packet packet{};
  ln_sample_info info{};
  ASSERT_EQ(on_request.read(&packet, sizeof packet, &info, 0), 1);
  EXPECT_EQ(packet.seq, 2u);
  packet.seq = 0;
  ASSERT_EQ(on_request.read(&packet, sizeof packet, &info, 0), 1);  // again, until a newer one comes
  EXPECT_EQ(packet.seq, 2u);
}

// ------------------------------------------------------------------ OutPort

struct Kib {
  std::uint32_t seq;
  std::uint8_t pad[1020];
};

// Makes every spare slot of `port`'s segment look pinned, as a subscriber's
// stray writes into the part of the segment readers may write can.
void scribble_over_reader_area(OutPort& port) {
  OutPort::SegmentOffer offer = port.offer_segment();
  const auto size = static_cast<std::size_t>(::lseek(offer.fd.get(), 0, SEEK_END));
  void* raw = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, offer.fd.get(), 0);
  ASSERT_NE(raw, MAP_FAILED);
  std::uint64_t shared_offset = 0;
  std::memcpy(&shared_offset, static_cast<unsigned char*>(raw) + 48, sizeof shared_offset);  // SegmentInfo
  ASSERT_LT(shared_offset, size);
  std::memset(static_cast<unsigned char*>(raw) + shared_offset, 0xff, size - shared_offset);
  ::munmap(raw, size);
}

TEST(OutPortSegments, ACorruptedSegmentIsReplacedAndReadersFollow) {
  ErrorSlot errors;
  OutPort out(errors, "t.recover", "test/kib", 4);
  int announced = 0;
  out.set_recovery_handler([&] { ++announced; });
  out.create_segment(sizeof(Kib), "hash", 4);
  InPort in(errors, "t.recover", "test/kib", -1, 4, false);
  const auto offer_to_subscriber = [&] {
    OutPort::SegmentOffer offer = out.offer_segment();
    in.offer_segment(std::move(offer.fd), {"peer", offer.generation}, offer.slots, offer.last_sequence);
  };
  offer_to_subscriber();
  Kib packet{};
  ln_sample_info info{};
  EXPECT_EQ(in.read(&packet, sizeof packet, &info, 0), 0);  // takes the segment over
  for (std::uint32_t seq = 1; seq <= 2; ++seq) {
    packet.seq = seq;
    ASSERT_EQ(out.write(&packet, sizeof packet, nullptr), 0);
  }
  const std::int64_t before = out.generation();
  scribble_over_reader_area(out);
  packet.seq = 3;
  ASSERT_EQ(out.write(&packet, sizeof packet, nullptr), 0) << errors.text();  // into a new segment
  EXPECT_EQ(out.segment_recoveries(), 1u);
  EXPECT_EQ(announced, 1);
  EXPECT_NE(out.generation(), before);
  offer_to_subscriber();  // what the I/O thread does once the manager announced it
  std::vector<std::uint32_t> seqs;
  while (in.read(&packet, sizeof packet, &info, 0) == 1) seqs.push_back(packet.seq);
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_EQ(info.lost, 0u);
}

TEST(OutPortSegments, GrowingDoesNotStopWrites) {
  ErrorSlot errors;
  OutPort out(errors, "t.grow", "test/kib", 1);
  out.create_segment(sizeof(Kib), "hash", 1);
  std::atomic<int> phase{0};  // 0 before, 1 while growing, 2 after
  std::atomic<int> written_while_growing{0};
  std::thread writer([&] {
    Kib packet{};
    while (phase.load() < 2) {
      ++packet.seq;
      if (out.write(&packet, sizeof packet, nullptr) == 0 && phase.load() == 1) ++written_while_growing;
    }
  });
  while (out.newest_sequence() == 0) std::this_thread::yield();  // the writer runs
  phase = 1;
  // ~110 MB: making and pre-faulting it takes a while, during which the
  // program's writes go on into the old segment (they waited for all of it
  // before, for seconds with gigabytes).
  const bool grew = out.ensure_history(100000);
  phase = 2;
  writer.join();
  EXPECT_TRUE(grew);
  EXPECT_GT(written_while_growing.load(), 0);
  EXPECT_EQ(out.offer_segment().slots, 100000u);
}

TEST(OutPortSegments, GrowthStaysWithinTheManagersLimit) {
  ErrorSlot errors;
  OutPort out(errors, "t.limit", "test/kib", 1);
  out.set_segment_limit(1024 * 1024);
  out.create_segment(sizeof(Kib), "hash", 4096);  // a subscriber asked for too many before
  EXPECT_LE(transport::topic_segment_size(sizeof(Kib), out.offer_segment().slots), 1024u * 1024);
  EXPECT_GT(out.offer_segment().slots, 900u);
  EXPECT_FALSE(out.ensure_history(100000)) << "an open_segment asking for more gets no bigger segment";
}

}  // namespace
}  // namespace ln::clientlib
