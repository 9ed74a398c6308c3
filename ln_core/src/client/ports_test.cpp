// White-box tests of an InPort taking over a publisher's segment, without a
// manager: the segment is handed to the port as the I/O thread would.
#include "client/ports.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <optional>

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

}  // namespace
}  // namespace ln::clientlib
