// When a publisher tells the manager its packet count (methods.hpp:
// topic_stats), so that `ln topic list` can show rates although topic data
// never passes the manager. The client's I/O thread asks every period; a
// report goes out while the count changes, once more after it stopped (the
// manager's rate then drops to 0), and not again until it changes.
#pragma once

#include <chrono>
#include <cstdint>

namespace ln::clientlib {

class PacketCountReports {
 public:
  using Clock = std::chrono::steady_clock;
  /// How often the I/O thread looks at the counts.
  static constexpr std::chrono::milliseconds kPeriod{1000};

  /// The manager learned `packets` at `now` (publish, publisher_ready): the
  /// next rate interval starts here.
  void restart(std::uint64_t packets, Clock::time_point now) {
    reported_ = packets;
    reported_at_ = now;
    changing_ = false;
  }

  /// True if `packets` should be reported now; it then counts as reported.
  bool due(std::uint64_t packets, Clock::time_point now) {
    // An interval much shorter than the period (the first one after a
    // restart, which is not aligned with the ticks) gives a noisy rate.
    if (now - reported_at_ < kPeriod / 2) return false;
    if (packets != reported_) {
      changing_ = true;
    } else if (changing_) {
      changing_ = false;  // the last report of a burst: the rate is 0 now
    } else {
      return false;
    }
    reported_ = packets;
    reported_at_ = now;
    return true;
  }

 private:
  std::uint64_t reported_ = 0;
  Clock::time_point reported_at_{};
  bool changing_ = false;
};

}  // namespace ln::clientlib
