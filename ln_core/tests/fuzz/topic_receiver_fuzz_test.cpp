// Fuzz target: what a client's receiver for topic data from other hosts
// (client/remote.hpp) gets over UDP and TCP: mutated datagrams and TCP
// frames of its wire format (fragments, foreign streams, ids without a
// route), raw bytes, connections that never finish a frame. It must keep
// delivering: a well-formed stream sent after arrives complete.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <mutex>
#include <thread>

#include "client/remote.hpp"
#include "fuzz.hpp"

namespace ln::fuzz {
namespace {

using clientlib::RemoteReceiver;
using clientlib::UniqueFd;
using namespace std::chrono_literals;

constexpr std::size_t kHeaderSize = 56;

// One fragment in remote.hpp's wire format.
std::string datagram(std::int64_t subscription, std::uint64_t stream, std::uint64_t joined_after,
                     std::uint64_t sequence, std::uint32_t packet_size, std::uint32_t offset,
                     const std::string& bytes) {
  std::string out(kHeaderSize, '\0');
  auto put = [&](std::size_t at, std::uint64_t value, int size) {
    for (int i = 0; i < size; ++i) out[at + static_cast<std::size_t>(i)] = static_cast<char>(value >> (8 * i));
  };
  const double timestamp = 1.5;
  std::uint64_t timestamp_bits;
  std::memcpy(&timestamp_bits, &timestamp, 8);
  put(0, 0x3254'4e4c, 4);
  put(4, __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__ ? 1 : 0, 4);
  put(8, static_cast<std::uint64_t>(subscription), 8);
  put(16, stream, 8);
  put(24, joined_after, 8);
  put(32, sequence, 8);
  put(40, timestamp_bits, 8);
  put(48, packet_size, 4);
  put(52, offset, 4);
  return out + bytes;
}

std::string payload_of(std::uint64_t sequence) {
  std::string bytes(64, '\0');
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(sequence * 7 + i);
  return bytes;
}

// A publisher of another byte order fails a subscription on purpose
// (remote.hpp): the byte-order flag is not what this target is about.
void keep_byte_order(std::string& bytes) {
  if (bytes.size() >= 8) bytes[4] = static_cast<char>(__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__ ? 1 : 0);
}

class Inbox {
 public:
  explicit Inbox(RemoteReceiver& receiver, std::int64_t subscription) {
    RemoteReceiver::InboxHandlers handlers;
    handlers.adopt = [this](UniqueFd ring, std::int64_t, std::uint64_t written_before) {
      std::lock_guard<std::mutex> lock(mutex_);
      transport::ReaderOptions options;
      options.buffers = 64;
      options.resume_after = written_before;
      reader_ = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(ring), options));
      ++rings_;
    };
    handlers.fail = [this](int code, const std::string&) { failure_ = code; };
    receiver.open_inbox(this, 64, 64, std::move(handlers));
    receiver.route(this, subscription);
  }

  int rings() {
    std::lock_guard<std::mutex> lock(mutex_);
    return rings_;
  }
  // The sequences in [first, last] that can be read now from a ring newer
  // than the `after`th; what the fuzzed streams left behind is skipped.
  std::vector<std::uint64_t> read_available(std::uint64_t first, std::uint64_t last, int after) {
    std::vector<std::uint64_t> got;
    std::string buffer(64, '\0');
    std::lock_guard<std::mutex> lock(mutex_);
    transport::SampleInfo info;
    while (reader_ && reader_->read(buffer.data(), buffer.size(), info) == transport::ReadStatus::ok) {
      if (rings_ <= after || info.sequence < first || info.sequence > last) continue;
      EXPECT_EQ(buffer, payload_of(info.sequence)) << info.sequence;
      got.push_back(info.sequence);
    }
    return got;
  }
  int failure() const { return failure_; }

 private:
  std::mutex mutex_;
  std::unique_ptr<transport::ShmReader> reader_;
  int rings_ = 0;
  std::atomic<int> failure_{0};
};

sockaddr_in address_of(const std::string& text) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(std::stoi(text.substr(text.rfind(':') + 1))));
  ::inet_pton(AF_INET, "127.0.0.1", &to.sin_addr);
  return to;
}

TEST(FuzzTopicReceiver, DatagramsAndStreamsOfAnyShape) {
  RemoteReceiver receiver("127.0.0.1");
  Inbox first(receiver, 7), second(receiver, 8);
  const sockaddr_in to = address_of(receiver.address());
  UniqueFd udp(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  Mutator mutator(seed());

  std::vector<std::string> corpus;
  for (std::uint64_t s = 1; s <= 4; ++s) corpus.push_back(datagram(7, 11, 0, s, 64, 0, payload_of(s)));
  // Fragments of a 150 000-byte packet (60 000 per fragment), an empty packet.
  const std::string big(150000, 'b');
  for (std::uint32_t offset = 0; offset < big.size(); offset += 60000)
    corpus.push_back(datagram(8, 12, 0, 5, 150000, offset, big.substr(offset, 60000)));
  corpus.push_back(datagram(8, 12, 0, 6, 0, 0, ""));
  corpus.push_back(datagram(99, 13, 0, 1, 64, 0, payload_of(1)));  // no route: held

  std::vector<UniqueFd> streams;
  Budget budget(20000);
  while (budget.next()) {
    std::string bytes =
        mutator.chance(10) ? mutator.random_bytes(1500) : mutator.mutate(corpus[mutator.below(corpus.size())], corpus);
    keep_byte_order(bytes);
    if (mutator.chance(5)) {  // over TCP: length-prefixed, perhaps never finished
      if (streams.size() >= 16 || streams.empty() || mutator.chance(4)) {
        if (streams.size() >= 16) streams.erase(streams.begin());
        UniqueFd tcp(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
        if (::connect(tcp.get(), reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0) continue;
        streams.push_back(std::move(tcp));
      }
      std::string frame(4, '\0');
      const std::uint32_t length = mutator.chance(8) ? static_cast<std::uint32_t>(mutator.below(1u << 31))
                                                     : static_cast<std::uint32_t>(bytes.size());
      for (int i = 0; i < 4; ++i) frame[static_cast<std::size_t>(i)] = static_cast<char>(length >> (8 * i));
      frame += bytes;
      ::send(streams[mutator.below(streams.size())].get(), frame.data(), frame.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    } else if (bytes.size() <= 65507) {
      ::sendto(udp.get(), bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    }
    if (budget.done() % 500 == 0) std::this_thread::sleep_for(2ms);  // let the receiver catch up now and then
  }
  streams.clear();
  std::printf("[fuzz] topic receiver: %d rounds, seed %llu\n", budget.done(), static_cast<unsigned long long>(seed()));

  // A well-formed stream (a new publisher) over UDP, then one over TCP,
  // paced like a 200 Hz publisher: each inbox takes a few new streams per
  // second, and the storm may have used them up, so the first packets may
  // be dropped; from its first delivered packet on, each arrives.
  const auto publish_until_delivered = [&](Inbox& inbox, std::uint64_t base,
                                           const std::function<void(const std::string&)>& send) {
    std::vector<std::uint64_t> got;
    const int rings_before = inbox.rings();
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    for (std::uint64_t s = base + 1; got.size() < 20 && std::chrono::steady_clock::now() < deadline; ++s) {
      send(datagram(&inbox == &first ? 7 : 8, base * 424, base, s, 64, 0, payload_of(s)));
      std::this_thread::sleep_for(5ms);  // the publisher's period
      for (std::uint64_t seq : inbox.read_available(base + 1, s, rings_before)) got.push_back(seq);
    }
    return got;
  };
  const auto consecutive = [](const std::vector<std::uint64_t>& got) {
    for (std::size_t i = 1; i < got.size(); ++i)
      if (got[i] != got[i - 1] + 1) return false;
    return got.size() >= 20;
  };
  std::vector<std::uint64_t> got = publish_until_delivered(first, 1000, [&](const std::string& d) {
    ::sendto(udp.get(), d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  });
  EXPECT_TRUE(consecutive(got)) << got.size() << " packets, seed " << seed();

  UniqueFd tcp(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  ASSERT_EQ(::connect(tcp.get(), reinterpret_cast<const sockaddr*>(&to), sizeof to), 0);
  got = publish_until_delivered(second, 2000, [&](const std::string& d) {
    std::string frame(4, '\0');
    for (int i = 0; i < 4; ++i) frame[static_cast<std::size_t>(i)] = static_cast<char>(d.size() >> (8 * i));
    frame += d;
    ASSERT_EQ(::send(tcp.get(), frame.data(), frame.size(), MSG_NOSIGNAL), static_cast<ssize_t>(frame.size()));
  });
  EXPECT_TRUE(consecutive(got)) << got.size() << " packets, seed " << seed();
  EXPECT_EQ(first.failure() + second.failure(), 0);
}

}  // namespace
}  // namespace ln::fuzz
