#pragma once

// Shared-memory topic transport: the data path of local publish/subscribe.
//
// One publisher process (ShmWriter) and any number of subscriber processes
// (ShmReader) share one segment: an anonymous, size-sealed memfd (see
// shm_segment.hpp) whose descriptor the publisher hands to subscribers over a
// Unix socket (send_fd / receive_fd).
//
// ---------------------------------------------------------------- semantics
// * Packets carry a sequence number (monotonic, starting at
//   RingConfig::first_sequence, default 1) and a publisher timestamp
//   (double seconds, wall clock unless the caller passes one).
// * The segment keeps the newest `history` packets. Each reader picks its own
//   `buffers` (1 ≤ buffers ≤ history):
//     buffers == 1: a read always returns the newest packet (older unread ones
//                   are counted as lost);
//     buffers == N: a reader may fall behind by up to N packets and still gets
//                   them in order; when it falls further behind it skips ahead,
//                   by default to the newest packet like LN 2.9
//                   (LagPolicy::skip_to_newest), or, on request, to the oldest
//                   packet of its window (LagPolicy::keep_latest_window, i.e.
//                   DDS KEEP_LAST(N)).
//   SampleInfo::lost reports how many packets were skipped since this
//   reader's previous delivery (including numbers that a write_as() jumped
//   over: a relayed stream's gaps count as lost too). A reader only sees packets written after it
//   attached (no latched value) unless ReaderOptions::resume_after asks for
//   an earlier starting point.
// * So LN's "the segment has as many slots as the largest `buffers` of any
//   subscriber" becomes: create the segment with `history` = the largest
//   `buffers` expected; subscribers choose theirs freely up to it. If a
//   subscriber needs more, the publisher creates a bigger segment and switches
//   (see "Switching segments" below).
// * write() never blocks and copies the whole packet; loan()/commit() is the
//   zero-copy variant (LN's ln_outport_get_next_buffer).
// * read() copies a whole packet or nothing: the caller's buffer is left
//   untouched unless ReadStatus::ok is returned (one documented exception in
//   ShmReader::read). borrow() gives zero-copy access in place.
// * Neither reads nor writes ever block each other; only blocking reads
//   wait, for the next packet.
//
// ---------------------------------------------------------------- protocol
// Slots are not tied to ring positions. The segment has
//     slot_count = history + borrow_slots + 1
// slots; `ring[seq % history]` names the slot that holds packet `seq`; the
// remaining borrow_slots + 1 slots are "spares" known only to the writer.
//
// Writing packet n: the writer takes a spare slot (skipping any that is
// borrowed), marks it "being written" (slot sequence = 0), copies the payload,
// stores sequence = n, points ring[n % history] at it, turns the slot that was
// there into a spare, and publishes head_sequence = n. The next write takes
// the slot just evicted (unless a reader pinned it), so a stream keeps
// reusing the same two cache-warm slots; a copying reader still busy with
// that older packet sees the overwrite and retries (see below).
//
// Copying read (seqlock): look up the slot of the wanted sequence, check its
// sequence, copy, check the sequence again; a mismatch means the writer reused
// the slot meanwhile, so the copy is discarded and the reader retries with the
// current head. Readers never write to the segment on this path. (As in every
// seqlock, the payload copy formally races with the writer in the C++ memory
// model; the copy is only used after the second check proved it intact, and
// ThreadSanitizer will report it.) After
// ReaderOptions::optimistic_copies torn copies in a row the reader pins the
// slot (see borrowing) for the next attempt, which then cannot fail.
//
// Streamed copies: write() of a packet of 64 KiB or more announces it in the
// header before copying (stream_target = its sequence and slot,
// stream_bytes = 0), wakes the readers that wait for stream starts, and
// copies in 16 KiB chunks, storing stream_bytes after each. A copying read
// without a deadline (kWaitForever) on another CPU whose next packet that is
// copies each chunk as it is announced, so the two copies of a packet run side by side instead of
// one after the other; after the commit (which clears stream_target) the
// same seqlock check as above decides whether the copy is valid. Readers on
// the writer's CPU do not follow (they would only keep the writer from
// running) and are not woken by stream starts (FUTEX_WAIT_BITSET masks).
// A writer that makes no progress for SpinPolicy::max_spin is left to the
// ordinary wait; that stream is not followed again. Reads with a deadline
// never follow: one that times out must leave the buffer untouched.
//
// Borrowing (zero-copy read): a reader pins a slot by setting one bit in the
// slot's borrow state (only while the writer is not writing it, checked by
// compare-and-swap; the writer in turn claims a spare by CAS 0 → writing).
// The writer never writes a pinned slot. Pins are made with *borrow tokens*:
// the segment has `borrow_slots` tokens, one bit each; a token pins at most
// one slot at a time. So at most borrow_slots slots are pinned and, among the
// borrow_slots + 1 spares, at least one is always free: the writer never
// blocks and never fails for lack of a slot.
// Tokens live in a small table of the reader area: token t is free or owned by a
// reader *ticket* (a number drawn once per attach and never reused). Claiming
// and returning a token is one CAS / one store, no system call. Every reader
// holds a Linux OFD byte-range lock on byte 1 + ticket of the memfd for its
// whole life; the kernel drops it when the reader's process dies. A reader
// that finds no free token checks the owners' locks and takes over tokens of
// dead readers (CAS on the owner ticket, so exactly one wins, and a ticket
// never comes back, so there is no ABA), clearing their stale pins first.
// A crashed reader thus costs nothing permanent.
//
// Blocking: readers spin adaptively (bounded by SpinPolicy; they yield once
// instead of spinning when the publisher last wrote from their own CPU, unless
// it streams there: see ReaderCore::yield_to_publisher), then
// sleep in FUTEX_WAIT on the reader area's wake_word, announced in
// `sleeping_readers`. The writer bumps wake_word on every write and issues
// FUTEX_WAKE only when sleeping_readers != 0 (LN 2.9 wakes on every write).
//
// Publisher liveness: the publisher holds an OFD lock on byte 0 of the memfd.
// A reader checks it (one fcntl) every ReaderOptions::liveness_check_interval
// while blocked and in publisher_alive(); a clean close() is seen at once.
// For this to work the descriptor received over the socket must be closed
// after attaching (attach(UniqueFd) does it; every reader maps through its
// own re-opened description), and no other process may keep the publisher's
// descriptor open (including children forked while it was open).
// A reader process that dies while asleep in a blocking read leaves
// sleeping_readers one too high: the writer then calls FUTEX_WAKE on every
// write (as LN 2.9 always does) -- slower, never wrong.
//
// Access: all that readers write (borrow states, tokens, tickets, the futex
// word and sleeping_readers) is in the reader area at the end of the
// segment (shm_layout.hpp). With ReaderOptions::write_protect a reader maps
// the publisher's part (header, ring, slots with the packets) read-only and
// only the reader area writable (on systems whose pages are larger than
// 4 KiB, everything writable), so its stray writes can never change a
// packet, the ring or the header. Garbage in the reader area can at worst
// make every spare look pinned: the writer's write() and loan() then fail
// with WriteStatus::no_free_slot / nullptr, and the owner replaces the
// segment as below (the client library does that by itself, see
// client/ports.hpp).
//
// Switching segments (e.g. a subscriber asks for more than `history`): the
// publisher creates a new ShmWriter with
// RingConfig::first_sequence = old.last_sequence() + 1, sends its descriptor
// to the subscribers (through the manager), and calls old.close_replaced().
// A reader of the old segment gets every packet still in its window and then
// ReadStatus::segment_replaced; it attaches to the new segment with
// ReaderOptions::resume_after = old_reader.last_sequence() and continues with
// no gap (packets already written to the new segment and still in the new
// reader's window are delivered, further ones are counted as lost).
//
// ---------------------------------------------------------------- threads
// An ShmWriter and an ShmReader are each used by one thread at a time.
// ShmReader::unblock() and BorrowedSample::release() (and destruction) may be
// called from any thread. Objects must not be used in a fork()ed child; the
// child attaches on its own.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "transport/shm_segment.hpp"

namespace ln::transport {

inline constexpr std::chrono::nanoseconds kNoWait{0};
inline constexpr std::chrono::nanoseconds kWaitForever{-1};

/// How long blocking reads may wait, as a deadline whose clock starts only
/// when a read first has to wait: a reader that keeps up with a stream finds
/// its packet at once, and reading the clock would cost as much as the read.
/// Consecutive reads given the same WaitDeadline share one deadline.
class WaitDeadline {
 public:
  using TimePoint = std::chrono::steady_clock::time_point;
  /// timeout: kNoWait, kWaitForever (any negative value) or a duration.
  explicit WaitDeadline(std::chrono::nanoseconds timeout) noexcept : timeout_(timeout) {}
  bool polls() const noexcept { return timeout_ == kNoWait; }
  bool forever() const noexcept { return timeout_ < std::chrono::nanoseconds::zero(); }
  /// The deadline; the first call starts the clock at `now`.
  TimePoint at(TimePoint now) noexcept {
    if (!started_) {
      started_ = true;
      at_ = forever() ? TimePoint::max() : now + timeout_;
    }
    return at_;
  }

 private:
  std::chrono::nanoseconds timeout_;
  bool started_ = false;
  TimePoint at_{};
};

struct RingConfig {
  std::uint32_t message_size = 0;          ///< largest packet in bytes (packets may be shorter)
  std::uint32_t history = 1;               ///< packets kept: the largest `buffers` a reader may use
  std::uint32_t borrow_slots = 2;          ///< simultaneous borrows over all readers (0..63); costs one slot each
  std::uint64_t first_sequence = 1;        ///< sequence number of the first packet (≥ 1)
  std::string debug_name = "ln_shm_ring";  ///< shows up in /proc/<pid>/fd
};

/// Borrow slots of the segments the client library creates for topics: one
/// per subscriber that holds a zero-copy loan at a time, shared by all
/// subscribers (the ring grows by one slot per token).
inline constexpr std::uint32_t kTopicBorrowSlots = 4;

/// Bytes of a topic's segment for packets of `message_size` bytes kept
/// `history` deep (kTopicBorrowSlots borrow slots): what the manager's
/// shared-memory limits count. 0 when the sizes are out of range.
std::uint64_t topic_segment_size(std::uint32_t message_size, std::uint32_t history) noexcept;

enum class WriteStatus {
  ok,
  packet_too_large,  ///< size > message_size; nothing written
  loan_outstanding,  ///< write()/loan() while a loan is open
  no_loan,           ///< commit()/discard without loan()
  no_free_slot,      ///< only with a corrupted segment: every spare looked borrowed
  closed,            ///< after close()
  bad_sequence,      ///< write_as(): not above last_sequence() (or beyond 2^62); nothing written
};

enum class ReadStatus {
  ok,                ///< a packet was delivered
  no_data,           ///< non-blocking call, no new packet
  timeout,           ///< blocking call, no new packet before the timeout
  unblocked,         ///< unblock() was called
  publisher_gone,    ///< no new packet and the publisher closed the segment or died
  segment_replaced,  ///< no new packet and the publisher moved to a new segment
  buffer_too_small,  ///< the packet is larger than the buffer; SampleInfo::size says how large; not consumed
  borrow_limit,      ///< this reader's max_borrows reached, or all borrow tokens of the segment are in use
  corrupt_segment,   ///< the shared header or ring holds impossible values
};

const char* to_string(WriteStatus status);
const char* to_string(ReadStatus status);

enum class ReadMode {
  next,    ///< the next packet by this reader's buffers/lag policy
  newest,  ///< the newest packet, skipping (and counting) any older unread ones
};

enum class LagPolicy {
  skip_to_newest,      ///< LN 2.9: a reader that fell behind its window jumps to the newest packet
  keep_latest_window,  ///< jump to the oldest packet of its window (DDS KEEP_LAST)
};

/// Busy-wait phase of blocking reads, before sleeping in the kernel. The
/// limit doubles (up to max_spin) after every wait that ended within max_spin
/// and halves (down to min_spin) after every wait that took longer, so a
/// reader of a fast stream spins up to max_spin per packet and a reader of a
/// slow one only min_spin. max_spin bounds the CPU a waiting reader burns per
/// packet; it is about what sleeping would cost instead, a futex sleep plus
/// wake-up across cores: 5-20 µs on bare metal, 40-50 µs on the 2-vCPU VMs we
/// measure on. A shorter bound loses exactly the partners it is for: a Python
/// ping-pong peer that needs ~20 µs per message (numpy work) made 20 µs
/// too short, both sides slept on every packet, 106 µs per round trip
/// instead of 5. max_spin == 0 disables spinning.
struct SpinPolicy {
  std::chrono::nanoseconds min_spin{std::chrono::microseconds(1)};
  std::chrono::nanoseconds max_spin{std::chrono::microseconds(50)};
};

struct ReaderOptions {
  std::uint32_t buffers = 1;
  LagPolicy on_lag = LagPolicy::skip_to_newest;
  std::uint32_t max_borrows = 2;  ///< simultaneous borrows by this reader (further capped by borrow_slots)
  /// Torn copies a read() tolerates before it pins the packet with a borrow
  /// token for the copy (so the next attempt cannot fail). 0 = always pin when
  /// a token is free: no copy is ever wasted, which pays off for very large
  /// packets that a fast publisher overwrites often (such a reader does not
  /// follow streamed writes either: a slot being written cannot be pinned).
  std::uint32_t optimistic_copies = 3;
  /// Unset: only packets written after attach; else packets with sequence >
  /// this (0: every packet still in the window).
  std::optional<std::uint64_t> resume_after;
  SpinPolicy spin;
  std::chrono::milliseconds liveness_check_interval{100};
  /// Map the publisher's part of the segment read-only (see "Access"): a
  /// stray write of this process then faults at once instead of changing
  /// packets. Off by default: reads through read-only pages measured about
  /// 30 % slower split-core round trips (0.34 -> 0.43 us, 1.07 -> 1.40 us;
  /// AMD EPYC under KVM, shm_ring_bench rtt 64 copy/zero_copy split).
  bool write_protect = false;
};

struct SampleInfo {
  std::uint64_t sequence = 0;  ///< publisher's sequence number of this packet
  std::uint64_t lost = 0;      ///< packets skipped since this reader's previous delivery
  double timestamp = 0.0;      ///< publisher timestamp, seconds
  std::uint32_t size = 0;      ///< packet size in bytes
};

struct ReaderStats {
  std::uint64_t torn_copies = 0;        ///< copies discarded because the writer reused the slot
  std::uint64_t pinned_copies = 0;      ///< copies done under a borrow after repeated torn copies
  std::uint64_t spin_wakeups = 0;       ///< waits satisfied while spinning
  std::uint64_t futex_sleeps = 0;       ///< FUTEX_WAIT calls
  std::uint64_t yield_backoffs = 0;     ///< times the publisher hogged this CPU during a yield
  std::uint64_t streamed_copies = 0;    ///< packets copied out behind the writer (see "Streamed copies")
  std::uint64_t abandoned_streams = 0;  ///< streamed writes given up on because the writer stalled
};

namespace detail {
struct ReaderCore;
struct WriterCore;
}  // namespace detail

/// Publisher side of one segment. Move-only; destruction closes the segment.
class ShmWriter {
 public:
  /// Creates the memfd, maps it and formats it. Throws ShmError.
  static ShmWriter create(const RingConfig& config);

  ShmWriter(ShmWriter&&) noexcept;
  ShmWriter& operator=(ShmWriter&&) noexcept;
  ~ShmWriter();

  /// The segment's descriptor, to send to subscribers with send_fd().
  /// Stays owned by the writer.
  int fd() const noexcept;
  std::uint32_t message_size() const noexcept;
  std::uint32_t history() const noexcept;
  std::uint32_t borrow_slots() const noexcept;

  /// Copies `size` bytes into the next slot and publishes them. Never blocks.
  WriteStatus write(const void* data, std::size_t size, double timestamp) noexcept;
  WriteStatus write(const void* data, std::size_t size) noexcept;  ///< timestamp = wall clock now
  /// write() with an explicit sequence number above last_sequence(), for
  /// relaying another writer's packets under their own numbers (the inbox
  /// of remote topic data). Numbers skipped by a jump were never written:
  /// readers count them in SampleInfo::lost like overwritten packets.
  WriteStatus write_as(std::uint64_t sequence, const void* data, std::size_t size, double timestamp) noexcept;

  /// Zero-copy write: returns message_size() writable bytes (32-byte aligned)
  /// in the next slot, or nullptr (loan already open, closed). Readers cannot
  /// see the slot until commit().
  void* loan() noexcept;
  WriteStatus commit(std::size_t size, double timestamp) noexcept;
  WriteStatus commit(std::size_t size) noexcept;
  void discard_loan() noexcept;

  /// Makes `first_sequence` the number of the first packet, as if the
  /// segment had been created with it. Only before anything was written and
  /// before the descriptor went to anyone: for a segment that is created
  /// ahead of time and takes over from another writer later. Returns false
  /// (and changes nothing) otherwise or for a number out of range.
  bool renumber(std::uint64_t first_sequence) noexcept;
  /// Sequence number of the newest packet written, first_sequence - 1 before any.
  std::uint64_t last_sequence() const noexcept;
  /// last_sequence() as readers see it, for threads other than the writer's
  /// (one atomic load, never blocks the writer).
  std::uint64_t published_sequence() const noexcept;
  /// Readers currently asleep in a blocking read (for tests and diagnostics).
  std::uint32_t sleeping_readers() const noexcept;
  /// False if the segment's shared state no longer is what this writer
  /// made it (a reader with a writable mapping wrote over the header or the
  /// ring): readers may then fail with ReadStatus::corrupt_segment, and the
  /// owner replaces the segment. Reads O(history); not during a write.
  bool shared_state_intact() const noexcept;

  /// Marks the segment closed and wakes all readers; they drain what is left
  /// and then get publisher_gone. Idempotent.
  void close() noexcept;
  /// Same, but readers get segment_replaced (see "Switching segments").
  void close_replaced() noexcept;

 private:
  explicit ShmWriter(std::unique_ptr<detail::WriterCore> core) noexcept;
  std::unique_ptr<detail::WriterCore> core_;
};

class ShmReader;
class ShmWakeWatch;

/// A packet read in place. Move-only; releases its pin on destruction or
/// release(). Keeps the mapping alive, so it may outlive its ShmReader.
/// The bytes must not be modified (other readers see the same memory).
class BorrowedSample {
 public:
  BorrowedSample() = default;
  BorrowedSample(BorrowedSample&& other) noexcept;
  BorrowedSample& operator=(BorrowedSample&& other) noexcept;
  BorrowedSample(const BorrowedSample&) = delete;
  BorrowedSample& operator=(const BorrowedSample&) = delete;
  ~BorrowedSample() { release(); }

  bool valid() const noexcept { return data_ != nullptr; }
  const void* data() const noexcept { return data_; }
  std::size_t size() const noexcept { return info_.size; }
  const SampleInfo& info() const noexcept { return info_; }
  void release() noexcept;

 private:
  friend class ShmReader;
  friend struct detail::ReaderCore;
  std::shared_ptr<detail::ReaderCore> core_;
  const std::byte* data_ = nullptr;
  SampleInfo info_;
  std::uint32_t token_ = 0;
  std::uint32_t slot_ = 0;
};

/// Subscriber side of one segment. Move-only.
class ShmReader {
 public:
  /// Attaches to the segment behind `segment_fd` and closes that descriptor
  /// (the reader maps through its own re-opened description; see "Publisher
  /// liveness"). Validates the header. Throws ShmError.
  static ShmReader attach(UniqueFd segment_fd, const ReaderOptions& options = {});
  /// Same, but leaves `segment_fd` open (for a process that also holds the writer).
  static ShmReader attach(int segment_fd, const ReaderOptions& options = {});

  ShmReader(ShmReader&&) noexcept;
  ShmReader& operator=(ShmReader&&) noexcept;
  ~ShmReader();

  /// Copies the next packet into `buffer`. timeout: kNoWait, kWaitForever or
  /// a duration. On any status but ok the buffer is untouched — except in two
  /// pathological cases: the writer overwrote the packet during several
  /// consecutive copy attempts and no borrow token was free to pin it (then
  /// a blocking read keeps trying until its timeout and a non-blocking read
  /// returns no_data with the buffer possibly overwritten), or a read without
  /// deadline followed a streamed write whose publisher then died mid-packet
  /// (publisher_gone) or was unblocked meanwhile (unblocked).
  ReadStatus read(void* buffer, std::size_t capacity, SampleInfo& info, std::chrono::nanoseconds timeout = kNoWait,
                  ReadMode mode = ReadMode::next);
  ReadStatus read(void* buffer, std::size_t capacity, SampleInfo& info, WaitDeadline& deadline,
                  ReadMode mode = ReadMode::next);

  /// Pins the next packet in place (same selection rules as read()).
  /// Releases whatever `sample` held before.
  ReadStatus borrow(BorrowedSample& sample, std::chrono::nanoseconds timeout = kNoWait, ReadMode mode = ReadMode::next);
  ReadStatus borrow(BorrowedSample& sample, WaitDeadline& deadline, ReadMode mode = ReadMode::next);

  /// True if a read would deliver a packet now.
  bool has_new_data() const noexcept;
  /// Makes a blocked read/borrow in another thread return `unblocked`; if none
  /// is blocked, the next one that would block returns `unblocked` at once.
  void unblock() noexcept;
  /// False once the publisher closed the segment or its process died.
  bool publisher_alive() const noexcept;
  /// Sequence number of the last packet delivered (for resume_after), or the
  /// starting point before the first delivery.
  std::uint64_t last_sequence() const noexcept;

  std::uint32_t message_size() const noexcept;
  std::uint32_t history() const noexcept;
  ReaderStats stats() const noexcept;

  /// For a thread that sleeps on several segments at once (see ShmWakeWatch):
  /// counts it in the segment's sleeping readers and notes the wake word.
  /// Any thread, also during a read (like unblock()); the watch may outlive
  /// the reader.
  ShmWakeWatch watch_wake_word() const noexcept;

 private:
  explicit ShmReader(std::shared_ptr<detail::ReaderCore> core) noexcept;
  std::shared_ptr<detail::ReaderCore> core_;
};

/// Sleeping on the wake words of several segments at once (ln's multi-waiter
/// uses futex_waitv), with the protocol of a blocking read split in two:
///   1. watch = reader.watch_wake_word(): counts the caller in the segment's
///      `sleeping_readers` (seq_cst), then loads `wake_word` (seq_cst) into
///      expected();
///   2. check the wake condition (e.g. reader.has_new_data()) and sleep only
///      if it is false, on word() while it still holds expected();
///   3. destroy the watch (or withdraw()): uncounts the caller.
/// A write (or close, unblock) after step 1 changes the word and, as the
/// writer then sees sleeping_readers != 0, calls FUTEX_WAKE; one before it is
/// seen by step 2. So no packet is missed. Futex operations on word() must not
/// use FUTEX_PRIVATE_FLAG (the word is in shared memory). The watch keeps the
/// mapping alive, so it may outlive its ShmReader. Move-only.
class ShmWakeWatch {
 public:
  ShmWakeWatch() = default;
  ShmWakeWatch(ShmWakeWatch&& other) noexcept = default;
  ShmWakeWatch& operator=(ShmWakeWatch&& other) noexcept;
  ShmWakeWatch(const ShmWakeWatch&) = delete;
  ShmWakeWatch& operator=(const ShmWakeWatch&) = delete;
  ~ShmWakeWatch() { withdraw(); }

  bool active() const noexcept { return core_ != nullptr; }
  /// The segment's futex word (nullptr if not active).
  const std::atomic<std::uint32_t>* word() const noexcept;
  /// The word's value right after the caller was counted.
  std::uint32_t expected() const noexcept { return expected_; }
  /// Uncounts the caller; idempotent.
  void withdraw() noexcept;

 private:
  friend class ShmReader;
  explicit ShmWakeWatch(std::shared_ptr<detail::ReaderCore> core) noexcept;
  std::shared_ptr<detail::ReaderCore> core_;
  std::uint32_t expected_ = 0;
};

}  // namespace ln::transport
