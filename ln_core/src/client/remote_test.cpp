// White-box tests of remote topic data without a manager: the receiver's
// packet bookkeeping (PacketAssembler), and a RemoteReceiver fed with
// hand-made datagrams over loopback (held before its route, duplicated,
// reordered, lost, another stream, the other byte order).
#include "client/remote.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "client/c_api.hpp"
#include "testing/wait.hpp"

namespace ln::clientlib {
namespace {

using namespace std::chrono_literals;

std::vector<unsigned char> bytes_of(std::uint64_t sequence, std::size_t size) {
  std::vector<unsigned char> bytes(size);
  for (std::size_t i = 0; i < size; ++i) bytes[i] = static_cast<unsigned char>(sequence * 31 + i);
  return bytes;
}

// ----------------------------------------------------------- PacketAssembler

TEST(PacketAssembler, WholePacketsOnlyNewerOnesOnce) {
  PacketAssembler assembler(10);
  const auto p = bytes_of(1, 8);
  EXPECT_EQ(assembler.add(10, 8, 0, p.data(), 8), nullptr);  // the starting point is not wanted
  EXPECT_EQ(assembler.add(11, 8, 0, p.data(), 8), p.data());
  EXPECT_EQ(assembler.add(11, 8, 0, p.data(), 8), nullptr);   // duplicate
  EXPECT_EQ(assembler.add(14, 8, 0, p.data(), 8), p.data());  // a gap is the reader's to count
  EXPECT_EQ(assembler.add(12, 8, 0, p.data(), 8), nullptr);   // late
  EXPECT_EQ(assembler.add(13, 8, 0, p.data(), 8), nullptr);
  EXPECT_EQ(assembler.newest(), 14u);
  EXPECT_NE(assembler.add(15, 0, 0, nullptr, 0), nullptr);  // an empty packet is a packet too
  EXPECT_EQ(assembler.newest(), 15u);
}

TEST(PacketAssembler, FragmentsInAnyOrderDuplicatesCountOnce) {
  PacketAssembler assembler(0, 4);
  const auto packet = bytes_of(5, 10);  // fragments at 0, 4, 8 (2 bytes)
  auto add = [&](std::uint64_t sequence, std::uint32_t offset) {
    const std::size_t size = std::min<std::size_t>(4, packet.size() - offset);
    return assembler.add(sequence, 10, offset, packet.data() + offset, size);
  };
  EXPECT_EQ(add(5, 8), nullptr);
  EXPECT_EQ(add(5, 8), nullptr);  // a duplicate does not complete it
  EXPECT_EQ(add(5, 0), nullptr);
  EXPECT_EQ(add(5, 0), nullptr);
  const unsigned char* whole = add(5, 4);
  ASSERT_NE(whole, nullptr);
  EXPECT_EQ(std::memcmp(whole, packet.data(), 10), 0);
  EXPECT_EQ(add(5, 4), nullptr);  // once
  EXPECT_EQ(assembler.newest(), 5u);

  // An incomplete packet is abandoned for a newer one; its late fragments stay out.
  EXPECT_EQ(add(6, 0), nullptr);
  EXPECT_EQ(add(7, 4), nullptr);
  EXPECT_EQ(add(6, 4), nullptr);
  EXPECT_EQ(add(6, 8), nullptr);
  EXPECT_EQ(add(7, 0), nullptr);
  ASSERT_NE(add(7, 8), nullptr);
  EXPECT_EQ(assembler.newest(), 7u);

  // Fragments that do not fit the layout are refused, not merged.
  EXPECT_EQ(assembler.add(8, 10, 2, packet.data(), 4), nullptr);   // misaligned
  EXPECT_EQ(assembler.add(8, 10, 4, packet.data(), 3), nullptr);   // wrong size
  EXPECT_EQ(assembler.add(8, 10, 12, packet.data(), 2), nullptr);  // beyond the end
  EXPECT_EQ(assembler.newest(), 7u);
}

// ------------------------------------------------------------ RemoteReceiver

// Datagrams in remote.hpp's wire format.
struct Datagram {
  bool big_endian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;
  std::int64_t subscription_id = 7;
  std::uint64_t stream = 1;
  std::uint64_t joined_after = 100;
  std::uint64_t sequence = 0;
  double timestamp = 0;
  std::vector<unsigned char> payload;

  std::vector<unsigned char> encode() const {
    std::vector<unsigned char> out(56);
    auto put = [&](std::size_t at, std::uint64_t value, int size) {
      for (int i = 0; i < size; ++i) out[at + i] = static_cast<unsigned char>(value >> (8 * i));
    };
    std::uint64_t timestamp_bits;
    std::memcpy(&timestamp_bits, &timestamp, 8);
    put(0, 0x3254'4e4c, 4);
    put(4, big_endian ? 1 : 0, 4);
    put(8, static_cast<std::uint64_t>(subscription_id), 8);
    put(16, stream, 8);
    put(24, joined_after, 8);
    put(32, sequence, 8);
    put(40, timestamp_bits, 8);
    put(48, payload.size(), 4);
    put(52, 0, 4);
    out.insert(out.end(), payload.begin(), payload.end());
    return out;
  }
};

bool eventually(const std::function<bool()>& condition) { return test::wait_until(condition, 5s); }

class Receiving : public ::testing::Test {
 protected:
  Receiving() : receiver_("127.0.0.1") {
    socket_ = UniqueFd(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
    const std::string address = receiver_.address();
    const auto colon = address.rfind(':');
    to_.sin_family = AF_INET;
    to_.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
    ::inet_pton(AF_INET, "127.0.0.1", &to_.sin_addr);
  }

  void open(std::uint32_t history) {
    RemoteReceiver::InboxHandlers handlers;
    handlers.adopt = [this](UniqueFd ring, std::int64_t generation, std::uint64_t written_before) {
      std::lock_guard<std::mutex> lock(mutex_);
      transport::ReaderOptions options;
      options.buffers = history_;
      options.resume_after = written_before;
      reader_ = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(ring), options));
      generations_.push_back(generation);
    };
    handlers.fail = [this](int code, const std::string&) {
      std::lock_guard<std::mutex> lock(mutex_);
      failure_ = code;
    };
    history_ = history;
    receiver_.open_inbox(&owner_, 64, history, std::move(handlers));
  }

  void send(const Datagram& datagram) {
    const auto bytes = datagram.encode();
    ASSERT_EQ(
        ::sendto(socket_.get(), bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to_), sizeof to_),
        static_cast<ssize_t>(bytes.size()));
  }
  void send(std::uint64_t sequence, std::uint64_t stream = 1) {
    Datagram datagram;
    datagram.sequence = sequence;
    datagram.stream = stream;
    datagram.payload = bytes_of(sequence, 16);
    send(datagram);
  }
  // Returns once the receiver has handled every datagram sent before: a
  // marker datagram for another, routed inbox is sent after them and read
  // from that inbox (one socket, one receiving thread: handled in order).
  void flush() {
    if (!marker_open_) {
      RemoteReceiver::InboxHandlers handlers;
      handlers.adopt = [this](UniqueFd ring, std::int64_t, std::uint64_t written_before) {
        std::lock_guard<std::mutex> lock(mutex_);
        transport::ReaderOptions options;
        options.buffers = 16;
        options.resume_after = written_before;
        marker_reader_ = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(ring), options));
      };
      handlers.fail = [](int, const std::string&) {};
      receiver_.open_inbox(&marker_owner_, 64, 16, std::move(handlers));
      receiver_.route(&marker_owner_, kMarkerId);
      marker_open_ = true;
    }
    Datagram marker;
    marker.subscription_id = kMarkerId;
    marker.joined_after = 0;
    marker.sequence = ++marker_sequence_;
    marker.payload = bytes_of(marker.sequence, 16);
    send(marker);
    std::vector<unsigned char> buffer(64);
    std::uint64_t newest = 0;
    EXPECT_TRUE(eventually([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      transport::SampleInfo info;
      while (marker_reader_ && marker_reader_->read(buffer.data(), buffer.size(), info) == transport::ReadStatus::ok) {
        newest = info.sequence;
      }
      return newest >= marker_sequence_;
    })) << "the receiver did not handle marker "
        << marker_sequence_;
  }

  // Every (sequence, lost) the reader gets until `last` arrives.
  std::vector<std::pair<std::uint64_t, std::uint64_t>> read_until(std::uint64_t last) {
    std::vector<std::pair<std::uint64_t, std::uint64_t>> got;
    std::vector<unsigned char> buffer(64);
    EXPECT_TRUE(eventually([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      transport::SampleInfo info;
      while (reader_ && reader_->read(buffer.data(), buffer.size(), info) == transport::ReadStatus::ok) {
        EXPECT_EQ(info.size, 16u);
        EXPECT_EQ(std::memcmp(buffer.data(), bytes_of(info.sequence, 16).data(), 16), 0);
        got.emplace_back(info.sequence, info.lost);
      }
      return !got.empty() && got.back().first >= last;
    })) << "no packet "
        << last;
    return got;
  }

  static constexpr std::int64_t kMarkerId = 99;
  int owner_ = 0;
  int marker_owner_ = 0;
  bool marker_open_ = false;
  std::uint64_t marker_sequence_ = 0;
  std::unique_ptr<transport::ShmReader> marker_reader_;
  RemoteReceiver receiver_;
  UniqueFd socket_;
  sockaddr_in to_{};
  std::mutex mutex_;
  std::uint32_t history_ = 1;
  std::unique_ptr<transport::ShmReader> reader_;
  std::vector<std::int64_t> generations_;
  int failure_ = 0;
};

using Got = std::vector<std::pair<std::uint64_t, std::uint64_t>>;

TEST_F(Receiving, PacketsBeforeTheRouteAreHeldAndKeepThePublishersNumbers) {
  open(16);
  // The publisher counted the subscription after its packet 100 and sends
  // before the subscriber's client knows its subscription id.
  for (std::uint64_t s : {101, 102, 104, 104, 103, 105, 107}) send(s);
  flush();  // arrived, and held
  {
    std::lock_guard<std::mutex> lock(mutex_);
    EXPECT_EQ(reader_, nullptr);
  }
  receiver_.route(&owner_, 7);
  // 103 came after 104: dropped and counted lost; 104 twice: once.
  EXPECT_EQ(read_until(107), (Got{{101, 0}, {102, 0}, {104, 1}, {105, 0}, {107, 1}}));
  for (std::uint64_t s : {108, 106, 108, 110}) send(s);
  EXPECT_EQ(read_until(110), (Got{{108, 0}, {110, 1}}));
  send(109);  // late: never delivered backwards
  send(111);
  EXPECT_EQ(read_until(111), (Got{{111, 0}}));

  // Another publisher (a new stream, numbered from 1): a new ring for the port.
  Datagram first;
  first.stream = 2;
  first.joined_after = 0;
  first.sequence = 2;
  first.payload = bytes_of(2, 16);
  send(first);
  EXPECT_EQ(read_until(2), (Got{{2, 1}}));
  send(3, 2);
  send(200, 1);  // a straggler of the old stream
  send(4, 2);
  EXPECT_EQ(read_until(4), (Got{{3, 0}, {4, 0}}));
  std::lock_guard<std::mutex> lock(mutex_);
  EXPECT_EQ(generations_, (std::vector<std::int64_t>{1, 2}));
  EXPECT_EQ(failure_, 0);
}

TEST_F(Receiving, EndedSubscriptionsAreNotHeld) {
  open(4);
  receiver_.route(&owner_, 7);
  receiver_.route(&owner_, 8);  // a new id after a manager restart
  send(101);                    // for id 7, which ended
  flush();
  receiver_.route(&owner_, 7);  // ... and is routed again: nothing held for it
  flush();
  std::lock_guard<std::mutex> lock(mutex_);
  EXPECT_EQ(reader_, nullptr);
}

TEST_F(Receiving, OtherByteOrderIsAnErrorNotData) {
  open(4);
  receiver_.route(&owner_, 7);
  Datagram foreign;
  foreign.big_endian = !foreign.big_endian;
  foreign.sequence = 101;
  foreign.payload = bytes_of(101, 16);
  send(foreign);
  EXPECT_TRUE(eventually([&] {
    std::lock_guard<std::mutex> lock(mutex_);
    return failure_ != 0;
  }));
  send(102);
  flush();
  std::lock_guard<std::mutex> lock(mutex_);
  EXPECT_EQ(failure_, LNE_WRONG_BYTE_ORDER);
  EXPECT_EQ(reader_, nullptr);  // nothing delivered
}

}  // namespace
}  // namespace ln::clientlib
