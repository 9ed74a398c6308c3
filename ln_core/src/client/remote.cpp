#include "client/remote.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <tuple>

#include "client/c_api.hpp"
#include "client/datagram_faults.hpp"
#include "client/failure.hpp"
#include "client/ports.hpp"

namespace ln::clientlib {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kMagic = 0x3254'4e4c;  // "LNT2" in little endian
constexpr std::size_t kHeaderSize = 4 + 4 + 8 + 8 + 8 + 8 + 8 + 4 + 4;
constexpr std::uint32_t kMaxPacketSize = 1u << 30;
constexpr int kSocketBuffer = 4 * 1024 * 1024;
constexpr std::uint32_t kBigEndianPayload = 1u << 0;  // header flag
constexpr bool kHostIsBigEndian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;
constexpr std::size_t kRetiredStreams = 4;  // per inbox
constexpr std::size_t kEndedIds = 64;       // per receiver
// TCP senders (reliable subscriptions): how many connections at once, and
// how many bytes of partly received packets all of them may hold; beyond,
// the oldest connection, or the one holding the most, is dropped.
constexpr std::size_t kMaxStreamConnections = 256;
constexpr std::size_t kMaxStreamBytes = 64u << 20;
// New publisher streams (a ring each) one inbox takes per period.
constexpr auto kNewStreamPeriod = std::chrono::seconds(1);
constexpr int kNewStreamsPerPeriod = 8;

void put_le(unsigned char* out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out[i] = static_cast<unsigned char>(value >> (8 * i));
}

std::uint64_t get_le(const unsigned char* in, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value |= std::uint64_t{in[i]} << (8 * i);
  return value;
}

struct Header {
  bool big_endian_payload = kHostIsBigEndian;
  std::int64_t subscription_id = 0;
  std::uint64_t stream = 0;
  std::uint64_t joined_after = 0;
  std::uint64_t sequence = 0;
  double timestamp = 0;
  std::uint32_t packet_size = 0;
  std::uint32_t offset = 0;
};

void encode_header(unsigned char* out, const Header& header) {
  std::uint64_t timestamp_bits;
  std::memcpy(&timestamp_bits, &header.timestamp, sizeof timestamp_bits);
  put_le(out, kMagic, 4);
  put_le(out + 4, header.big_endian_payload ? kBigEndianPayload : 0, 4);
  put_le(out + 8, static_cast<std::uint64_t>(header.subscription_id), 8);
  put_le(out + 16, header.stream, 8);
  put_le(out + 24, header.joined_after, 8);
  put_le(out + 32, header.sequence, 8);
  put_le(out + 40, timestamp_bits, 8);
  put_le(out + 48, header.packet_size, 4);
  put_le(out + 52, header.offset, 4);
}

bool decode_header(const unsigned char* in, std::size_t size, Header& header) {
  if (size < kHeaderSize || get_le(in, 4) != kMagic) return false;
  header.big_endian_payload = (get_le(in + 4, 4) & kBigEndianPayload) != 0;
  header.subscription_id = static_cast<std::int64_t>(get_le(in + 8, 8));
  header.stream = get_le(in + 16, 8);
  header.joined_after = get_le(in + 24, 8);
  header.sequence = get_le(in + 32, 8);
  const std::uint64_t timestamp_bits = get_le(in + 40, 8);
  std::memcpy(&header.timestamp, &timestamp_bits, sizeof header.timestamp);
  header.packet_size = static_cast<std::uint32_t>(get_le(in + 48, 4));
  header.offset = static_cast<std::uint32_t>(get_le(in + 52, 4));
  return header.packet_size <= kMaxPacketSize && header.offset <= header.packet_size &&
         size - kHeaderSize <= header.packet_size - header.offset;
}

bool parse_ipv4(const std::string& address, sockaddr_in& out) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos) return false;
  out = sockaddr_in{};
  out.sin_family = AF_INET;
  char* end = nullptr;
  const unsigned long port = std::strtoul(address.c_str() + colon + 1, &end, 10);
  if (*end != '\0' || port == 0 || port > 65535) return false;
  out.sin_port = htons(static_cast<std::uint16_t>(port));
  return ::inet_pton(AF_INET, address.substr(0, colon).c_str(), &out.sin_addr) == 1;
}

}  // namespace

// -------------------------------------------------------------- RemoteTarget

bool RemoteTarget::operator<(const RemoteTarget& other) const {
  return std::tie(subscription_id, rate, reliable, address) <
         std::tie(other.subscription_id, other.rate, other.reliable, other.address);
}

bool RemoteTarget::parse(const std::string& text, RemoteTarget& target) {
  std::istringstream in(text);
  int reliable = 0;
  if (!(in >> target.subscription_id >> target.rate >> reliable >> target.address)) return false;
  target.reliable = reliable != 0;
  sockaddr_in ignored{};
  return parse_ipv4(target.address, ignored);
}

// ----------------------------------------------------------- PacketAssembler

const unsigned char* PacketAssembler::add(std::uint64_t sequence, std::uint32_t packet_size, std::uint32_t offset,
                                          const unsigned char* fragment, std::size_t fragment_size) {
  if (sequence <= newest_ || sequence < assembling_ || fragment_size_ == 0) return nullptr;  // stale
  if (offset == 0 && fragment_size == packet_size) {                                         // a whole packet
    static const unsigned char kEmpty = 0;
    newest_ = sequence;
    assembling_ = 0;
    return packet_size != 0 ? fragment : &kEmpty;
  }
  if (offset % fragment_size_ != 0 || offset >= packet_size ||
      fragment_size != std::min<std::size_t>(fragment_size_, packet_size - offset))
    return nullptr;
  if (sequence != assembling_ || packet_.size() != packet_size) {
    // A newer packet; an unfinished older one is lost.
    assembling_ = sequence;
    packet_.resize(packet_size);
    missing_ = static_cast<std::uint32_t>((std::uint64_t{packet_size} + fragment_size_ - 1) / fragment_size_);
    have_.assign(missing_, false);
  }
  const std::size_t index = offset / fragment_size_;
  if (have_[index]) return nullptr;  // a duplicate
  have_[index] = true;
  std::memcpy(packet_.data() + offset, fragment, fragment_size);
  if (--missing_ != 0) return nullptr;
  newest_ = sequence;
  assembling_ = 0;
  return packet_.data();
}

// -------------------------------------------------------------- RemoteSender

RemoteSender::RemoteSender(OutPort& port, RemoteTarget target)
    : port_(port), target_(std::move(target)), faults_(datagram_faults_from_environment()) {
  thread_ = std::thread([this] { run(); });
}

RemoteSender::~RemoteSender() {
  stopping_.store(true);
  {
    std::lock_guard<std::mutex> lock(reader_mutex_);
    if (reader_) reader_->unblock();
  }
  if (thread_.joinable()) thread_.join();
}

bool RemoteSender::attach(std::optional<std::uint64_t> resume_after) {
  OutPort::SegmentOffer offer = port_.offer_segment();
  if (!offer.fd.valid()) return false;
  transport::ReaderOptions options;
  options.buffers = std::max<std::uint32_t>(offer.slots, 1);  // a burst is sent, not skipped
  options.max_borrows = 0;
  // Packets from before a segment switch are not in this one: the reader
  // must not wait for them.
  if (resume_after) resume_after = std::max(*resume_after, offer.first_sequence - 1);
  options.resume_after = resume_after;
  try {
    auto reader = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(offer.fd), options));
    buffer_.resize(reader->message_size());
    std::lock_guard<std::mutex> lock(reader_mutex_);
    reader_ = std::move(reader);
    stream_ = offer.stream;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

bool RemoteSender::connect_target() {
  sockaddr_in address{};
  if (!parse_ipv4(target_.address, address)) return false;
  UniqueFd fd(::socket(AF_INET, (target_.reliable ? SOCK_STREAM : SOCK_DGRAM) | SOCK_CLOEXEC, 0));
  if (!fd.valid()) return false;
  ::setsockopt(fd.get(), SOL_SOCKET, SO_SNDBUF, &kSocketBuffer, sizeof kSocketBuffer);
  if (target_.reliable) {
    const int one = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    // A subscriber host that does not answer must not hold the thread for long.
    timeval timeout{1, 0};
    ::setsockopt(fd.get(), SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  }
  if (::connect(fd.get(), reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) return false;
  socket_ = std::move(fd);
  return true;
}

bool RemoteSender::send_datagram(const unsigned char* header, const unsigned char* payload, std::size_t length) {
  auto send = [this](const unsigned char* head, const unsigned char* body, std::size_t body_length) {
    iovec parts[2] = {{const_cast<unsigned char*>(head), kHeaderSize}, {const_cast<unsigned char*>(body), body_length}};
    msghdr message{};
    message.msg_iov = parts;
    message.msg_iovlen = 2;
    // A full socket buffer drops the datagram (the subscriber counts it lost).
    return ::sendmsg(socket_.get(), &message, MSG_NOSIGNAL | MSG_DONTWAIT) >= 0 || errno == ECONNREFUSED;
  };
  if (faults_) return faults_->send(header, kHeaderSize, payload, length, send);
  return send(header, payload, length);
}

bool RemoteSender::send_packet(const void* data, std::uint32_t size, std::uint64_t sequence, double timestamp) {
  unsigned char header[4 + kHeaderSize];
  Header fields;
  fields.subscription_id = target_.subscription_id;
  fields.stream = stream_;
  fields.joined_after = target_.joined_after;
  fields.sequence = sequence;
  fields.timestamp = timestamp;
  fields.packet_size = size;
  if (target_.reliable) {
    put_le(header, kHeaderSize + size, 4);
    encode_header(header + 4, fields);
    iovec parts[2] = {{header, sizeof header}, {const_cast<void*>(data), size}};
    std::size_t total = sizeof header + size, sent = 0;
    while (sent < total) {
      msghdr message{};
      iovec rest[2];
      int count = 0;
      std::size_t skip = sent;
      for (const iovec& part : parts) {
        if (skip >= part.iov_len) {
          skip -= part.iov_len;
          continue;
        }
        rest[count++] = {static_cast<char*>(part.iov_base) + skip, part.iov_len - skip};
        skip = 0;
      }
      message.msg_iov = rest;
      message.msg_iovlen = count;
      const ssize_t n = ::sendmsg(socket_.get(), &message, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  }
  // UDP: fragments of one packet; one that cannot be sent loses the packet.
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::uint32_t offset = 0;
  do {
    const std::uint32_t length = std::min(size - offset, kMaxDatagramPayload);
    fields.offset = offset;
    encode_header(header, fields);
    if (!send_datagram(header, bytes + offset, length)) break;
    offset += length;
  } while (offset < size);
  return true;
}

void RemoteSender::run() {
  // The subscription's packets are those after the publisher counted it.
  std::optional<std::uint64_t> resume_after = target_.joined_after;
  while (!stopping_.load()) {
    if (!reader_ && !attach(resume_after)) {
      std::this_thread::sleep_for(50ms);
      continue;
    }
    if (!socket_.valid() && !connect_target()) {
      std::this_thread::sleep_for(100ms);
      continue;
    }
    transport::SampleInfo info;
    const transport::ReadStatus status = reader_->read(buffer_.data(), buffer_.size(), info, 100ms);
    switch (status) {
      case transport::ReadStatus::ok: {
        // A rate-limited subscriber gets only what it would keep anyway.
        if (target_.rate > 0 && sent_any_) {
          const double since = info.timestamp - last_sent_timestamp_;
          if (since >= 0 && since < 1.0 / target_.rate) break;
        }
        if (!send_packet(buffer_.data(), info.size, info.sequence, info.timestamp)) socket_.reset();
        last_sent_timestamp_ = info.timestamp;
        sent_any_ = true;
        break;
      }
      case transport::ReadStatus::segment_replaced:
      case transport::ReadStatus::publisher_gone:
      case transport::ReadStatus::corrupt_segment: {
        resume_after = status == transport::ReadStatus::segment_replaced
                           ? std::optional<std::uint64_t>(reader_->last_sequence())
                           : std::nullopt;
        std::lock_guard<std::mutex> lock(reader_mutex_);
        reader_.reset();
        break;
      }
      default:
        break;  // timeout, unblocked (stopping), ...
    }
  }
}

// ------------------------------------------------------------ RemoteReceiver

RemoteReceiver::RemoteReceiver(const std::string& local_ip) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  if (::inet_pton(AF_INET, local_ip.c_str(), &address.sin_addr) != 1)
    throw Failure(LNE_INVALID_PARAMETER, "no IPv4 address to receive remote topic data on: " + local_ip);
  // UDP and TCP on the same port number, so that one "IP:PORT" serves both.
  for (int attempt = 0; attempt < 20 && !udp_.valid(); ++attempt) {
    UniqueFd listener(::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    address.sin_port = 0;
    socklen_t length = sizeof address;
    if (!listener.valid() || ::bind(listener.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
        ::listen(listener.get(), 128) != 0 ||
        ::getsockname(listener.get(), reinterpret_cast<sockaddr*>(&address), &length) != 0)
      throw errno_failure(errno, "opening the TCP receiver for remote topic data on " + local_ip);
    UniqueFd udp(::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!udp.valid()) throw errno_failure(errno, "opening the UDP receiver for remote topic data");
    ::setsockopt(udp.get(), SOL_SOCKET, SO_RCVBUF, &kSocketBuffer, sizeof kSocketBuffer);
    if (::bind(udp.get(), reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) continue;  // port taken for UDP
    listener_ = std::move(listener);
    udp_ = std::move(udp);
  }
  if (!udp_.valid()) throw Failure(LNE_CHECK_ERRNO, "no port free for both UDP and TCP on " + local_ip);
  wake_ = UniqueFd(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  if (!wake_.valid()) throw errno_failure(errno, "creating the receiver's wake-up descriptor");
  address_ = local_ip + ":" + std::to_string(ntohs(address.sin_port));
  try {
    thread_ = std::thread([this] { run(); });
  } catch (const std::system_error& error) {
    throw Failure(LNE_CHECK_ERRNO, std::string("starting the receiver thread: ") + error.what());
  }
}

RemoteReceiver::~RemoteReceiver() {
  stopping_.store(true);
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t ignored = ::write(wake_.get(), &one, sizeof one);
  if (thread_.joinable()) thread_.join();
}

void RemoteReceiver::open_inbox(const void* owner, std::uint32_t message_size, std::uint32_t history,
                                InboxHandlers handlers) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (inboxes_.count(owner) != 0) return;
  Inbox& inbox = inboxes_[owner];
  inbox.message_size = std::max<std::uint32_t>(message_size, 1);
  inbox.history = std::max<std::uint32_t>(history, 1);
  inbox.handlers = std::move(handlers);
}

void RemoteReceiver::route(const void* owner, std::int64_t subscription_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = inboxes_.find(owner);
  if (it == inboxes_.end()) return;
  if (it->second.subscription_id == subscription_id) return;
  if (it->second.subscription_id >= 0) forget_id_locked(it->second.subscription_id);
  it->second.subscription_id = subscription_id;
  routes_[subscription_id] = owner;
  ended_ids_.erase(std::remove(ended_ids_.begin(), ended_ids_.end(), subscription_id), ended_ids_.end());
  // What came before the route, in the order it came.
  std::deque<Held> others;
  std::deque<Held> held;
  held.swap(held_);
  for (Held& packet : held) {
    if (packet.subscription_id != subscription_id) {
      others.push_back(std::move(packet));
      continue;
    }
    held_bytes_ -= packet.bytes.size();
    deliver_locked(packet.bytes.data(), packet.bytes.size(), false);
  }
  held_.swap(others);
}

void RemoteReceiver::close_inbox(const void* owner) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = inboxes_.find(owner);
  if (it == inboxes_.end()) return;
  if (it->second.subscription_id >= 0) forget_id_locked(it->second.subscription_id);
  inboxes_.erase(it);
}

void RemoteReceiver::forget_id_locked(std::int64_t subscription_id) {
  routes_.erase(subscription_id);
  // Publishers may still send to it for a while: neither deliver nor hold that.
  ended_ids_.push_back(subscription_id);
  if (ended_ids_.size() > kEndedIds) ended_ids_.pop_front();
  for (auto it = held_.begin(); it != held_.end();) {
    if (it->subscription_id != subscription_id) {
      ++it;
      continue;
    }
    held_bytes_ -= it->bytes.size();
    it = held_.erase(it);
  }
}

void RemoteReceiver::deliver_locked(const unsigned char* data, std::size_t size, bool may_hold) {
  Header header;
  if (!decode_header(data, size, header)) return;
  auto route = routes_.find(header.subscription_id);
  if (route == routes_.end()) {
    // Maybe a subscription whose subscribe answer this client has not
    // processed yet (the publisher heard of it from the manager first).
    const bool ended = std::find(ended_ids_.begin(), ended_ids_.end(), header.subscription_id) != ended_ids_.end();
    if (may_hold && !ended && held_bytes_ + size <= kHoldBytes) {
      held_.push_back(
          {std::chrono::steady_clock::now(), header.subscription_id, std::vector<unsigned char>(data, data + size)});
      held_bytes_ += size;
    }
    return;
  }
  Inbox& inbox = inboxes_.at(route->second);
  if (inbox.failed || header.packet_size > inbox.message_size) return;
  if (header.big_endian_payload != kHostIsBigEndian) {
    inbox.failed = true;
    if (inbox.handlers.fail)
      inbox.handlers.fail(LNE_WRONG_BYTE_ORDER, std::string("the publisher's host is ") +
                                                    (header.big_endian_payload ? "big" : "little") +
                                                    " endian, this one is not: its data cannot be read here");
    return;
  }
  if (!inbox.ring || header.stream != inbox.stream) {
    // The first packet of a publisher's stream: a ring that starts after
    // the point where the publisher counted the subscription.
    const auto& retired = inbox.retired_streams;
    if (std::find(retired.begin(), retired.end(), header.stream) != retired.end()) return;  // a straggler
    if (header.sequence <= header.joined_after) return;
    // A new publisher is rare; datagrams that claim a new one all the time
    // (anyone can send them) must not make a ring each (a memory file
    // each): a few per second, the rest are dropped.
    const auto now = std::chrono::steady_clock::now();
    if (now - inbox.new_streams_since > kNewStreamPeriod) {
      inbox.new_streams_since = now;
      inbox.new_streams = 0;
    }
    if (++inbox.new_streams > kNewStreamsPerPeriod) return;
    transport::RingConfig config;
    config.message_size = inbox.message_size;
    config.history = inbox.history;
    config.first_sequence = header.joined_after + 1;
    config.debug_name = "ln:remote_inbox";
    std::unique_ptr<transport::ShmWriter> ring;
    UniqueFd duplicate;
    try {
      ring = std::make_unique<transport::ShmWriter>(transport::ShmWriter::create(config));
      duplicate = UniqueFd(::fcntl(ring->fd(), F_DUPFD_CLOEXEC, 0));
    } catch (const transport::ShmError& error) {
      inbox.failed = true;
      if (inbox.handlers.fail)
        inbox.handlers.fail(LNE_SHM_IS_TOO_BIG,
                            std::string("creating the inbox for remote topic data: ") + error.what());
      return;
    }
    if (!duplicate.valid()) return;
    if (inbox.ring) {
      inbox.ring->close();
      inbox.retired_streams.push_back(inbox.stream);
      if (inbox.retired_streams.size() > kRetiredStreams) inbox.retired_streams.erase(inbox.retired_streams.begin());
    }
    inbox.ring = std::move(ring);
    inbox.stream = header.stream;
    inbox.assembler = PacketAssembler(header.joined_after);
    if (inbox.handlers.adopt) inbox.handlers.adopt(std::move(duplicate), ++inbox.generation, header.joined_after);
  }
  const unsigned char* packet =
      inbox.assembler.add(header.sequence, header.packet_size, header.offset, data + kHeaderSize, size - kHeaderSize);
  if (packet != nullptr) inbox.ring->write_as(header.sequence, packet, header.packet_size, header.timestamp);
}

void RemoteReceiver::on_packet(const unsigned char* data, std::size_t size) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  while (!held_.empty() && now - held_.front().arrived > kHoldTime) {
    held_bytes_ -= held_.front().bytes.size();
    held_.pop_front();
  }
  deliver_locked(data, size, true);
}

void RemoteReceiver::on_stream(Connection& connection) {
  std::size_t done = 0;
  for (;;) {
    const std::size_t left = connection.buffered.size() - done;
    if (left < 4) break;
    const auto* bytes = reinterpret_cast<const unsigned char*>(connection.buffered.data()) + done;
    const std::uint32_t frame = static_cast<std::uint32_t>(get_le(bytes, 4));
    if (frame < kHeaderSize || frame > kMaxPacketSize + kHeaderSize) {
      connection.socket.reset();  // not our protocol
      return;
    }
    if (left < 4u + frame) break;
    Header header;
    if (decode_header(bytes + 4, frame, header) && header.offset == 0 && header.packet_size == frame - kHeaderSize)
      on_packet(bytes + 4, frame);
    done += 4u + frame;
  }
  connection.buffered.erase(0, done);
}

void RemoteReceiver::drop_largest_streams_over_budget() {
  for (;;) {
    std::size_t total = 0;
    Connection* largest = nullptr;
    for (Connection& connection : connections_) {
      if (!connection.socket.valid()) continue;
      total += connection.buffered.size();
      if (!largest || connection.buffered.size() > largest->buffered.size()) largest = &connection;
    }
    if (total <= kMaxStreamBytes || largest == nullptr) return;
    largest->socket.reset();
  }
}

void RemoteReceiver::run() {
  std::vector<unsigned char> datagram(65536);
  while (!stopping_.load()) {
    std::vector<pollfd> fds = {{wake_.get(), POLLIN, 0}, {udp_.get(), POLLIN, 0}, {listener_.get(), POLLIN, 0}};
    for (const Connection& connection : connections_) fds.push_back({connection.socket.get(), POLLIN, 0});
    if (::poll(fds.data(), fds.size(), -1) < 0) continue;
    if (fds[1].revents != 0) {
      for (int i = 0; i < 256; ++i) {
        const ssize_t n = ::recv(udp_.get(), datagram.data(), datagram.size(), 0);
        if (n <= 0) break;
        on_packet(datagram.data(), static_cast<std::size_t>(n));
      }
    }
    for (int i = 0; fds[2].revents != 0 && i < 64; ++i) {
      UniqueFd accepted(::accept4(listener_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC));
      if (!accepted.valid()) break;
      if (connections_.size() >= kMaxStreamConnections) {  // the oldest goes (erased below)
        for (Connection& oldest : connections_) {
          if (!oldest.socket.valid()) continue;
          oldest.socket.reset();
          break;
        }
      }
      connections_.push_back(Connection{std::move(accepted), {}});
    }
    for (std::size_t i = 3; i < fds.size(); ++i) {
      Connection& connection = connections_[i - 3];
      if (fds[i].revents == 0 || !connection.socket.valid()) continue;
      char chunk[65536];
      const ssize_t n = ::recv(connection.socket.get(), chunk, sizeof chunk, 0);
      if (n <= 0) {
        if (n == 0 || (errno != EAGAIN && errno != EINTR)) connection.socket.reset();
        continue;
      }
      connection.buffered.append(chunk, static_cast<std::size_t>(n));
      on_stream(connection);
    }
    drop_largest_streams_over_budget();
    connections_.erase(
        std::remove_if(connections_.begin(), connections_.end(), [](const Connection& c) { return !c.socket.valid(); }),
        connections_.end());
  }
}

}  // namespace ln::clientlib
