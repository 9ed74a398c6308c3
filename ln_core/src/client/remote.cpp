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
#include <cstring>
#include <sstream>
#include <tuple>

#include "client/c_api.hpp"
#include "client/failure.hpp"
#include "client/ports.hpp"

namespace ln::clientlib {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kMagic = 0x3154'4e4c;  // "LNT1" in little endian
constexpr std::size_t kHeaderSize = 4 + 8 + 8 + 8 + 4 + 4;
// Fragments stay below the 64 KiB UDP limit (and well below it for IPv4
// reassembly buffers on the way).
constexpr std::size_t kMaxDatagramPayload = 60000;
constexpr std::uint32_t kMaxPacketSize = 1u << 30;
constexpr int kSocketBuffer = 4 * 1024 * 1024;

void put_le(unsigned char* out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out[i] = static_cast<unsigned char>(value >> (8 * i));
}

std::uint64_t get_le(const unsigned char* in, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value |= std::uint64_t{in[i]} << (8 * i);
  return value;
}

struct Header {
  std::int64_t subscription_id;
  std::uint64_t sequence;
  double timestamp;
  std::uint32_t packet_size;
  std::uint32_t offset;
};

void encode_header(unsigned char* out, const Header& header) {
  std::uint64_t timestamp_bits;
  std::memcpy(&timestamp_bits, &header.timestamp, sizeof timestamp_bits);
  put_le(out, kMagic, 4);
  put_le(out + 4, static_cast<std::uint64_t>(header.subscription_id), 8);
  put_le(out + 12, header.sequence, 8);
  put_le(out + 20, timestamp_bits, 8);
  put_le(out + 28, header.packet_size, 4);
  put_le(out + 32, header.offset, 4);
}

bool decode_header(const unsigned char* in, std::size_t size, Header& header) {
  if (size < kHeaderSize || get_le(in, 4) != kMagic) return false;
  header.subscription_id = static_cast<std::int64_t>(get_le(in + 4, 8));
  header.sequence = get_le(in + 12, 8);
  const std::uint64_t timestamp_bits = get_le(in + 20, 8);
  std::memcpy(&header.timestamp, &timestamp_bits, sizeof header.timestamp);
  header.packet_size = static_cast<std::uint32_t>(get_le(in + 28, 4));
  header.offset = static_cast<std::uint32_t>(get_le(in + 32, 4));
  return header.packet_size <= kMaxPacketSize && header.offset <= header.packet_size;
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

// -------------------------------------------------------------- RemoteSender

RemoteSender::RemoteSender(OutPort& port, RemoteTarget target) : port_(port), target_(std::move(target)) {
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
  options.resume_after = resume_after;
  try {
    auto reader = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(offer.fd), options));
    buffer_.resize(reader->message_size());
    std::lock_guard<std::mutex> lock(reader_mutex_);
    reader_ = std::move(reader);
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

bool RemoteSender::send_packet(const void* data, std::uint32_t size, std::uint64_t sequence, double timestamp) {
  unsigned char header[4 + kHeaderSize];
  Header fields{target_.subscription_id, sequence, timestamp, size, 0};
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
  // UDP: fragments of one packet; a full socket buffer drops the packet.
  std::uint32_t offset = 0;
  do {
    const std::uint32_t length = static_cast<std::uint32_t>(std::min<std::size_t>(size - offset, kMaxDatagramPayload));
    fields.offset = offset;
    encode_header(header, fields);
    iovec parts[2] = {{header, kHeaderSize}, {static_cast<char*>(const_cast<void*>(data)) + offset, length}};
    msghdr message{};
    message.msg_iov = parts;
    message.msg_iovlen = 2;
    if (::sendmsg(socket_.get(), &message, MSG_NOSIGNAL | MSG_DONTWAIT) < 0 && errno != ECONNREFUSED) break;
    offset += length;
  } while (offset < size);
  return true;
}

void RemoteSender::run() {
  std::optional<std::uint64_t> resume_after;
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
        ::listen(listener.get(), 16) != 0 ||
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

UniqueFd RemoteReceiver::open_inbox(const void* owner, std::uint32_t message_size, std::uint32_t history) {
  std::lock_guard<std::mutex> lock(mutex_);
  Inbox& inbox = inboxes_[owner];
  if (!inbox.ring) {
    transport::RingConfig config;
    config.message_size = std::max<std::uint32_t>(message_size, 1);
    config.history = std::max<std::uint32_t>(history, 1);
    config.debug_name = "ln:remote_inbox";
    try {
      inbox.ring = std::make_unique<transport::ShmWriter>(transport::ShmWriter::create(config));
    } catch (const transport::ShmError& error) {
      inboxes_.erase(owner);
      throw Failure(LNE_SHM_IS_TOO_BIG, std::string("creating the inbox for remote topic data: ") + error.what());
    }
  }
  UniqueFd duplicate(::fcntl(inbox.ring->fd(), F_DUPFD_CLOEXEC, 0));
  if (!duplicate.valid()) throw errno_failure(errno, "duplicating the inbox descriptor");
  return duplicate;
}

void RemoteReceiver::route(const void* owner, std::int64_t subscription_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = inboxes_.find(owner);
  if (it == inboxes_.end()) return;
  if (it->second.subscription_id >= 0) routes_.erase(it->second.subscription_id);
  it->second.subscription_id = subscription_id;
  routes_[subscription_id] = owner;
}

void RemoteReceiver::close_inbox(const void* owner) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = inboxes_.find(owner);
  if (it == inboxes_.end()) return;
  if (it->second.subscription_id >= 0) routes_.erase(it->second.subscription_id);
  inboxes_.erase(it);
}

void RemoteReceiver::deliver(std::int64_t subscription_id, std::uint64_t sequence, double timestamp,
                             std::uint32_t packet_size, std::uint32_t offset, const unsigned char* fragment,
                             std::size_t fragment_size) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto route = routes_.find(subscription_id);
  if (route == routes_.end()) return;  // not (or no longer) ours
  Inbox& inbox = inboxes_.at(route->second);
  if (packet_size > inbox.ring->message_size() || offset + fragment_size > packet_size) return;
  if (offset == 0 && fragment_size == packet_size) {
    inbox.ring->write(fragment, packet_size, timestamp);
    return;
  }
  if (inbox.sequence != sequence || inbox.assembly.size() != packet_size) {
    // A new packet; an unfinished older one is lost.
    inbox.sequence = sequence;
    inbox.received = 0;
    inbox.assembly.resize(packet_size);
  }
  std::memcpy(inbox.assembly.data() + offset, fragment, fragment_size);
  inbox.received += static_cast<std::uint32_t>(fragment_size);
  if (inbox.received >= packet_size) {
    inbox.ring->write(inbox.assembly.data(), packet_size, timestamp);
    inbox.sequence = 0;
    inbox.received = 0;
  }
}

void RemoteReceiver::on_datagram(const unsigned char* data, std::size_t size) {
  Header header{};
  if (!decode_header(data, size, header)) return;
  deliver(header.subscription_id, header.sequence, header.timestamp, header.packet_size, header.offset,
          data + kHeaderSize, size - kHeaderSize);
}

void RemoteReceiver::on_stream(Connection& connection) {
  for (;;) {
    if (connection.buffered.size() < 4) return;
    const auto* bytes = reinterpret_cast<const unsigned char*>(connection.buffered.data());
    const std::uint32_t frame = static_cast<std::uint32_t>(get_le(bytes, 4));
    if (frame < kHeaderSize || frame > kMaxPacketSize + kHeaderSize) {
      connection.socket.reset();  // not our protocol
      return;
    }
    if (connection.buffered.size() < 4u + frame) return;
    Header header{};
    if (decode_header(bytes + 4, frame, header) && header.offset == 0 && header.packet_size == frame - kHeaderSize)
      deliver(header.subscription_id, header.sequence, header.timestamp, header.packet_size, 0,
              bytes + 4 + kHeaderSize, header.packet_size);
    connection.buffered.erase(0, 4u + frame);
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
        on_datagram(datagram.data(), static_cast<std::size_t>(n));
      }
    }
    if (fds[2].revents != 0) {
      UniqueFd accepted(::accept4(listener_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC));
      if (accepted.valid()) connections_.push_back(Connection{std::move(accepted), {}});
    }
    for (std::size_t i = 3; i < fds.size(); ++i) {
      if (fds[i].revents == 0) continue;
      Connection& connection = connections_[i - 3];
      char chunk[65536];
      const ssize_t n = ::recv(connection.socket.get(), chunk, sizeof chunk, 0);
      if (n <= 0) {
        if (n == 0 || (errno != EAGAIN && errno != EINTR)) connection.socket.reset();
        continue;
      }
      connection.buffered.append(chunk, static_cast<std::size_t>(n));
      on_stream(connection);
    }
    connections_.erase(std::remove_if(connections_.begin(), connections_.end(),
                                      [](const Connection& c) { return !c.socket.valid(); }),
                       connections_.end());
  }
}

}  // namespace ln::clientlib
