// Ports: the publisher end (OutPort) and subscriber end (InPort) of a topic
// inside one client. Their data path is the shared-memory ring of
// transport/shm_ring.hpp (for a publisher on another host: the subscription's
// inbox ring, fed by remote.hpp); the manager only arranges who talks to whom.
//
// Threads: read/write/borrow/unblock come from application threads; segment
// changes (a new publisher, a bigger segment) come from the client's I/O
// thread and are handed over without ever blocking a reader or writer for
// long.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "client/c_api.hpp"
#include "client/net.hpp"
#include "client/remote.hpp"
#include "transport/shm_ring.hpp"

namespace ln::clientlib {

class Client;
class ErrorSlot;

enum class PortKind : std::uint32_t { outport = 0x4f555450, inport = 0x494e5054 };

/// What ports of both kinds have in common; handles are PortBase pointers.
class PortBase {
 public:
  PortBase(PortKind kind, ErrorSlot& errors, std::string topic, std::string md_name)
      : kind_(kind), errors_(errors), topic_(std::move(topic)), md_name_(std::move(md_name)) {}
  virtual ~PortBase();
  PortBase(const PortBase&) = delete;
  PortBase& operator=(const PortBase&) = delete;

  PortKind kind() const { return kind_; }
  /// The topic name as the manager knows it (after name mapping).
  const std::string& topic() const { return topic_; }
  const std::string& md_name() const { return md_name_; }
  const std::string& hash() const { return hash_; }
  std::uint32_t message_size() const { return message_size_; }
  /// The client that owns the port.
  Client* owner() const { return owner_; }

  /// Sanity check for handles coming through the C API.
  static PortBase* from_handle(void* handle) noexcept;

 protected:
  /// Records the detail for ln_get_error_message() and returns -code.
  int fail(int code, const char* format, ...) const noexcept __attribute__((format(printf, 3, 4)));

  // Written before the port is handed to the application, constant after.
  PortKind kind_;
  ErrorSlot& errors_;
  std::string topic_;
  std::string md_name_;
  std::string hash_;
  std::uint32_t message_size_ = 0;
  Client* owner_ = nullptr;

  friend class Client;
};

/// Which publisher segment a subscriber reads: the publisher's peer socket
/// (unique per client) and the publisher's segment generation (unique per
/// process).
struct SegmentIdentity {
  std::string publisher_socket;
  std::int64_t generation = 0;
  bool operator==(const SegmentIdentity& other) const {
    return publisher_socket == other.publisher_socket && generation == other.generation;
  }
};

class OutPort : public PortBase {
 public:
  /// write() and next_buffer() replace a segment whose shared state makes
  /// writing impossible (a subscriber's stray writes into the part readers
  /// may write, which only can pin every spare slot) by a new one that
  /// continues the numbering: subscribers drain the old one and follow, as
  /// for a bigger segment, once set_recovery_handler()'s handler announced it.
  OutPort(ErrorSlot& errors, std::string topic, std::string md_name, std::uint32_t buffers)
      : PortBase(PortKind::outport, errors, std::move(topic), std::move(md_name)), buffers_(buffers) {}
  /// Stops the senders to remote subscribers first: they read the segment.
  ~OutPort() override;

  // ---- application threads
  int write(const void* packet, unsigned size, const double* timestamp) noexcept;
  int next_buffer(void** buffer, unsigned* length) noexcept;
  int subscribers() const noexcept { return subscribers_.load(std::memory_order_relaxed); }

  // ---- set-up and I/O thread
  std::uint32_t buffers() const { return buffers_; }
  /// The largest segment the manager allows for this topic (publish's
  /// segment_limit; 0: none known). Before create_segment().
  void set_segment_limit(std::uint64_t bytes) noexcept { segment_limit_ = bytes; }
  /// Creates the first segment. Throws Failure.
  void create_segment(std::uint32_t message_size, const std::string& hash, std::uint32_t history);
  /// Moves to a segment with at least `history` slots (as many as the
  /// segment limit allows) if the current one is smaller; subscribers drain
  /// the old one and continue without a gap. The new segment is made and
  /// filled in without the write lock, so writes go on meanwhile. Returns
  /// true if it switched. Throws Failure.
  bool ensure_history(std::uint32_t history);
  /// Called (from the writing thread, write lock held: it must only hand
  /// the work on) after write() replaced a corrupted segment. Before the
  /// port is handed to the program.
  void set_recovery_handler(std::function<void()> handler) { recovery_handler_ = std::move(handler); }
  /// Segments write() found corrupted and replaced (see write()).
  std::uint64_t segment_recoveries() const noexcept { return recoveries_.load(std::memory_order_relaxed); }
  std::int64_t generation() const;
  /// Packets written since the port was created (sequence numbers continue
  /// across segments). Only tries the write lock, so that counting never
  /// waits for a writer: while one writes, the previous count is returned.
  std::uint64_t packets_written() const noexcept;
  /// Replaces the segment if its shared state was written over (by a
  /// subscriber with a writable mapping; readers then fail): what write()
  /// does when it finds no free slot, for damage write() cannot notice. Only
  /// tries the write lock (the I/O thread calls it about once a second).
  /// True if it replaced the segment.
  bool check_segment() noexcept;
  void set_subscribers(int count) noexcept { subscribers_.store(count, std::memory_order_relaxed); }
  /// The newest packet's sequence number (0 before any). Taken under the
  /// write lock, so that whatever the program writes once it sees a
  /// set_subscribers() made after this call gets a higher number.
  std::uint64_t newest_sequence() const;
  /// Remembers the largest `buffers` a local subscriber asked for.
  void want_history(std::uint32_t history) noexcept;
  std::uint32_t wanted_history() const noexcept { return wanted_history_.load(); }

  /// What a subscriber needs to attach: a duplicate of the segment's
  /// descriptor (for passing; the caller closes it) and its parameters.
  struct SegmentOffer {
    UniqueFd fd;
    std::uint32_t slots = 0;
    std::int64_t generation = 0;
    std::uint64_t last_sequence = 0;
    std::uint64_t first_sequence = 1;  // of the segment's first packet: earlier ones are not in it
    std::uint64_t stream = 0;          // names the numbering of its packets (remote.hpp)
  };
  SegmentOffer offer_segment() const;

  /// The subscribers on other hosts, which this port feeds itself: starts a
  /// sender for each new one and stops those no longer listed.
  void set_remote_targets(const std::vector<RemoteTarget>& targets);

 private:
  const std::uint32_t buffers_;
  std::atomic<int> subscribers_{0};
  std::atomic<std::uint32_t> wanted_history_{1};

  /// The largest history that keeps the segment within segment_limit_.
  std::uint32_t history_limit() const noexcept;
  std::unique_ptr<transport::ShmWriter> make_writer(std::uint32_t message_size, std::uint32_t history,
                                                    std::uint64_t first_sequence, const char* what) const;
  /// Closes the current segment as replaced and continues in `next` (write lock held).
  void switch_segment_locked(std::unique_ptr<transport::ShmWriter> next);
  /// After writer_ found no free slot: a fresh segment (write lock held). False if that failed.
  bool recover_segment_locked() noexcept;

  std::uint64_t segment_limit_ = 0;
  mutable std::atomic<std::uint64_t> last_packets_written_{0};
  std::atomic<std::uint64_t> recoveries_{0};
  std::function<void()> recovery_handler_;
  mutable std::mutex write_mutex_;  // the writer, its loan and the generation
  std::unique_ptr<transport::ShmWriter> writer_;
  std::int64_t generation_ = 0;
  std::uint64_t first_sequence_ = 1;  // of writer_'s first packet
  std::uint64_t stream_ = 0;          // random, new whenever the numbering starts again at 1
  void* loan_ = nullptr;              // buffer handed out by next_buffer, not yet written
  // A writer replaced while a loan into it was open: kept until that loan's write.
  std::unique_ptr<transport::ShmWriter> retired_;
  void* retired_loan_ = nullptr;

  std::mutex senders_mutex_;
  std::map<RemoteTarget, std::unique_ptr<RemoteSender>> senders_;
};

class InPort : public PortBase {
 public:
  InPort(ErrorSlot& errors, std::string topic, std::string md_name, double rate, std::uint32_t buffers, bool reliable);
  ~InPort() override;

  // ---- application threads (one read at a time per port; others wait)
  /// timeout < 0 waits without limit, 0 polls. Returns 1, 0 or -LNE_*.
  int read(void* packet, unsigned size, ln_sample_info* info, double timeout) noexcept;
  int borrow(const void** packet, unsigned* size, ln_sample_info* info, double timeout) noexcept;
  int release_borrow() noexcept;
  /// Ends a blocked read with -LNE_PORT_UNBLOCKED (or the next one that would block). Any thread.
  void unblock() noexcept;
  bool has_publisher() const noexcept { return has_publisher_.load(std::memory_order_relaxed); }
  /// True if a read would return a packet now. Never blocks: a port being
  /// read by another thread counts as not readable.
  bool readable_now() noexcept;
  /// readable_now() for a thread about to sleep until that changes (the
  /// multi-waiter): if the port reads a segment, `watch` is set to watch its
  /// wake word *before* the check (see transport::ShmWakeWatch), so any packet
  /// that comes after the check changes the watched word. A port without a
  /// segment can only become readable through a new one, which changes
  /// segment_change_word(): load that before calling this.
  enum class WaitCheck {
    readable,
    not_readable,
    busy,  ///< another thread is reading the port: not checked, and nothing watched
  };
  WaitCheck check_before_sleep(transport::ShmWakeWatch& watch) noexcept;
  /// A process-wide futex word (shared-memory style: no FUTEX_PRIVATE_FLAG)
  /// that changes, with a FUTEX_WAKE, whenever a publisher's segment is
  /// offered to any input port.
  static const std::atomic<std::uint32_t>* segment_change_word() noexcept;

  // ---- set-up and I/O thread
  double rate() const { return rate_; }
  std::uint32_t buffers() const { return buffers_; }
  bool reliable() const { return reliable_; }
  void set_has_publisher(bool present) noexcept;
  /// True if `identity` is the segment being read or about to be.
  bool knows_segment(const SegmentIdentity& identity) const;
  /// A publisher's segment to read from now on (replacing a pending one).
  /// `written_before`: the last packet that is not this subscriber's (0:
  /// none); later ones are, even if they come before its next read adopts
  /// the segment. Unset: only those written after adopting.
  void offer_segment(UniqueFd fd, SegmentIdentity identity, std::uint32_t slots,
                     std::optional<std::uint64_t> written_before = std::nullopt);
  /// The publisher left: forget a segment that was not adopted yet.
  void forget_pending_segment();
  /// The publisher's data cannot be delivered (remote: other byte order):
  /// reads fail with `code` from now on. Any thread.
  void fail_stream(int code, const std::string& text);

 private:
  struct PendingSegment {
    UniqueFd fd;
    SegmentIdentity identity;
    std::uint32_t slots = 0;
    std::optional<std::uint64_t> written_before;
  };

  template <typename Attempt>
  int next_packet(transport::WaitDeadline& deadline, Attempt&& attempt, transport::SampleInfo& info);
  void adopt_pending_segment();
  /// adopt_pending_segment(), and also the same publisher's next segment once
  /// the current one is drained and closed (what a read does when it gets
  /// segment_replaced), so that a port that is only watched moves on too.
  /// With a watch: the segment read afterwards is watched, from before its
  /// state was looked at.
  void settle_segment(transport::ShmWakeWatch* watch);
  /// After a read reported segment_replaced or publisher_gone: forgets the segment.
  void leave_segment(transport::ReadStatus status);
  /// readable_now() and check_before_sleep() (which passes a watch).
  WaitCheck check(transport::ShmWakeWatch* watch) noexcept;
  int wait_for_segment(transport::WaitDeadline& deadline);
  void drop_reader();
  bool passes_rate_limit(const transport::SampleInfo& info);
  void deliver_info(const transport::SampleInfo& info, ln_sample_info* out);
  int read_on_request(void* packet, unsigned size, ln_sample_info* info) noexcept;

  const double rate_;
  const std::uint32_t buffers_;
  const bool reliable_;
  const bool on_request_;
  std::atomic<bool> has_publisher_{false};

  std::mutex read_mutex_;                         // one reading thread at a time; held while it waits
  std::unique_ptr<transport::ShmReader> reader_;  // swapped only with state_mutex_ held as well
  SegmentIdentity current_;
  std::vector<unsigned char> bounce_;  // for rate filtering, short user buffers, on-request reads
  double last_delivered_timestamp_ = 0;
  bool delivered_any_ = false;
  std::uint64_t lost_carry_ = 0;  // packets skipped by the rate limit since the last delivery
  std::uint64_t resume_after_ = 0;
  std::string resume_socket_;
  // RATE_ON_REQUEST_LAST: the newest packet seen, returned again until a newer one arrives.
  bool have_cached_ = false;
  transport::SampleInfo cached_info_;

  mutable std::mutex state_mutex_;  // hand-over from the I/O thread and unblock
  std::condition_variable state_changed_;
  std::optional<PendingSegment> pending_;
  std::atomic<bool> has_pending_{false};  // pending_ is set; read without the lock on every read
  std::atomic<int> stream_failure_{0};    // fail_stream()'s code
  std::string stream_failure_text_;
  bool user_unblock_ = false;

  std::mutex loan_mutex_;
  transport::BorrowedSample loan_;
  bool loan_is_copy_ = false;  // lent from loan_copy_ (RATE_ON_REQUEST_LAST)
  std::vector<unsigned char> loan_copy_;
};

/// A process-unique generation number for a new publisher segment.
std::int64_t next_segment_generation();

}  // namespace ln::clientlib
