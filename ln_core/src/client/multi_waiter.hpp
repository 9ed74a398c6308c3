// ln_multi_waiter: waits until any of several input ports has a packet.
//
// The shared-memory rings wake their own readers only, so the waiter checks
// its ports itself: spinning briefly (packets that follow quickly are caught
// without a system call), then sleeping in growing steps up to 1 ms. A port
// being read by another thread at that moment counts as not readable.
#pragma once

#include <atomic>
#include <condition_variable>
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

 private:
  int count_readable();
  void notifier_main();

  Client* const owner_;
  std::mutex mutex_;  // the port set; held while ports are checked, so removal waits for a check
  std::vector<InPort*> ports_;

  std::thread notifier_;
  std::atomic<bool> stopping_{false};
  UniqueFd pipe_read_;
  UniqueFd pipe_write_;
  std::mutex ack_mutex_;
  std::condition_variable ack_cv_;
  bool notified_ = false;
};

}  // namespace ln::clientlib
