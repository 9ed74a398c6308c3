#pragma once

// Named shared-memory segments in LN 2.9's own byte layout: what ln.h's
// low-level API (create_shm_target, read_from_shm_source, ...) works on.
// Topics do not use this (they use the sealed memfd ring of shm_ring.hpp);
// it exists for programs and tools that share a segment by name.
//
// A segment is the POSIX shared-memory object "/<name>" (/dev/shm/<name>).
// Either side may create it; the other opens it by name. Layout (host byte
// order), as LN 2.9 writes it:
//
//   0    "LN_SHM\0", version byte (0..3)
//   8    u32 element_size, u32 n_elements
//   16   88 bytes LN 2.9 uses for a process-shared mutex and condition
//        variable in versions 0..2 (zero and unused here)
//   104  u32 next write index, u32 "ring full" flag
//   112  u32 packet counter: the newest packet's number (0 = none yet); also
//        the futex word readers sleep on
//   120  n_elements slots of `stride` bytes: u32 packet number, 4 bytes
//        padding, double timestamp, the payload; version 3 adds a u32 copy of
//        the packet number in the last 4 bytes. stride is rounded up to 8.
//
// Protocol. The writer fills the slot at the write index: it marks the slot
// as being written (leading number 0), copies timestamp and payload, stores
// the new number (version 3: first the trailing copy, then the leading one),
// advances the index and the counter and wakes all sleepers with FUTEX_WAKE
// on the counter. A reader takes the slot before the write index; its copy
// is valid if the slot's numbers read before the copy equal those read after
// it (leading and, in version 3, trailing) and are not 0, else it retries.
// That also detects LN 2.9's own writers mid-write, which number a slot before
// and after its payload; in version 3, segments are shared with LN 2.9
// processes in both directions (tests/ln29_behaviour/test_ln29b_shm.py).
// LN 2.9 processes lock the mutex for versions 0..2 instead, so those
// segments are only for processes of this library.
//
// Reads deliver the packets in order, each once: packet k lives in slot
// (k - 1) % n_elements until the writer laps it, so a reader may fall up to
// n_elements - 1 packets behind without losing one; one that fell further
// behind continues with the oldest packet still in the ring. A reader sees
// only packets written after it opened the segment. One writer at a time.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

#include "transport/shm_segment.hpp"

namespace ln::transport::ln29 {

inline constexpr std::uint32_t kNewestVersion = 3;
inline constexpr std::size_t kHeaderSize = 120;

enum class ReadResult {
  packet,       ///< a packet was copied
  nothing_new,  ///< non-blocking: no packet newer than the last one seen
  timeout,      ///< no newer packet before the timeout
  unblocked,    ///< unblock() was called
  torn,         ///< the writer kept rewriting the slot (only read_last)
};

/// One end of a named segment. Not copyable; unmaps on destruction.
class Segment {
 public:
  /// Creates "/<name>" (replacing any segment of that name: users of the old
  /// one keep it, detached) and formats it. Throws ShmError: invalid_config
  /// (n_elements 0, sizes too large), bad_version (version > 3),
  /// system_error (name: EINVAL for "" or one with '/', ENAMETOOLONG).
  static Segment create(const std::string& name, std::uint32_t element_size, std::uint32_t n_elements,
                        std::uint32_t version);
  /// Opens an existing segment and checks its header. Throws ShmError:
  /// system_error (ENOENT ...), too_small (smaller than its header says),
  /// bad_magic, bad_version.
  static Segment open(const std::string& name);

  Segment(Segment&&) noexcept;
  Segment& operator=(Segment&&) = delete;
  Segment(const Segment&) = delete;
  Segment& operator=(const Segment&) = delete;
  ~Segment();

  std::uint32_t element_size() const noexcept { return element_size_; }
  std::uint32_t n_elements() const noexcept { return n_elements_; }
  std::uint32_t version() const noexcept { return version_; }
  /// Removes the name (the mapping stays valid). Returns errno or 0.
  int unlink() noexcept;

  // ------------------------------------------------------------ writer side
  /// Writes a packet of `size` <= element_size() bytes (the rest of the slot
  /// keeps what it held). `data` nullptr: the payload is already in
  /// next_buffer(). Returns false if size > element_size().
  bool write(double timestamp, const void* data, std::size_t size) noexcept;
  /// The payload of the slot the next write() fills, marked as being
  /// written until then (zero-copy writing).
  void* next_buffer() noexcept;

  // ------------------------------------------------------------ reader side
  /// The packet after the last one this object delivered (or, after it
  /// fell behind by n_elements() or more, the oldest one still in the ring):
  /// copies min(capacity, element_size()) bytes. timeout: 0 (do not wait),
  /// negative (no limit) or a duration.
  ReadResult read_next(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter,
                       std::chrono::nanoseconds timeout) noexcept;
  /// The newest packet, delivered or not (zeros, timestamp 0 and counter 0
  /// before the first one); reads continue after it. Returns packet, or torn
  /// if the writer kept rewriting it.
  ReadResult read_last(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter) noexcept;
  /// Waits until the segment's counter differs from `counter`, then sets
  /// `counter` (and the last packet seen) to it. Returns packet, timeout or
  /// unblocked.
  ReadResult wait_for_packet(std::uint32_t& counter, std::chrono::nanoseconds timeout) noexcept;
  /// The newest packet's number (0: none yet).
  std::uint32_t newest_counter() const noexcept;
  /// Makes a waiting read (any thread) return unblocked; if none waits, the
  /// next one that would wait does.
  void unblock() noexcept;

 private:
  struct Header;
  Segment(std::string name, UniqueFd fd, Mapping mapping) noexcept;
  Header& header() const noexcept;
  std::byte* slot(std::uint32_t index) const noexcept;
  std::atomic<std::uint32_t>& leading_number(std::byte* slot) const noexcept;
  std::atomic<std::uint32_t>& trailing_number(std::byte* slot) const noexcept;
  enum class Copy { ok, torn, other_packet };
  // Copies slot `index` if it holds packet `expected` (0: any packet).
  Copy copy_slot(std::uint32_t index, std::uint32_t expected, void* data, std::size_t capacity,
                 double& timestamp) noexcept;
  bool copy_next(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter) noexcept;
  bool wait(std::uint32_t seen, std::chrono::steady_clock::time_point deadline, bool forever, ReadResult& why) noexcept;

  std::string name_;
  UniqueFd fd_;
  Mapping mapping_;
  // Copied from the header once and validated: never re-read from shared memory.
  std::uint32_t element_size_ = 0;
  std::uint32_t n_elements_ = 0;
  std::uint32_t version_ = 0;
  std::uint64_t stride_ = 0;
  std::uint32_t last_seen_ = 0;      // reader: number of the last packet delivered
  std::uint32_t copied_number_ = 0;  // the packet copy_slot() copied last
  std::atomic<bool> unblocked_{false};
};

}  // namespace ln::transport::ln29
