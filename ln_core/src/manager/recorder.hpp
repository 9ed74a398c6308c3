// Where ln_core's topic loggers record: in the manager process, which reads a
// publisher's shared-memory segment as a subscriber does (LN 2.9's daemon did
// this on the publisher's host; ln_core has no daemons).
//
// Why here and not in the publisher's client library: a recording in the
// publisher's process would die with it, and LN's logged data outlives the
// publisher until it is downloaded. The manager maps the segment itself (the
// memfd lives as long as a mapping does), so it drains every packet a
// crashed or finished publisher wrote. The manager's event loop stays free:
// reading happens in the Recorder's own thread.
//
// Why polling: a reader asleep in a blocking read makes every write() of the
// publisher issue FUTEX_WAKE. Measured on the 2-vCPU VM at 1 kHz, 64 B
// (3000 writes, median / p99 of the publisher's write()): no reader 0.5-0.7 /
// 1.5-2.6 µs, a sleeping reader 6.0 / 19-23 µs (max 5 ms), a reader polling
// every 5 ms 0.5-0.9 / 1.5-2.2 µs, an extra copy into a log inside the
// publisher 0.8-0.9 / 2.7 µs. So the recorder never sleeps on a segment: it
// drains all its segments, then sleeps on its own clock. It asks for a window
// of kTapBytes (at most kMaxTapSlots, at least kMinTapSlots packets) and
// shortens its period while a drain finds the window more than half full, so
// it keeps up with fast streams and wakes rarely for slow ones. The price:
// log_ts is when the recorder copied the packet, up to one period
// (kMaxPeriod) after it was written, not within microseconds as with LN 2.9.
// Packets the publisher overwrote before the recorder came are counted and
// reported in the manager's log (packet_counter shows the gap).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "manager/log.hpp"
#include "manager/sample_log.hpp"
#include "transport/shm_ring.hpp"

namespace ln::manager {

/// A tap asks the publisher for a window of this many bytes of packets ...
inline constexpr std::uint64_t kTapBytes = 4u << 20;
/// ... within these many packets (the segment grows to the largest window).
inline constexpr std::uint32_t kMinTapSlots = 4;
inline constexpr std::uint32_t kMaxTapSlots = 256;
/// The recorder's polling period adapts between these.
inline constexpr std::chrono::microseconds kMinPeriod{100};
inline constexpr std::chrono::microseconds kMaxPeriod{5000};

/// The packets a tap reads at once for a topic of `message_size` bytes.
std::uint32_t tap_slots(std::uint64_t message_size);

/// What the publisher's peer server answered to open_segment.
struct OpenedSegment {
  transport::UniqueFd fd;
  std::uint32_t slots = 1;
  std::int64_t generation = 0;
  std::uint64_t last_sequence = 0;  ///< read the packets after this one
};

/// Asks the publisher listening on the abstract Unix socket `peer_socket`
/// for its segment of `topic` (methods.hpp open_segment), as subscription
/// `tap`. Blocks at most `timeout`. Throws RequestError (LNE_REQUEST_FAILED
/// with the reason: unreachable, refused, no answer).
OpenedSegment open_publisher_segment(const std::string& peer_socket, std::int64_t topic_id, const std::string& topic,
                                     std::int64_t tap, std::uint32_t slots, std::chrono::milliseconds timeout);

/// How a tap records.
struct TapSettings {
  std::shared_ptr<SampleLog> log;
  std::uint32_t divisor = 1;  ///< every divisor-th packet (0 counts as 1)
  bool only_ts = false;       ///< sample headers only
  std::string name;           ///< "logger 'L', topic 'T'" for the manager's log
};

/// The recording thread. All methods are thread-safe.
class Recorder {
 public:
  explicit Recorder(LogFunction log);
  /// Stops the thread; the logs keep what was recorded.
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// Records what `reader` (attached with ReaderOptions::buffers `window`)
  /// delivers into the tap `tap` (created with `settings` on first use;
  /// later calls keep the tap's settings). A tap reads its segments in
  /// attach order: a publisher's replaced segment before the new one, one
  /// publisher before the next.
  void attach(std::int64_t tap, std::unique_ptr<transport::ShmReader> reader, std::uint32_t window,
              const TapSettings& settings);
  /// Records what the tap's segments hold now (the packets written before
  /// this call), then forgets the tap.
  void detach(std::int64_t tap);
  /// Records what the tap's segments hold now.
  void catch_up(std::int64_t tap);
  /// Taps being recorded (for tests and diagnostics).
  std::size_t taps() const;
  /// The current polling period (for tests and diagnostics).
  std::chrono::microseconds period() const;

 private:
  struct Segment {
    std::unique_ptr<transport::ShmReader> reader;
    std::uint32_t window;  // packets the reader may fall behind
    std::chrono::steady_clock::time_point checked_alive;
  };
  struct Tap {
    TapSettings settings;
    std::vector<Segment> segments;
    std::vector<unsigned char> buffer;
    std::uint64_t seen = 0;  // packets delivered, for the divisor
    std::uint64_t lost = 0;  // packets overwritten before the recorder read them
    std::uint64_t lost_reported = 0;
  };
  /// Reads every segment of `tap` empty; returns the largest fraction of a
  /// window one drain found (1 or more: packets were lost).
  double drain(Tap& tap);
  /// Adjusts the polling period to what a drain found.
  void adapt(double fullest, bool may_grow);
  void run();

  LogFunction log_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::map<std::int64_t, Tap> taps_;
  std::chrono::microseconds period_ = kMaxPeriod;
  std::thread thread_;
};

}  // namespace ln::manager
