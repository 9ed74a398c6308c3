#pragma once

// Byte layout of a shared-memory ring segment (internal to ln_transport).
// Everything a reader trusts for addressing (sizes, counts, offsets) is copied
// out of the segment once, validated, and never re-read from shared memory, so
// a corrupted or hostile segment cannot steer a reader outside its mapping.
//
//   offset 0               SegmentHeader (immutable info, publisher line, stream line)
//   ring_offset            std::atomic<uint32_t> ring[history]   slot index per ring position
//   slots_offset           slot_count × slot_stride bytes, each slot:
//                              SlotHeader (32 bytes) then payload (message_size bytes)
//   shared_offset          ReaderArea (futex word, sleepers, tickets, token table), then
//   (page aligned)         std::atomic<uint64_t> borrow_state[slot_count] at kBorrowStatesOffset
//
// Everything before shared_offset is written by the publisher only; readers
// map it read-only (where the page size allows, see shm_ring.cpp), so a
// subscriber's stray write cannot destroy packets, the ring or the header.
// The reader area is all that readers write: who sleeps, who borrows what.

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace ln::transport::layout {

inline constexpr char kMagic[8] = {'L', 'N', 'S', 'H', 'R', 'I', 'N', 'G'};
inline constexpr std::uint32_t kVersion = 3;
inline constexpr std::size_t kCacheLine = 64;
/// The reader area starts on a boundary of this many bytes, so that it can
/// be mapped separately (on systems with pages of this size or smaller).
inline constexpr std::size_t kReaderAreaAlignment = 4096;

/// Limits that keep every size computation far away from overflow.
inline constexpr std::uint32_t kMaxMessageSize = 1u << 30;
inline constexpr std::uint32_t kMaxHistory = 1u << 20;
inline constexpr std::uint32_t kMaxBorrowSlots = 63;  // one state bit each, bit 63 is "writing"

/// Slot borrow state (ReaderArea): bit 63 is set while the publisher writes
/// the slot, bit t (t < 63) while borrow token t pins it.
inline constexpr std::uint64_t kWritingBit = std::uint64_t{1} << 63;

/// Byte offsets used as OFD lock "alive" flags (see shm_segment.hpp): the
/// publisher locks byte 0, the reader with ticket k locks byte 1 + k.
inline constexpr std::uint64_t kPublisherLockByte = 0;
inline constexpr std::uint64_t kFirstReaderLockByte = 1;
inline constexpr std::uint64_t kMaxReaderTicket = std::uint64_t{1} << 62;

/// SegmentInfo::flags
inline constexpr std::uint32_t kPublisherHoldsLivenessLock = 1u << 0;

enum class SegmentState : std::uint32_t { open = 1, closed = 2, replaced = 3 };

/// Immutable description of the segment, written once before the memfd is
/// handed to anyone. A plain struct so that it can be checksummed and copied.
struct SegmentInfo {
  char magic[8];
  std::uint32_t version;
  std::uint32_t info_size;  // sizeof(SegmentInfo) of the creator
  std::uint64_t total_size;
  std::uint64_t ring_offset;
  std::uint64_t slots_offset;
  std::uint64_t slot_stride;
  std::uint64_t shared_offset;
  std::uint32_t message_size;
  std::uint32_t history;
  std::uint32_t borrow_slots;
  std::uint32_t slot_count;
  std::uint32_t flags;
  std::uint32_t checksum;  // FNV-1a over this struct with checksum = 0
};

/// The publisher's part of the segment header (readers only read it).
struct SegmentHeader {
  SegmentInfo info;

  // Written by the publisher on every packet; polled by spinning readers.
  alignas(kCacheLine) std::atomic<std::uint64_t> head_sequence;  // newest committed packet, 0 = none
  std::atomic<std::int32_t> publisher_cpu;  // CPU of the last write: readers on the same CPU yield instead of spinning
  std::atomic<std::uint32_t> state;         // SegmentState
  std::int32_t publisher_pid;               // informational only
  // Steady-clock nanoseconds of the last write that woke sleeping readers (0 = none yet):
  // a woken reader learns when its packet came, not when it got a CPU back.
  std::atomic<std::int64_t> last_wake_ns;

  // The large packet write() is copying right now, so that readers on other
  // CPUs can copy it out behind the writer instead of after it (see
  // "Streamed copies" in shm_ring.hpp). stream_target is 0 or
  // kStreamActive | (sequence & kStreamSequenceMask) << kStreamSlotBits | slot;
  // stream_bytes counts the payload bytes of that packet already in its slot.
  alignas(kCacheLine) std::atomic<std::uint64_t> stream_target;
  std::atomic<std::uint32_t> stream_bytes;
};

/// The part of the segment readers write, at SegmentInfo::shared_offset.
struct ReaderArea {
  // The futex word and the count of readers asleep on it, in one line: the
  // publisher bumps the word and then checks the count on every packet;
  // readers touch them only to sleep (and unblock() bumps the word).
  alignas(kCacheLine) std::atomic<std::uint32_t> wake_word;  // bumped by every write, close and unblock
  std::atomic<std::uint32_t> sleeping_readers;
  std::atomic<std::uint64_t> next_reader_ticket;  // unique, never reused reader identities

  // Borrow token t is free (0) or owned by the reader with that ticket.
  alignas(kCacheLine) std::atomic<std::uint64_t> token_owner[kMaxBorrowSlots];
};

/// Offset of borrow_state[0] within the reader area. Slot s's borrow state
/// is kWritingBit while the publisher writes the slot, bit t (t < 63) while
/// borrow token t pins it.
inline constexpr std::size_t kBorrowStatesOffset = (sizeof(ReaderArea) + kCacheLine - 1) / kCacheLine * kCacheLine;

inline constexpr std::uint64_t kStreamActive = std::uint64_t{1} << 63;
inline constexpr unsigned kStreamSlotBits = 21;  // slot_count <= kMaxHistory + kMaxBorrowSlots + 1 < 2^21
inline constexpr std::uint64_t kStreamSlotMask = (std::uint64_t{1} << kStreamSlotBits) - 1;
inline constexpr std::uint64_t kStreamSequenceMask = (std::uint64_t{1} << (63 - kStreamSlotBits)) - 1;
static_assert(std::uint64_t{kMaxHistory} + kMaxBorrowSlots + 1 <= kStreamSlotMask,
              "every slot index must fit into a stream target");

inline constexpr std::uint64_t stream_target(std::uint64_t sequence, std::uint32_t slot) noexcept {
  return kStreamActive | (sequence & kStreamSequenceMask) << kStreamSlotBits | slot;
}

/// Futex wake masks on SegmentHeader::wake_word: every reader waits for
/// commits; only readers that may copy behind the writer wait for stream starts.
inline constexpr std::uint32_t kWakeOnCommit = 1u << 0;
inline constexpr std::uint32_t kWakeOnStreamStart = 1u << 1;

struct SlotHeader {
  std::atomic<std::uint64_t> sequence;  // packet in this slot; 0 while it is being (re)written
  std::atomic<double> timestamp;
  std::atomic<std::uint32_t> size;
  std::uint32_t reserved[3];
};

inline constexpr std::size_t kPayloadOffset = 32;
inline constexpr std::size_t kPayloadAlignment = 32;

static_assert(sizeof(SlotHeader) == kPayloadOffset, "payload follows the slot header directly");
static_assert(std::atomic<std::uint64_t>::is_always_lock_free && std::atomic<std::uint32_t>::is_always_lock_free &&
                  std::atomic<std::int32_t>::is_always_lock_free && std::atomic<double>::is_always_lock_free,
              "atomics in shared memory must be lock-free to work across processes");
static_assert(sizeof(std::atomic<std::uint32_t>) == 4 && sizeof(std::atomic<std::uint64_t>) == 8,
              "atomics must have the size of the plain integers");

/// Everything derived from the three creation parameters.
struct Geometry {
  std::uint32_t message_size = 0;
  std::uint32_t history = 0;
  std::uint32_t borrow_slots = 0;
  std::uint32_t slot_count = 0;
  std::uint64_t slot_stride = 0;
  std::uint64_t ring_offset = 0;
  std::uint64_t slots_offset = 0;
  std::uint64_t shared_offset = 0;
  std::uint64_t total_size = 0;
};

/// Throws ShmError(invalid_config) when a parameter is out of range.
Geometry compute_geometry(std::uint32_t message_size, std::uint32_t history, std::uint32_t borrow_slots);

std::uint32_t checksum(const SegmentInfo& info);

}  // namespace ln::transport::layout
