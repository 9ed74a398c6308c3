#include "manager/recorder.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstring>

#include "manager/request_error.hpp"
#include "protocol/methods.hpp"
#include "protocol/wire.hpp"
#include "transport/shm_layout.hpp"

namespace ln::manager {
namespace {

using Clock = std::chrono::steady_clock;
using transport::ReadStatus;
using transport::UniqueFd;

double wall_clock_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// How often a segment that stays silent is checked for a publisher that
/// died without closing it (a non-blocking read does not look).
constexpr std::chrono::seconds kAliveCheckInterval{1};

[[noreturn]] void unreachable(const std::string& peer_socket, const std::string& topic, const std::string& why) {
  throw RequestError(LNE_REQUEST_FAILED,
                     "cannot record topic '" + topic + "': its publisher's peer socket '" + peer_socket + "' " + why);
}

// One blocking request/response on a connected Unix socket whose send and
// receive timeouts are set; collects the descriptors that come along.
protocol::Message exchange(int socket, const protocol::Message& request, std::vector<UniqueFd>& fds,
                           Clock::time_point deadline, const std::string& peer_socket, const std::string& topic) {
  const std::string frame = protocol::encode(request);
  for (std::size_t sent = 0; sent < frame.size();) {
    const ssize_t n = ::send(socket, frame.data() + sent, frame.size() - sent, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) unreachable(peer_socket, topic, std::string("failed: ") + std::strerror(errno));
    sent += static_cast<std::size_t>(n);
  }
  protocol::FrameReader reader;
  for (;;) {
    if (auto message = reader.next()) return std::move(*message);
    char buffer[4096];
    iovec part{buffer, sizeof buffer};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 4)];
    msghdr header{};
    header.msg_iov = &part;
    header.msg_iovlen = 1;
    header.msg_control = control;
    header.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(socket, &header, MSG_CMSG_CLOEXEC);
    if (n < 0 && errno == EINTR && Clock::now() < deadline) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
      unreachable(peer_socket, topic, "did not answer open_segment in time");
    if (n <= 0) unreachable(peer_socket, topic, n == 0 ? "closed the connection" : std::strerror(errno));
    for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr; c = CMSG_NXTHDR(&header, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_RIGHTS) continue;
      for (std::size_t i = 0; i < (c->cmsg_len - CMSG_LEN(0)) / sizeof(int); ++i) {
        int fd = -1;
        std::memcpy(&fd, CMSG_DATA(c) + i * sizeof(int), sizeof fd);
        fds.emplace_back(fd);
      }
    }
    reader.append(buffer, static_cast<std::size_t>(n));
  }
}

}  // namespace

std::uint32_t tap_slots(std::uint64_t message_size) {
  const std::uint64_t fitting = kTapBytes / std::max<std::uint64_t>(message_size, 1);
  return static_cast<std::uint32_t>(std::clamp<std::uint64_t>(fitting, kMinTapSlots, kMaxTapSlots));
}

OpenedSegment open_publisher_segment(const std::string& peer_socket, std::int64_t topic_id, const std::string& topic,
                                     std::int64_t tap, std::uint32_t slots, std::chrono::milliseconds timeout) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (peer_socket.empty() || peer_socket.size() + 1 > sizeof address.sun_path)
    unreachable(peer_socket, topic, "is not a valid abstract socket name");
  std::memcpy(address.sun_path + 1, peer_socket.data(), peer_socket.size());  // abstract: leading NUL
  const auto length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + peer_socket.size());
  UniqueFd socket(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (!socket.valid()) unreachable(peer_socket, topic, std::string("cannot be used: ") + std::strerror(errno));
  timeval limit{};
  limit.tv_sec = static_cast<time_t>(timeout.count() / 1000);
  limit.tv_usec = static_cast<suseconds_t>((timeout.count() % 1000) * 1000);
  ::setsockopt(socket.get(), SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  ::setsockopt(socket.get(), SOL_SOCKET, SO_SNDTIMEO, &limit, sizeof limit);
  if (::connect(socket.get(), reinterpret_cast<const sockaddr*>(&address), length) != 0)
    unreachable(peer_socket, topic,
                std::string("is not reachable from the manager (") + std::strerror(errno) +
                    "): ln_core's manager records topics of publishers on its own host (same network namespace) only");

  protocol::Message request = protocol::Message::request(1, protocol::method::open_segment);
  request.set("topic_id", topic_id).set("subscription_id", tap).set("topic", topic).set("buffers", slots);
  std::vector<UniqueFd> fds;
  const protocol::Message answer = exchange(socket.get(), request, fds, Clock::now() + timeout, peer_socket, topic);
  if (answer.is_error())
    throw RequestError(LNE_REQUEST_FAILED, "cannot record topic '" + topic +
                                               "': its publisher refused to hand over "
                                               "its segment: " +
                                               answer.error_text());
  if (fds.empty()) unreachable(peer_socket, topic, "answered open_segment without a segment");
  OpenedSegment opened;
  opened.fd = std::move(fds.front());
  opened.slots = static_cast<std::uint32_t>(answer.get_int("slots", 1, transport::layout::kMaxHistory));
  opened.generation = answer.get_int_or("segment_generation", 0);
  opened.last_sequence = static_cast<std::uint64_t>(std::max<std::int64_t>(answer.get_int_or("last_sequence", 0), 0));
  return opened;
}

// ------------------------------------------------------------------ Recorder

Recorder::Recorder(LogFunction log) : log_(std::move(log)) {
  thread_ = std::thread([this] { run(); });
}

Recorder::~Recorder() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void Recorder::attach(std::int64_t tap_id, std::unique_ptr<transport::ShmReader> reader, std::uint32_t window,
                      const TapSettings& settings) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto [it, created] = taps_.try_emplace(tap_id);
    Tap& tap = it->second;
    if (created) tap.settings = settings;
    tap.buffer.resize(std::max<std::size_t>(tap.buffer.size(), reader->message_size()));
    tap.segments.push_back({std::move(reader), std::max<std::uint32_t>(window, 1), Clock::now()});
    period_ = kMinPeriod;  // a new stream: look soon, then settle
  }
  wake_.notify_all();
}

void Recorder::detach(std::int64_t tap_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = taps_.find(tap_id);
  if (it == taps_.end()) return;
  drain(it->second);
  taps_.erase(it);
}

void Recorder::catch_up(std::int64_t tap_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (const auto it = taps_.find(tap_id); it != taps_.end()) adapt(drain(it->second), false);
}

// Keep a drain at about a quarter of the window: halve the period when one
// found more than half, double it (only from the thread's own rounds) when
// all found less than 1/8.
void Recorder::adapt(double fullest, bool may_grow) {
  if (fullest > 0.5)
    period_ = std::max(kMinPeriod, period_ / 2);
  else if (may_grow && fullest < 0.125)
    period_ = std::min(kMaxPeriod, period_ * 2);
}

std::size_t Recorder::taps() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return taps_.size();
}

std::chrono::microseconds Recorder::period() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return period_;
}

double Recorder::drain(Tap& tap) {
  double fullest = 0;
  const auto now = Clock::now();
  for (auto segment = tap.segments.begin(); segment != tap.segments.end();) {
    transport::ShmReader& reader = *segment->reader;
    std::uint64_t delivered = 0;
    bool finished = false;
    for (;;) {
      transport::SampleInfo info;
      const ReadStatus status = reader.read(tap.buffer.data(), tap.buffer.size(), info, transport::kNoWait);
      if (status == ReadStatus::ok) {
        ++delivered;
        tap.lost += info.lost;
        const std::uint32_t divisor = std::max<std::uint32_t>(tap.settings.divisor, 1);
        if (++tap.seen % divisor != 0) continue;
        protocol::logger::SampleHeader header;
        header.log_ts = wall_clock_now();
        header.src_ts = info.timestamp;
        header.packet_counter = static_cast<std::uint32_t>(info.sequence);
        tap.settings.log->append(header, tap.buffer.data(), tap.settings.only_ts ? 0 : info.size);
        continue;
      }
      if (status == ReadStatus::no_data) {
        // A publisher that died without closing stays silent: look now and then.
        if (delivered == 0 && now - segment->checked_alive > kAliveCheckInterval) {
          segment->checked_alive = now;
          finished = !reader.publisher_alive() && !reader.has_new_data();
        }
        break;
      }
      // publisher_gone and segment_replaced come only once the window is read.
      if (status != ReadStatus::publisher_gone && status != ReadStatus::segment_replaced && log_)
        log_(LogLevel::Warning, tap.settings.name + ": stopped reading a segment: " + transport::to_string(status));
      finished = true;
      break;
    }
    fullest = std::max(fullest, static_cast<double>(delivered) / segment->window);
    segment = finished ? tap.segments.erase(segment) : segment + 1;
  }
  if (tap.lost > tap.lost_reported) {
    if (log_)
      log_(LogLevel::Warning, tap.settings.name + ": " + std::to_string(tap.lost - tap.lost_reported) +
                                  " packet(s) were overwritten before the recorder read them");
    tap.lost_reported = tap.lost;
    fullest = std::max(fullest, 1.0);
  }
  return fullest;
}

void Recorder::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    // Nothing to read (no tap, or only taps whose publishers left): sleep until attach().
    const auto reading = [this] {
      return std::any_of(taps_.begin(), taps_.end(), [](const auto& entry) { return !entry.second.segments.empty(); });
    };
    if (!reading()) {
      wake_.wait(lock, [&] { return stopping_ || reading(); });
      continue;
    }
    double fullest = 0;
    for (auto& entry : taps_) fullest = std::max(fullest, drain(entry.second));
    adapt(fullest, true);
    const auto period = period_;
    wake_.wait_for(lock, period, [this] { return stopping_; });
  }
}

}  // namespace ln::manager
