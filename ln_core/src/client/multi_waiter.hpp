// ln_multi_waiter: waits until any of several input ports has a packet.
//
// Event-driven: the waiter sleeps in one futex_waitv (Linux >= 5.16) on
//   * its own wake word: add_port, remove_port and shutdown change it;
//   * InPort::segment_change_word(): a port is offered a (new) segment;
//   * the wake word of every port's current segment, each watched with the
//     protocol of a blocking shared-memory read (transport::ShmWakeWatch):
//     counted as a sleeping reader, word loaded, port checked, then sleep
//     only while the word is unchanged.
// Each word is loaded before the state it guards is checked, and whoever
// changes that state changes the word afterwards and wakes it, so a change
// after the check makes the sleep return (or not begin), and one before it
// is seen by the check: no packet is missed, and an idle waiter never wakes.
// A port being read by another thread at that moment counts as not readable
// and cannot be checked, so while there is one (or more ports than
// futex_waitv takes) the sleep is cut into steps of 20 µs growing to 1 ms.
//
// Where futex_waitv is missing (old kernel, seccomp: ENOSYS or EPERM) the
// waiter polls its ports instead: spinning briefly, then sleeping in growing
// steps up to 1 ms.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "client/net.hpp"

namespace ln::clientlib {

class Client;
class InPort;

class MultiWaiter {
 public:
  explicit MultiWaiter(Client* owner) : owner_(owner) {}
  ~MultiWaiter();
  MultiWaiter(const MultiWaiter&) = delete;
  MultiWaiter& operator=(const MultiWaiter&) = delete;

  void add_port(InPort* port);
  /// False if the port was not in the set.
  bool remove_port(InPort* port);
  /// Number of readable ports (> 0), or 0 when `timeout` passed first
  /// (timeout < 0: no limit, 0: only checks).
  int wait(double timeout);
  bool can_read(InPort* port);

  /// Starts the thread that makes the returned descriptor readable while a
  /// port is readable; one notification until it is acknowledged. Throws Failure.
  int start_pipe_notifier();
  /// Consumes one notification. Returns 0, or -LNE_INVALID_PARAMETER if no
  /// notifier runs.
  int acknowledge();

  Client* owner() const { return owner_; }

  /// Tests only: while true, futex_waitv fails with ENOSYS, so waiters poll.
  /// Setting it back to false lets them try futex_waitv again.
  static void simulate_missing_futex_waitv(bool missing) noexcept;
  /// False once futex_waitv failed with ENOSYS/EPERM: waits poll.
  static bool event_driven() noexcept;

 private:
  class Sleep;

  int count_readable();
  /// The polling wait (without futex_waitv).
  int poll(std::chrono::steady_clock::time_point deadline);
  /// Changes wake_word_ and wakes a waiting wait().
  void wake() noexcept;
  void notifier_main();

  Client* const owner_;
  std::mutex mutex_;  // the port set; held while ports are checked, so removal waits for a check
  std::vector<InPort*> ports_;
  std::atomic<std::uint32_t> wake_word_{0};  // futex word (non-private futex operations)

  std::thread notifier_;
  std::atomic<bool> stopping_{false};
  UniqueFd pipe_read_;
  UniqueFd pipe_write_;
  std::mutex ack_mutex_;
  std::condition_variable ack_cv_;
  bool notified_ = false;
};

}  // namespace ln::clientlib
