#include "transport/shm_ring.hpp"

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "transport/shm_layout.hpp"

namespace ln::transport {

using Clock = std::chrono::steady_clock;
using TimePoint = Clock::time_point;
using std::chrono::nanoseconds;

namespace layout {

namespace {
constexpr std::uint64_t round_up(std::uint64_t value, std::uint64_t alignment) {
  return (value + alignment - 1) / alignment * alignment;
}
constexpr std::uint64_t kMaxTotalSize = std::uint64_t{1} << 40;
}  // namespace

Geometry compute_geometry(std::uint32_t message_size, std::uint32_t history, std::uint32_t borrow_slots) {
  if (message_size == 0 || message_size > kMaxMessageSize) {
    throw ShmError(ShmErrc::invalid_config, "message_size must be between 1 and " + std::to_string(kMaxMessageSize));
  }
  if (history == 0 || history > kMaxHistory) {
    throw ShmError(ShmErrc::invalid_config, "history must be between 1 and " + std::to_string(kMaxHistory));
  }
  if (borrow_slots > kMaxBorrowSlots) {
    throw ShmError(ShmErrc::invalid_config, "borrow_slots must be at most " + std::to_string(kMaxBorrowSlots));
  }
  Geometry geometry;
  geometry.message_size = message_size;
  geometry.history = history;
  geometry.borrow_slots = borrow_slots;
  geometry.slot_count = history + borrow_slots + 1;
  geometry.slot_stride = round_up(kPayloadOffset + std::uint64_t{message_size}, kCacheLine);
  geometry.ring_offset = round_up(sizeof(SegmentHeader), kCacheLine);
  geometry.slots_offset =
      geometry.ring_offset + round_up(std::uint64_t{history} * sizeof(std::atomic<std::uint32_t>), kCacheLine);
  geometry.shared_offset =
      round_up(geometry.slots_offset + std::uint64_t{geometry.slot_count} * geometry.slot_stride, kReaderAreaAlignment);
  geometry.total_size = geometry.shared_offset + kBorrowStatesOffset +
                        std::uint64_t{geometry.slot_count} * sizeof(std::atomic<std::uint64_t>);
  if (geometry.total_size > kMaxTotalSize) {
    throw ShmError(ShmErrc::invalid_config, "segment would be larger than 1 TiB");
  }
  return geometry;
}

std::uint32_t checksum(const SegmentInfo& info) {
  SegmentInfo copy = info;
  copy.checksum = 0;
  const auto* bytes = reinterpret_cast<const unsigned char*>(&copy);
  std::uint32_t hash = 2166136261u;  // FNV-1a
  for (std::size_t i = 0; i < sizeof(copy); ++i) {
    hash ^= bytes[i];
    hash *= 16777619u;
  }
  return hash;
}

}  // namespace layout

namespace {

using layout::ReaderArea;
using layout::SegmentHeader;
using layout::SegmentState;
using layout::SlotHeader;

inline void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

std::size_t page_size() noexcept {
  static const long size = ::sysconf(_SC_PAGESIZE);
  return size > 0 ? static_cast<std::size_t>(size) : layout::kReaderAreaAlignment;
}

double wall_clock_seconds() noexcept {
  const auto since_epoch = std::chrono::system_clock::now().time_since_epoch();
  return std::chrono::duration<double>(since_epoch).count();
}

// Addresses of the parts of a mapped segment, computed from a validated
// geometry: `base` maps the publisher's part (read-only for readers),
// `shared` the reader area at geometry.shared_offset.
struct SegmentView {
  layout::Geometry geometry;
  SegmentHeader* header = nullptr;
  std::atomic<std::uint32_t>* ring = nullptr;
  std::byte* slots = nullptr;
  ReaderArea* readers = nullptr;
  std::atomic<std::uint64_t>* borrow_states = nullptr;

  SegmentView() = default;
  SegmentView(std::byte* base, std::byte* shared, const layout::Geometry& g)
      : geometry(g),
        header(reinterpret_cast<SegmentHeader*>(base)),
        ring(reinterpret_cast<std::atomic<std::uint32_t>*>(base + g.ring_offset)),
        slots(base + g.slots_offset),
        readers(reinterpret_cast<ReaderArea*>(shared)),
        borrow_states(reinterpret_cast<std::atomic<std::uint64_t>*>(shared + layout::kBorrowStatesOffset)) {}

  SlotHeader& slot(std::uint32_t index) const noexcept {
    return *reinterpret_cast<SlotHeader*>(slots + std::uint64_t{index} * geometry.slot_stride);
  }
  std::byte* payload(std::uint32_t index) const noexcept {
    return slots + std::uint64_t{index} * geometry.slot_stride + layout::kPayloadOffset;
  }
  std::atomic<std::uint64_t>& borrow_state(std::uint32_t index) const noexcept { return borrow_states[index]; }
};

ReadStatus status_for_state(std::uint32_t state) noexcept {
  return state == static_cast<std::uint32_t>(SegmentState::replaced) ? ReadStatus::segment_replaced
                                                                     : ReadStatus::publisher_gone;
}

constexpr std::uint32_t kOpen = static_cast<std::uint32_t>(SegmentState::open);

// A non-blocking read attempt gives up after this many times finding its
// packet overwritten; the blocking loop then yields and tries again.
constexpr int kMaxAttempts = 64;
// write() copies packets of at least kStreamMinSize bytes in chunks of
// kStreamChunk, announcing its progress (see "Streamed copies"). Below 64 KiB
// a copy takes about as long as a reader needs to notice a stream; from 64 KiB
// up, round trips across cores measured equal or faster with streaming on the
// 2-vCPU VM (shm_ring_bench rtt, medians: 64 KiB 19 vs 21 us, 160 KiB 35 vs
// 49-109 us, 384 KiB 58-83 vs 222-231 us, 1 MiB 186 vs 507 us).
constexpr std::size_t kStreamMinSize = 64 * 1024;
constexpr std::size_t kStreamChunk = 16 * 1024;
// How long a reader sleeps instead of yielding after the publisher hogged its
// CPU: doubling from min to max while it keeps happening.
constexpr nanoseconds kMinYieldBackoff = std::chrono::milliseconds(1);
constexpr nanoseconds kMaxYieldBackoff = std::chrono::milliseconds(100);

}  // namespace

std::uint64_t topic_segment_size(std::uint32_t message_size, std::uint32_t history) noexcept {
  try {
    return layout::compute_geometry(std::max<std::uint32_t>(message_size, 1), history, kTopicBorrowSlots).total_size;
  } catch (const ShmError&) {
    return 0;
  }
}

const char* to_string(WriteStatus status) {
  switch (status) {
    case WriteStatus::ok:
      return "ok";
    case WriteStatus::packet_too_large:
      return "packet too large";
    case WriteStatus::loan_outstanding:
      return "a loan is outstanding";
    case WriteStatus::no_loan:
      return "no loan to commit";
    case WriteStatus::no_free_slot:
      return "no free slot (corrupted segment)";
    case WriteStatus::closed:
      return "segment closed";
    case WriteStatus::bad_sequence:
      return "sequence number not above the last one";
  }
  return "unknown";
}

const char* to_string(ReadStatus status) {
  switch (status) {
    case ReadStatus::ok:
      return "ok";
    case ReadStatus::no_data:
      return "no new packet";
    case ReadStatus::timeout:
      return "timeout";
    case ReadStatus::unblocked:
      return "unblocked";
    case ReadStatus::publisher_gone:
      return "publisher gone";
    case ReadStatus::segment_replaced:
      return "segment replaced";
    case ReadStatus::buffer_too_small:
      return "buffer too small";
    case ReadStatus::borrow_limit:
      return "borrow limit reached";
    case ReadStatus::corrupt_segment:
      return "corrupt segment";
  }
  return "unknown";
}

// ============================================================== writer

namespace detail {

struct WriterCore {
  UniqueFd fd;
  Mapping mapping;
  SegmentView view;
  // The writer's own bookkeeping lives in private memory, so nothing a reader
  // (or a corruption) does to the segment can confuse it.
  std::vector<std::uint32_t> ring_slots;  // mirror of view.ring
  std::vector<std::uint32_t> spares;      // slots not in the ring
  std::size_t next_spare = 0;
  std::size_t loan_spare = 0;
  bool loan_open = false;
  bool streaming = false;  // the loan is being filled by stream_into_loan
  bool closed = false;
  std::uint64_t last_sequence = 0;
  std::uint64_t created_before = 0;  // last_sequence at creation: nothing written while they agree

  bool borrowing_possible() const noexcept { return view.geometry.borrow_slots != 0; }

  // Claims a spare slot that no reader has pinned and marks it "being written".
  bool claim_spare() noexcept {
    const std::size_t count = spares.size();
    for (std::size_t i = 0; i < count; ++i) {
      std::size_t candidate = next_spare + i;
      if (candidate >= count) candidate -= count;
      SlotHeader& slot = view.slot(spares[candidate]);
      if (borrowing_possible()) {
        std::uint64_t expected = 0;
        if (!view.borrow_state(spares[candidate])
                 .compare_exchange_strong(expected, layout::kWritingBit, std::memory_order_acquire,
                                          std::memory_order_relaxed)) {
          continue;  // pinned by a reader
        }
      }
      loan_spare = candidate;
      loan_open = true;
      slot.sequence.store(0, std::memory_order_relaxed);
      // Seqlock: the invalidated sequence must be visible before any payload byte changes.
      std::atomic_thread_fence(std::memory_order_release);
      return true;
    }
    return false;
  }

  void commit(std::uint32_t size, double timestamp) noexcept {
    const std::uint32_t index = spares[loan_spare];
    SlotHeader& slot = view.slot(index);
    const std::uint64_t sequence = last_sequence + 1;
    slot.timestamp.store(timestamp, std::memory_order_relaxed);
    slot.size.store(size, std::memory_order_relaxed);
    slot.sequence.store(sequence, std::memory_order_release);
    if (borrowing_possible()) view.borrow_state(index).store(0, std::memory_order_release);

    const std::size_t position = sequence % view.geometry.history;
    spares[loan_spare] = ring_slots[position];
    ring_slots[position] = index;
    view.ring[position].store(index, std::memory_order_release);
    // The evicted slot now sits at loan_spare: the next write reuses it, so
    // a stream cycles through two warm slots instead of all spares (for
    // large packets that is the difference between cache and memory).
    next_spare = loan_spare;
    loan_open = false;
    last_sequence = sequence;

    SegmentHeader& header = *view.header;
    header.publisher_cpu.store(sched_getcpu(), std::memory_order_relaxed);
    header.head_sequence.store(sequence, std::memory_order_release);
    if (streaming) {
      // After the head: a follower that sees the stream end sees the commit.
      header.stream_target.store(0, std::memory_order_release);
      streaming = false;
    }
    wake_sleepers(false, kFutexAnyEvent);
  }

  // write() of a large packet into the claimed spare: announce it, wake the
  // readers that copy behind the writer, and copy in chunks, publishing how
  // far the copy got after each one.
  void stream_into_loan(const void* data, std::uint32_t size) noexcept {
    const std::uint32_t index = spares[loan_spare];
    SegmentHeader& header = *view.header;
    view.slot(index).size.store(size, std::memory_order_relaxed);
    // Release: a follower that reads this reset knows the previous stream ended.
    header.stream_bytes.store(0, std::memory_order_release);
    header.publisher_cpu.store(sched_getcpu(), std::memory_order_relaxed);
    header.stream_target.store(layout::stream_target(last_sequence + 1, index), std::memory_order_release);
    streaming = true;
    wake_sleepers(false, layout::kWakeOnStreamStart);
    const auto* source = static_cast<const std::byte*>(data);
    std::byte* target = view.payload(index);
    for (std::uint32_t done = 0; done < size;) {
      const std::uint32_t chunk = static_cast<std::uint32_t>(std::min<std::size_t>(kStreamChunk, size - done));
      std::memcpy(target + done, source + done, chunk);
      done += chunk;
      header.stream_bytes.store(done, std::memory_order_release);
    }
  }

  void discard_loan() noexcept {
    if (!loan_open) return;
    // The slot keeps sequence 0, so no reader will ever take its contents.
    if (borrowing_possible()) {
      view.borrow_state(spares[loan_spare]).store(0, std::memory_order_release);
    }
    loan_open = false;
  }

  // The seq_cst increment orders the head store before the sleeper check;
  // readers increment sleeping_readers before loading wake_word, so either we
  // see their count or they see the new head / a changed futex word.
  void wake_sleepers(bool always, std::uint32_t wake_mask) noexcept {
    ReaderArea& readers = *view.readers;
    readers.wake_word.fetch_add(1, std::memory_order_seq_cst);
    if (always || readers.sleeping_readers.load(std::memory_order_seq_cst) != 0) {
      view.header->last_wake_ns.store(Clock::now().time_since_epoch().count(), std::memory_order_relaxed);
      futex_wake_all(&readers.wake_word, wake_mask);
    }
  }

  void close(SegmentState state) noexcept {
    if (closed) return;
    discard_loan();
    closed = true;
    view.header->state.store(static_cast<std::uint32_t>(state), std::memory_order_release);
    wake_sleepers(true, kFutexAnyEvent);
  }

  ~WriterCore() {
    if (view.header != nullptr) close(SegmentState::closed);
    // Closing fd drops the liveness lock; the mapping goes after it.
  }
};

}  // namespace detail

ShmWriter ShmWriter::create(const RingConfig& config) {
  if (config.first_sequence == 0 || config.first_sequence > (std::uint64_t{1} << 62)) {
    throw ShmError(ShmErrc::invalid_config, "first_sequence must be between 1 and 2^62");
  }
  const layout::Geometry geometry = layout::compute_geometry(config.message_size, config.history, config.borrow_slots);

  auto core = std::make_unique<detail::WriterCore>();
  UniqueFd fd = create_sealed_memfd(config.debug_name, geometry.total_size);
  Mapping mapping = Mapping::map_shared(fd.get(), geometry.total_size);
  std::byte* base = mapping.data();

  // The memfd is zero-filled; construct the shared objects in place.
  auto* header = new (base) SegmentHeader();
  for (std::uint32_t i = 0; i < geometry.history; ++i) {
    new (base + geometry.ring_offset + i * sizeof(std::atomic<std::uint32_t>))
        std::atomic<std::uint32_t>(i);  // ring position i starts out naming slot i (holding nothing)
  }
  for (std::uint32_t i = 0; i < geometry.slot_count; ++i) {
    new (base + geometry.slots_offset + i * geometry.slot_stride) SlotHeader();
  }
  std::byte* shared = base + geometry.shared_offset;
  new (shared) ReaderArea();
  for (std::uint32_t i = 0; i < geometry.slot_count; ++i) {
    new (shared + layout::kBorrowStatesOffset + i * sizeof(std::atomic<std::uint64_t>)) std::atomic<std::uint64_t>(0);
  }
  header->head_sequence.store(config.first_sequence - 1, std::memory_order_relaxed);
  header->publisher_cpu.store(-1, std::memory_order_relaxed);
  header->state.store(kOpen, std::memory_order_relaxed);
  header->publisher_pid = static_cast<std::int32_t>(::getpid());

  layout::SegmentInfo& info = header->info;
  std::memcpy(info.magic, layout::kMagic, sizeof(info.magic));
  info.version = layout::kVersion;
  info.info_size = sizeof(layout::SegmentInfo);
  info.total_size = geometry.total_size;
  info.ring_offset = geometry.ring_offset;
  info.slots_offset = geometry.slots_offset;
  info.slot_stride = geometry.slot_stride;
  info.shared_offset = geometry.shared_offset;
  info.message_size = geometry.message_size;
  info.history = geometry.history;
  info.borrow_slots = geometry.borrow_slots;
  info.slot_count = geometry.slot_count;
  info.flags = 0;
  if (try_lock_byte(fd.get(), layout::kPublisherLockByte)) {
    info.flags |= layout::kPublisherHoldsLivenessLock;
  }
  info.checksum = layout::checksum(info);

  core->fd = std::move(fd);
  core->mapping = std::move(mapping);
  core->view = SegmentView(base, shared, geometry);
  core->ring_slots.resize(geometry.history);
  for (std::uint32_t i = 0; i < geometry.history; ++i) core->ring_slots[i] = i;
  for (std::uint32_t i = geometry.history; i < geometry.slot_count; ++i) core->spares.push_back(i);
  core->last_sequence = core->created_before = config.first_sequence - 1;
  return ShmWriter(std::move(core));
}

ShmWriter::ShmWriter(std::unique_ptr<detail::WriterCore> core) noexcept : core_(std::move(core)) {}
ShmWriter::ShmWriter(ShmWriter&&) noexcept = default;
ShmWriter& ShmWriter::operator=(ShmWriter&&) noexcept = default;
ShmWriter::~ShmWriter() = default;

int ShmWriter::fd() const noexcept { return core_->fd.get(); }
std::uint32_t ShmWriter::message_size() const noexcept { return core_->view.geometry.message_size; }
std::uint32_t ShmWriter::history() const noexcept { return core_->view.geometry.history; }
std::uint32_t ShmWriter::borrow_slots() const noexcept { return core_->view.geometry.borrow_slots; }

WriteStatus ShmWriter::write(const void* data, std::size_t size, double timestamp) noexcept {
  detail::WriterCore& core = *core_;
  if (core.closed) return WriteStatus::closed;
  if (core.loan_open) return WriteStatus::loan_outstanding;
  if (size > core.view.geometry.message_size) return WriteStatus::packet_too_large;
  if (!core.claim_spare()) return WriteStatus::no_free_slot;
  if (size >= kStreamMinSize) {
    core.stream_into_loan(data, static_cast<std::uint32_t>(size));
  } else if (size != 0) {
    std::memcpy(core.view.payload(core.spares[core.loan_spare]), data, size);
  }
  core.commit(static_cast<std::uint32_t>(size), timestamp);
  return WriteStatus::ok;
}

WriteStatus ShmWriter::write(const void* data, std::size_t size) noexcept {
  return write(data, size, wall_clock_seconds());
}

WriteStatus ShmWriter::write_as(std::uint64_t sequence, const void* data, std::size_t size, double timestamp) noexcept {
  detail::WriterCore& core = *core_;
  if (sequence <= core.last_sequence || sequence > (std::uint64_t{1} << 62)) return WriteStatus::bad_sequence;
  // commit() numbers the packet last_sequence + 1. The ring positions of the
  // numbers jumped over keep older packets, which readers recognise as
  // skipped (ReaderCore::locate).
  const std::uint64_t last = core.last_sequence;
  core.last_sequence = sequence - 1;
  const WriteStatus status = write(data, size, timestamp);
  if (status != WriteStatus::ok) core.last_sequence = last;
  return status;
}

void* ShmWriter::loan() noexcept {
  detail::WriterCore& core = *core_;
  if (core.closed || core.loan_open || !core.claim_spare()) return nullptr;
  return core.view.payload(core.spares[core.loan_spare]);
}

WriteStatus ShmWriter::commit(std::size_t size, double timestamp) noexcept {
  detail::WriterCore& core = *core_;
  if (!core.loan_open) return core.closed ? WriteStatus::closed : WriteStatus::no_loan;
  if (size > core.view.geometry.message_size) return WriteStatus::packet_too_large;
  core.commit(static_cast<std::uint32_t>(size), timestamp);
  return WriteStatus::ok;
}

WriteStatus ShmWriter::commit(std::size_t size) noexcept { return commit(size, wall_clock_seconds()); }

void ShmWriter::discard_loan() noexcept { core_->discard_loan(); }

bool ShmWriter::renumber(std::uint64_t first_sequence) noexcept {
  detail::WriterCore& core = *core_;
  if (core.closed || core.loan_open || core.last_sequence != core.created_before || first_sequence == 0 ||
      first_sequence > (std::uint64_t{1} << 62))
    return false;
  core.last_sequence = core.created_before = first_sequence - 1;
  core.view.header->head_sequence.store(first_sequence - 1, std::memory_order_release);
  return true;
}
std::uint64_t ShmWriter::last_sequence() const noexcept { return core_->last_sequence; }
std::uint64_t ShmWriter::published_sequence() const noexcept {
  return core_->view.header->head_sequence.load(std::memory_order_relaxed);
}

bool ShmWriter::shared_state_intact() const noexcept {
  const detail::WriterCore& core = *core_;
  const SegmentHeader& header = *core.view.header;
  const layout::Geometry& g = core.view.geometry;
  const layout::SegmentInfo& info = header.info;
  if (layout::checksum(info) != info.checksum || info.total_size != g.total_size || info.ring_offset != g.ring_offset ||
      info.slots_offset != g.slots_offset || info.slot_stride != g.slot_stride ||
      info.shared_offset != g.shared_offset || info.message_size != g.message_size || info.history != g.history ||
      info.slot_count != g.slot_count || info.borrow_slots != g.borrow_slots)
    return false;
  const std::uint32_t expected_state =
      static_cast<std::uint32_t>(core.closed ? SegmentState::closed : SegmentState::open);
  if (!core.closed && header.state.load(std::memory_order_relaxed) != expected_state) return false;
  if (!core.loan_open && header.head_sequence.load(std::memory_order_relaxed) != core.last_sequence) return false;
  for (std::uint32_t i = 0; i < g.history; ++i)
    if (core.view.ring[i].load(std::memory_order_relaxed) != core.ring_slots[i]) return false;
  return true;
}

std::uint32_t ShmWriter::sleeping_readers() const noexcept {
  return core_->view.readers->sleeping_readers.load(std::memory_order_acquire);
}

void ShmWriter::close() noexcept { core_->close(SegmentState::closed); }
void ShmWriter::close_replaced() noexcept { core_->close(SegmentState::replaced); }

// ============================================================== reader

namespace detail {

struct ReaderCore {
  // What one non-blocking attempt found.
  struct Attempt {
    enum Kind { finished, nothing_new, busy } kind;
    ReadStatus status;
  };
  static constexpr Attempt kNothingNew{Attempt::nothing_new, ReadStatus::no_data};
  static constexpr Attempt kBusy{Attempt::busy, ReadStatus::no_data};
  static Attempt finished(ReadStatus status) { return {Attempt::finished, status}; }

  // A packet found in the ring: its sequence number and the slot that held it.
  struct Location {
    std::uint64_t sequence;
    std::uint32_t slot;
  };
  enum class Locate { found, none, moved, corrupt };

  UniqueFd fd;
  bool own_description = false;  // false only without /proc: no liveness check, no borrowing
  Mapping mapping;               // the publisher's part (read-only), or everything
  Mapping shared_mapping;        // the reader area, when mapped on its own
  SegmentView view;
  std::uint32_t flags = 0;
  ReaderOptions options;
  std::uint32_t max_borrows = 0;
  std::uint64_t next_sequence = 1;  // the oldest sequence this reader may still deliver
  // Sequences below it were found missing from the ring (jumped over by
  // write_as, or overwritten already): not looked for again. Lost counts
  // still start at next_sequence.
  std::uint64_t skip_below = 0;
  nanoseconds spin_limit{0};
  TimePoint no_yield_until{};
  nanoseconds yield_backoff{kMinYieldBackoff};
  std::atomic<bool> unblock_requested{false};
  ReaderStats stats;
  // Streamed copies: set for blocking copying reads, the only ones that copy
  // behind the writer; a stream whose writer stalled is not followed again.
  bool follow_streams = false;
  std::uint64_t abandoned_stream = 0;

  // Borrowing; BorrowedSample::release may run on any thread.
  std::uint64_t ticket = 0;  // 0: no identity (no own description), so no borrowing
  std::mutex token_mutex;
  std::uint32_t tokens_in_use = 0;
  std::uint32_t token_scan_start = 0;

  SegmentHeader& header() const noexcept { return *view.header; }

  std::uint64_t choose_target(std::uint64_t head, ReadMode mode) const noexcept {
    if (head < next_sequence) return 0;  // sequence 0 is never used
    if (mode == ReadMode::newest) return head;
    const std::uint64_t unread = head - next_sequence + 1;
    if (unread <= options.buffers) return next_sequence;
    return options.on_lag == LagPolicy::skip_to_newest ? head : head - options.buffers + 1;
  }

  Locate locate(ReadMode mode, std::uint64_t& known_head, Location& where) noexcept {
    const std::uint64_t published = header().head_sequence.load(std::memory_order_acquire);
    known_head = std::max(known_head, published);
    std::uint64_t target = choose_target(known_head, mode);
    if (target == 0) return Locate::none;
    if (target < skip_below) {
      if (skip_below > known_head) return Locate::none;
      target = skip_below;
    }
    const std::uint32_t index = view.ring[target % view.geometry.history].load(std::memory_order_acquire);
    if (index >= view.geometry.slot_count) return Locate::corrupt;
    const std::uint64_t found = view.slot(index).sequence.load(std::memory_order_acquire);
    if (found != target) {
      // The writer moved on since we read the head. A newer sequence in the
      // slot proves that everything up to it is committed: skip ahead without
      // waiting for the writer's head store.
      if (found > target) known_head = std::max(known_head, found);
      // An older packet (or none) where one published by the head should
      // be: the writer jumped over `target` (write_as), or it was
      // overwritten and its slot is being rewritten (sequence 0). Either way
      // it is gone. (Above the published head, the ring position may just
      // not be updated yet.)
      else if (target <= published)
        skip_below = target + 1;
      return Locate::moved;
    }
    where = {target, index};
    return Locate::found;
  }

  void deliver(const Location& where, std::uint32_t size, double timestamp, SampleInfo& info) noexcept {
    info.sequence = where.sequence;
    info.lost = where.sequence - next_sequence;
    info.timestamp = timestamp;
    info.size = size;
    next_sequence = where.sequence + 1;
  }

  // ---- borrow tokens

  void clear_stale_pins(std::uint32_t token) noexcept {
    const std::uint64_t bit = std::uint64_t{1} << token;
    for (std::uint32_t i = 0; i < view.geometry.slot_count; ++i) {
      auto& state = view.borrow_state(i);
      if ((state.load(std::memory_order_relaxed) & bit) != 0) {
        state.fetch_and(~bit, std::memory_order_release);
      }
    }
  }

  bool reader_alive(std::uint64_t other_ticket) const noexcept {
    if (other_ticket == 0 || other_ticket >= layout::kMaxReaderTicket) return true;  // not a ticket: leave it alone
    return byte_locked_by_other(fd.get(), layout::kFirstReaderLockByte + other_ticket);
  }

  std::optional<std::uint32_t> acquire_token() noexcept {
    std::lock_guard<std::mutex> lock(token_mutex);
    if (ticket == 0 || tokens_in_use >= max_borrows) return std::nullopt;
    const std::uint32_t count = view.geometry.borrow_slots;
    auto* owners = view.readers->token_owner;
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t t = (token_scan_start + i) % count;
      std::uint64_t expected = 0;
      if (owners[t].load(std::memory_order_relaxed) == 0 &&
          owners[t].compare_exchange_strong(expected, ticket, std::memory_order_acq_rel)) {
        // A token is only ever returned after its pin was cleared: nothing stale.
        ++tokens_in_use;
        return t;
      }
    }
    // All taken. Tokens of readers that died are taken over; tickets are never
    // reused, so a successful CAS proves the owner we checked is the dead one.
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t t = (token_scan_start + i) % count;
      std::uint64_t owner = owners[t].load(std::memory_order_acquire);
      if (owner == ticket || reader_alive(owner)) continue;
      if (!owners[t].compare_exchange_strong(owner, ticket, std::memory_order_acq_rel)) continue;
      clear_stale_pins(t);
      ++tokens_in_use;
      return t;
    }
    return std::nullopt;
  }

  void release_token(std::uint32_t token) noexcept {
    std::lock_guard<std::mutex> lock(token_mutex);
    view.readers->token_owner[token].store(0, std::memory_order_release);
    --tokens_in_use;
  }

  // Sets the token's bit in the slot unless the writer is writing it, then
  // checks that the slot still holds the packet we want.
  bool pin(const Location& where, std::uint32_t token) noexcept {
    auto& state = view.borrow_state(where.slot);
    const std::uint64_t bit = std::uint64_t{1} << token;
    std::uint64_t current = state.load(std::memory_order_relaxed);
    do {
      if ((current & layout::kWritingBit) != 0) return false;
    } while (
        !state.compare_exchange_weak(current, current | bit, std::memory_order_acq_rel, std::memory_order_relaxed));
    if (view.slot(where.slot).sequence.load(std::memory_order_acquire) == where.sequence) return true;
    state.fetch_and(~bit, std::memory_order_release);
    return false;
  }

  void unpin(std::uint32_t slot, std::uint32_t token) noexcept {
    view.borrow_state(slot).fetch_and(~(std::uint64_t{1} << token), std::memory_order_release);
  }

  // ---- streamed copies

  // The packet this reader waits for once it has read everything published.
  std::uint64_t wanted_next() const noexcept { return std::max(next_sequence, skip_below); }

  // The stream target of our next packet if we may copy it behind the
  // writer now (0 if not): only blocking copying reads, only from another CPU
  // (on the writer's CPU we would just keep it from writing).
  std::uint64_t followable_stream() const noexcept {
    if (!follow_streams) return 0;
    const std::uint64_t target = header().stream_target.load(std::memory_order_acquire);
    if (target == 0 || target == abandoned_stream ||
        (target >> layout::kStreamSlotBits & layout::kStreamSequenceMask) !=
            (wanted_next() & layout::kStreamSequenceMask) ||
        (target & layout::kStreamSlotMask) >= view.geometry.slot_count || publisher_on_this_cpu()) {
      return 0;
    }
    return target;
  }

  // Copies our next packet while the writer is still copying it in, chunk by
  // chunk as it announces them, then checks after the commit that the slot
  // still holds that packet (the seqlock check of try_copy). kBusy: it did not
  // (retry); kNothingNew: no stream to follow, or the writer stalled for
  // max_spin (then this stream is left to the ordinary wait, and the buffer
  // may hold part of the packet).
  Attempt follow_stream(void* buffer, std::size_t capacity, SampleInfo& info) noexcept {
    const std::uint64_t target = followable_stream();
    if (target == 0) return kNothingNew;
    const Location where{wanted_next(), static_cast<std::uint32_t>(target & layout::kStreamSlotMask)};
    SlotHeader& slot = view.slot(where.slot);
    const std::uint32_t size = slot.size.load(std::memory_order_relaxed);
    if (size > view.geometry.message_size || size > capacity) {
      abandoned_stream = target;  // the ordinary read reports it once committed
      return kNothingNew;
    }
    auto* destination = static_cast<std::byte*>(buffer);
    const std::byte* source = view.payload(where.slot);
    SegmentHeader& shared = header();
    std::uint32_t copied = 0;
    TimePoint last_progress = Clock::now();
    for (;;) {
      // Progress before target: if the target is still ours, so was the progress.
      std::uint32_t ready = shared.stream_bytes.load(std::memory_order_acquire);
      const bool committed = shared.stream_target.load(std::memory_order_acquire) != target;
      if (committed || ready > size) ready = size;
      if (ready > copied) {
        std::memcpy(destination + copied, source + copied, ready - copied);
        copied = ready;
        if (committed) break;
        last_progress = Clock::now();
        continue;
      }
      if (committed) break;
      if (Clock::now() - last_progress > options.spin.max_spin) {
        abandoned_stream = target;
        ++stats.abandoned_streams;
        return kNothingNew;
      }
      cpu_relax();
    }
    const double timestamp = slot.timestamp.load(std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (slot.sequence.load(std::memory_order_relaxed) != where.sequence) {
      ++stats.torn_copies;
      return kBusy;
    }
    ++stats.streamed_copies;
    deliver(where, size, timestamp, info);
    return finished(ReadStatus::ok);
  }

  // ---- attempts

  Attempt try_copy(void* buffer, std::size_t capacity, SampleInfo& info, ReadMode mode) noexcept {
    std::uint64_t known_head = 0;
    std::optional<std::uint32_t> token;  // taken only after repeated torn copies
    struct TokenGuard {
      ReaderCore& core;
      std::optional<std::uint32_t>& token;
      ~TokenGuard() {
        if (token) core.release_token(*token);
      }
    } guard{*this, token};

    std::uint32_t torn = 0;
    bool asked_for_token = false;
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
      Location where{};
      switch (locate(mode, known_head, where)) {
        case Locate::none: {
          const Attempt streamed = follow_stream(buffer, capacity, info);
          if (streamed.kind != Attempt::busy) return streamed;
          continue;
        }
        case Locate::corrupt:
          return finished(ReadStatus::corrupt_segment);
        case Locate::moved:
          cpu_relax();
          continue;
        case Locate::found:
          break;
      }
      SlotHeader& slot = view.slot(where.slot);
      if (!asked_for_token && torn >= options.optimistic_copies) {
        asked_for_token = true;  // once per read: a busy token table stays busy for a while
        token = acquire_token();
      }
      const bool pinned = token && pin(where, *token);
      if (token && !pinned) continue;

      const std::uint32_t size = slot.size.load(std::memory_order_relaxed);
      const double timestamp = slot.timestamp.load(std::memory_order_relaxed);
      const bool fits = size <= view.geometry.message_size && size <= capacity;
      if (fits) std::memcpy(buffer, view.payload(where.slot), size);
      std::atomic_thread_fence(std::memory_order_acquire);
      const bool intact = slot.sequence.load(std::memory_order_relaxed) == where.sequence;
      if (pinned) unpin(where.slot, *token);
      if (!intact) {
        ++torn;
        ++stats.torn_copies;
        continue;
      }
      if (size > view.geometry.message_size) return finished(ReadStatus::corrupt_segment);
      if (size > capacity) {
        info = SampleInfo{where.sequence, where.sequence - next_sequence, timestamp, size};
        return finished(ReadStatus::buffer_too_small);
      }
      if (pinned) ++stats.pinned_copies;
      deliver(where, size, timestamp, info);
      return finished(ReadStatus::ok);
    }
    return kBusy;
  }

  Attempt try_borrow(BorrowedSample& sample, ReadMode mode) noexcept {
    if (header().head_sequence.load(std::memory_order_acquire) < next_sequence) return kNothingNew;
    const std::optional<std::uint32_t> token = acquire_token();
    if (!token) return finished(ReadStatus::borrow_limit);

    std::uint64_t known_head = 0;
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
      Location where{};
      switch (locate(mode, known_head, where)) {
        case Locate::none:
          release_token(*token);
          return kNothingNew;
        case Locate::corrupt:
          release_token(*token);
          return finished(ReadStatus::corrupt_segment);
        case Locate::moved:
          cpu_relax();
          continue;
        case Locate::found:
          break;
      }
      if (!pin(where, *token)) continue;
      const SlotHeader& slot = view.slot(where.slot);
      const std::uint32_t size = slot.size.load(std::memory_order_relaxed);
      if (size > view.geometry.message_size) {
        unpin(where.slot, *token);
        release_token(*token);
        return finished(ReadStatus::corrupt_segment);
      }
      deliver(where, size, slot.timestamp.load(std::memory_order_relaxed), sample.info_);
      sample.data_ = view.payload(where.slot);
      sample.token_ = *token;
      sample.slot_ = where.slot;
      return finished(ReadStatus::ok);
    }
    release_token(*token);
    return kBusy;
  }

  // ---- waiting

  bool publisher_alive() const noexcept {
    if (header().state.load(std::memory_order_acquire) != kOpen) return false;
    if (!own_description || (flags & layout::kPublisherHoldsLivenessLock) == 0) return true;
    return byte_locked_by_other(fd.get(), layout::kPublisherLockByte);
  }

  bool wake_condition() const noexcept {
    return header().head_sequence.load(std::memory_order_acquire) >= next_sequence ||
           header().state.load(std::memory_order_acquire) != kOpen ||
           unblock_requested.load(std::memory_order_acquire) || followable_stream() != 0;
  }

  bool publisher_on_this_cpu() const noexcept {
    return header().publisher_cpu.load(std::memory_order_relaxed) == sched_getcpu();
  }

  // First phase of a blocking wait when the publisher last wrote from this
  // CPU: spinning would only keep it off the CPU, so yield once instead,
  // which lets a runnable publisher (or ping-pong partner) go first without a
  // futex round trip. A publisher that streams on this CPU (it wrote several
  // packets during a long yield) is better served by sleeping: the scheduler
  // pushes a yielding task back, so later wake-ups stop preempting it; then we
  // sleep instead for a while. A long yield that brought one packet is a
  // partner that simply worked that long (e.g. copying a large packet): no
  // reason to give up the cheaper hand-over.
  bool yield_to_publisher(TimePoint start) noexcept {
    if (start < no_yield_until) return false;
    const std::uint64_t head_before = header().head_sequence.load(std::memory_order_relaxed);
    sched_yield();
    const bool ready = wake_condition();
    const std::uint64_t written = header().head_sequence.load(std::memory_order_relaxed) - head_before;
    if (written > 1) {
      const TimePoint after = Clock::now();
      if (after - start > options.spin.max_spin) {
        no_yield_until = after + yield_backoff;
        yield_backoff = std::min(2 * yield_backoff, kMaxYieldBackoff);
        ++stats.yield_backoffs;
        return ready;
      }
    }
    if (ready) yield_backoff = kMinYieldBackoff;
    return ready;
  }

  // First phase of a blocking wait when the publisher runs elsewhere: spin
  // for the learned spin_limit.
  bool spin_until_ready(TimePoint start, TimePoint deadline) const noexcept {
    const TimePoint spin_end = std::min(deadline, start + spin_limit);
    for (;;) {
      for (int i = 0; i < 4; ++i) {
        if (wake_condition()) return true;
        cpu_relax();
      }
      if (Clock::now() >= spin_end) return wake_condition();
    }
  }

  // Spin as long as max_spin while packets keep arriving within it (a
  // futex sleep and wake-up costs more than that); when they arrive later,
  // spinning is wasted CPU, so halve the limit towards min_spin. `delay` is
  // when the packet came, never when a sleeping reader got its CPU back:
  // that wake-up latency (15-25 µs across cores on a VM) would otherwise
  // exceed max_spin by itself, and two ping-pong partners with a few µs of
  // work per message would both stop spinning for good.
  void learn_arrival(nanoseconds delay) noexcept {
    const nanoseconds lower = options.spin.min_spin;
    const nanoseconds upper = options.spin.max_spin;
    if (upper <= nanoseconds::zero()) return;
    if (delay <= upper) {
      spin_limit = std::clamp(2 * spin_limit, std::max(lower, nanoseconds(1)), upper);
    } else {
      spin_limit = std::max(lower, spin_limit / 2);
    }
  }

  // Time from `start` until the writer woke this sleeping reader (now, if
  // the stamp is from an earlier wake-up or a publisher without stamps).
  static nanoseconds arrival_since(TimePoint start, const SegmentHeader& shared) noexcept {
    const TimePoint now = Clock::now();
    const TimePoint woken_at{nanoseconds(shared.last_wake_ns.load(std::memory_order_relaxed))};
    return (woken_at >= start && woken_at <= now ? woken_at : now) - start;
  }

  // Returns ok when woken for any reason worth a new attempt. `start` is now.
  ReadStatus wait_for_packet(TimePoint start, TimePoint deadline) noexcept {
    if (spin_limit > nanoseconds::zero()) {
      if (publisher_on_this_cpu()) {
        if (yield_to_publisher(start)) {
          ++stats.spin_wakeups;
          return ReadStatus::ok;
        }
      } else if (spin_until_ready(start, deadline)) {
        ++stats.spin_wakeups;
        learn_arrival(Clock::now() - start);
        return ReadStatus::ok;
      }
    }
    ReaderArea& readers = *view.readers;
    const nanoseconds check_interval = options.liveness_check_interval;
    TimePoint last_check = start;
    ReadStatus result = ReadStatus::ok;
    readers.sleeping_readers.fetch_add(1, std::memory_order_seq_cst);
    for (;;) {
      const std::uint32_t word = readers.wake_word.load(std::memory_order_seq_cst);
      if (wake_condition()) break;
      const TimePoint now = Clock::now();
      if (now >= deadline) {
        result = ReadStatus::timeout;
        break;
      }
      if (now - last_check >= check_interval) {
        last_check = now;
        if (!publisher_alive()) {
          result = ReadStatus::publisher_gone;
          break;
        }
      }
      nanoseconds sleep = check_interval - (now - last_check);
      if (deadline != TimePoint::max()) sleep = std::min(sleep, nanoseconds(deadline - now));
      ++stats.futex_sleeps;
      const bool may_follow = follow_streams && !publisher_on_this_cpu();
      futex_wait(&readers.wake_word, word, sleep,
                 layout::kWakeOnCommit | (may_follow ? layout::kWakeOnStreamStart : 0));
    }
    readers.sleeping_readers.fetch_sub(1, std::memory_order_seq_cst);
    if (result == ReadStatus::ok) learn_arrival(arrival_since(start, header()));
    if (result == ReadStatus::timeout && !publisher_alive()) result = ReadStatus::publisher_gone;
    return result;
  }

  template <typename TryOnce>
  ReadStatus run(TryOnce&& try_once, WaitDeadline& wait) noexcept {
    const bool blocking = !wait.polls();
    bool busy_before = false;
    TimePoint last_busy_check{};
    for (;;) {
      // Read the state before trying: packets written before a close are still delivered.
      const std::uint32_t state = header().state.load(std::memory_order_acquire);
      const Attempt attempt = try_once();
      if (attempt.kind == Attempt::finished) return attempt.status;
      if (state != kOpen) return status_for_state(state);
      if (!blocking) return ReadStatus::no_data;
      if (unblock_requested.exchange(false, std::memory_order_acq_rel)) return ReadStatus::unblocked;
      const TimePoint now = Clock::now();
      const TimePoint deadline = wait.at(now);
      if (now >= deadline) return publisher_alive() ? ReadStatus::timeout : ReadStatus::publisher_gone;
      if (attempt.kind == Attempt::busy) {
        // The writer keeps overwriting our packet, or stopped half-way through publishing one.
        if (!busy_before) {
          busy_before = true;
          last_busy_check = now;
        } else if (now - last_busy_check >= options.liveness_check_interval) {
          last_busy_check = now;
          if (!publisher_alive()) return ReadStatus::publisher_gone;
        }
        sched_yield();
        continue;
      }
      const ReadStatus waited = wait_for_packet(now, deadline);
      if (waited != ReadStatus::ok) return waited;
    }
  }
};

}  // namespace detail

// ---- BorrowedSample

BorrowedSample::BorrowedSample(BorrowedSample&& other) noexcept
    : core_(std::move(other.core_)), data_(other.data_), info_(other.info_), token_(other.token_), slot_(other.slot_) {
  other.data_ = nullptr;
  other.info_ = {};
}

BorrowedSample& BorrowedSample::operator=(BorrowedSample&& other) noexcept {
  if (this != &other) {
    release();
    core_ = std::move(other.core_);
    data_ = other.data_;
    info_ = other.info_;
    token_ = other.token_;
    slot_ = other.slot_;
    other.data_ = nullptr;
    other.info_ = {};
  }
  return *this;
}

void BorrowedSample::release() noexcept {
  if (core_ && data_ != nullptr) {
    core_->unpin(slot_, token_);
    core_->release_token(token_);
  }
  core_.reset();
  data_ = nullptr;
  info_ = {};
}

// ---- ShmReader

namespace {

layout::Geometry validate_segment_info(const layout::SegmentInfo& info, std::size_t file_size) {
  if (std::memcmp(info.magic, layout::kMagic, sizeof(info.magic)) != 0) {
    throw ShmError(ShmErrc::bad_magic, "not an ln shared-memory ring segment (bad magic)");
  }
  if (info.version != layout::kVersion) {
    throw ShmError(ShmErrc::bad_version, "segment layout version " + std::to_string(info.version) + ", expected " +
                                             std::to_string(layout::kVersion));
  }
  if (info.info_size != sizeof(layout::SegmentInfo) || layout::checksum(info) != info.checksum) {
    throw ShmError(ShmErrc::bad_layout, "segment header checksum mismatch");
  }
  layout::Geometry geometry;
  try {
    geometry = layout::compute_geometry(info.message_size, info.history, info.borrow_slots);
  } catch (const ShmError& error) {
    throw ShmError(ShmErrc::bad_layout, std::string("segment header: ") + error.what());
  }
  if (geometry.slot_count != info.slot_count || geometry.slot_stride != info.slot_stride ||
      geometry.ring_offset != info.ring_offset || geometry.slots_offset != info.slots_offset ||
      geometry.shared_offset != info.shared_offset || geometry.total_size != info.total_size) {
    throw ShmError(ShmErrc::bad_layout, "segment header sizes are inconsistent");
  }
  if (geometry.total_size > file_size) {
    throw ShmError(ShmErrc::too_small, "segment file is " + std::to_string(file_size) + " bytes, header says " +
                                           std::to_string(geometry.total_size));
  }
  return geometry;
}

}  // namespace

ShmReader ShmReader::attach(UniqueFd segment_fd, const ReaderOptions& options) {
  ShmReader reader = attach(segment_fd.get(), options);
  segment_fd.reset();
  return reader;
}

ShmReader ShmReader::attach(int segment_fd, const ReaderOptions& options) {
  auto core = std::make_shared<detail::ReaderCore>();
  core->fd = reopen_as_own_description(segment_fd);
  core->own_description = core->fd.valid();
  if (!core->own_description) {
    core->fd.reset(::fcntl(segment_fd, F_DUPFD_CLOEXEC, 0));
    if (!core->fd.valid()) {
      const int err = errno;
      throw ShmError(ShmErrc::system_error, std::string("dup of segment descriptor: ") + std::strerror(err), err);
    }
  }

  const std::size_t file_size = sealed_memfd_size(core->fd.get());
  if (file_size < sizeof(SegmentHeader)) {
    throw ShmError(ShmErrc::too_small, "segment file is smaller than a segment header");
  }
  layout::SegmentInfo info{};
  if (::pread(core->fd.get(), &info, sizeof(info), 0) != static_cast<ssize_t>(sizeof(info))) {
    const int err = errno;
    throw ShmError(ShmErrc::system_error, "reading segment header failed", err);
  }
  const layout::Geometry geometry = validate_segment_info(info, file_size);

  if (options.buffers == 0 || options.buffers > geometry.history) {
    throw ShmError(ShmErrc::invalid_argument, "reader buffers must be between 1 and the segment history (" +
                                                  std::to_string(geometry.history) + ")");
  }
  if (options.liveness_check_interval <= std::chrono::milliseconds::zero()) {
    throw ShmError(ShmErrc::invalid_argument, "liveness_check_interval must be positive");
  }
  if (options.spin.min_spin < nanoseconds::zero() || options.spin.max_spin < options.spin.min_spin) {
    throw ShmError(ShmErrc::invalid_argument, "spin policy needs 0 <= min_spin <= max_spin");
  }

  // Write-protected: the publisher's part read-only, the reader area
  // writable: a stray write of this process can then only disturb sleeping
  // and borrowing (which the publisher survives, see ShmWriter), never the
  // packets. With pages larger than the reader area's alignment, one
  // writable mapping of everything.
  std::byte* shared = nullptr;
  if (options.write_protect && geometry.shared_offset % page_size() == 0) {
    core->mapping = Mapping::map_shared(core->fd.get(), 0, geometry.shared_offset, false);
    core->shared_mapping =
        Mapping::map_shared(core->fd.get(), geometry.shared_offset, geometry.total_size - geometry.shared_offset, true);
    shared = core->shared_mapping.data();
  } else {
    core->mapping = Mapping::map_shared(core->fd.get(), geometry.total_size);
    shared = core->mapping.data() + geometry.shared_offset;
  }
  core->view = SegmentView(core->mapping.data(), shared, geometry);
  core->flags = info.flags;
  core->options = options;
  core->max_borrows = std::min(options.max_borrows, geometry.borrow_slots);
  if (core->own_description && geometry.borrow_slots != 0) {
    // An identity whose liveness the kernel maintains: our lock on byte 1 + ticket.
    const std::uint64_t ticket = core->view.readers->next_reader_ticket.fetch_add(1, std::memory_order_relaxed) + 1;
    if (ticket < layout::kMaxReaderTicket && try_lock_byte(core->fd.get(), layout::kFirstReaderLockByte + ticket)) {
      core->ticket = ticket;
      core->token_scan_start = static_cast<std::uint32_t>(ticket % geometry.borrow_slots);
    }
  }
  core->spin_limit = options.spin.max_spin;
  core->next_sequence = options.resume_after ? *options.resume_after + 1
                                             : core->view.header->head_sequence.load(std::memory_order_acquire) + 1;
  return ShmReader(std::move(core));
}

ShmReader::ShmReader(std::shared_ptr<detail::ReaderCore> core) noexcept : core_(std::move(core)) {}
ShmReader::ShmReader(ShmReader&&) noexcept = default;
ShmReader& ShmReader::operator=(ShmReader&&) noexcept = default;
ShmReader::~ShmReader() = default;

ReadStatus ShmReader::read(void* buffer, std::size_t capacity, SampleInfo& info, nanoseconds timeout, ReadMode mode) {
  WaitDeadline deadline(timeout);
  return read(buffer, capacity, info, deadline, mode);
}

ReadStatus ShmReader::read(void* buffer, std::size_t capacity, SampleInfo& info, WaitDeadline& deadline,
                           ReadMode mode) {
  detail::ReaderCore& core = *core_;
  // Only reads without a deadline follow streams: a read that times out must
  // leave the buffer untouched, and a stalled writer would leave part of a
  // packet in it. A follower cannot pin the slot being written either, so
  // with optimistic_copies == 0 it waits for the commit.
  core.follow_streams = deadline.forever() && core.options.optimistic_copies != 0;
  const ReadStatus status = core.run([&] { return core.try_copy(buffer, capacity, info, mode); }, deadline);
  core.follow_streams = false;
  return status;
}

ReadStatus ShmReader::borrow(BorrowedSample& sample, nanoseconds timeout, ReadMode mode) {
  WaitDeadline deadline(timeout);
  return borrow(sample, deadline, mode);
}

ReadStatus ShmReader::borrow(BorrowedSample& sample, WaitDeadline& deadline, ReadMode mode) {
  sample.release();
  detail::ReaderCore& core = *core_;
  const ReadStatus status = core.run([&] { return core.try_borrow(sample, mode); }, deadline);
  if (status == ReadStatus::ok) sample.core_ = core_;
  return status;
}

bool ShmReader::has_new_data() const noexcept {
  return core_->header().head_sequence.load(std::memory_order_acquire) >= core_->next_sequence;
}

void ShmReader::unblock() noexcept {
  core_->unblock_requested.store(true, std::memory_order_seq_cst);
  // Changing the futex word makes a reader that is just about to sleep return at once.
  core_->view.readers->wake_word.fetch_add(1, std::memory_order_seq_cst);
  futex_wake_all(&core_->view.readers->wake_word);
}

bool ShmReader::publisher_alive() const noexcept { return core_->publisher_alive(); }
std::uint64_t ShmReader::last_sequence() const noexcept { return core_->next_sequence - 1; }
std::uint32_t ShmReader::message_size() const noexcept { return core_->view.geometry.message_size; }
std::uint32_t ShmReader::history() const noexcept { return core_->view.geometry.history; }
ReaderStats ShmReader::stats() const noexcept { return core_->stats; }

// ---- ShmWakeWatch: sleeping on several segments at once

ShmWakeWatch ShmReader::watch_wake_word() const noexcept { return ShmWakeWatch(core_); }

ShmWakeWatch::ShmWakeWatch(std::shared_ptr<detail::ReaderCore> core) noexcept : core_(std::move(core)) {
  ReaderArea& shared = *core_->view.readers;
  // The order of wait_for_packet: counted first, so that a writer that bumps
  // the word after our load also sees the count and wakes us.
  shared.sleeping_readers.fetch_add(1, std::memory_order_seq_cst);
  expected_ = shared.wake_word.load(std::memory_order_seq_cst);
}

ShmWakeWatch& ShmWakeWatch::operator=(ShmWakeWatch&& other) noexcept {
  if (this != &other) {
    withdraw();
    core_ = std::move(other.core_);
    expected_ = other.expected_;
  }
  return *this;
}

const std::atomic<std::uint32_t>* ShmWakeWatch::word() const noexcept {
  return core_ ? &core_->view.readers->wake_word : nullptr;
}

void ShmWakeWatch::withdraw() noexcept {
  if (!core_) return;
  core_->view.readers->sleeping_readers.fetch_sub(1, std::memory_order_seq_cst);
  core_.reset();
}

}  // namespace ln::transport
