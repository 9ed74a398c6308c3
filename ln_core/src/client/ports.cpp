#include "client/ports.hpp"

#include <fcntl.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

#include "client/error_slot.hpp"
#include "client/failure.hpp"
#include "transport/shm_layout.hpp"

namespace ln::clientlib {

using transport::ReadMode;
using transport::ReadStatus;
using transport::SampleInfo;
using transport::ShmError;
using transport::WriteStatus;
using Clock = std::chrono::steady_clock;

namespace {

double wall_clock_now() noexcept {
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  return static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
}

int failure_code_of(const ShmError& error) {
  switch (error.code()) {
    case transport::ShmErrc::system_error:
      remember_errno(error.sys_errno());
      return LNE_CHECK_ERRNO;
    case transport::ShmErrc::too_small:
      return LNE_WRONG_SHM_SIZE;
    case transport::ShmErrc::bad_magic:
      return LNE_INVALID_SHM_MAGIC;
    case transport::ShmErrc::bad_version:
      return LNE_SHM_VERSION_TOO_NEW;
    case transport::ShmErrc::bad_layout:
      return LNE_WRONG_SHM_SIZE;
    case transport::ShmErrc::invalid_config:
      return LNE_SHM_IS_TOO_BIG;
    default:
      return LNE_INVALID_PARAMETER;
  }
}

}  // namespace

namespace {

std::uint64_t new_stream_id() {
  static std::atomic<std::uint64_t> counter{0};
  std::random_device random;
  const std::uint64_t id = (std::uint64_t{random()} << 32 ^ random()) + ++counter;
  return id != 0 ? id : 1;
}

}  // namespace

std::int64_t next_segment_generation() {
  static std::atomic<std::int64_t> counter{0};
  return ++counter;
}

// ------------------------------------------------------------------ PortBase

PortBase::~PortBase() { kind_ = PortKind{0}; }  // a stale handle then fails from_handle

PortBase* PortBase::from_handle(void* handle) noexcept {
  auto* port = static_cast<PortBase*>(handle);
  if (port == nullptr) return nullptr;
  if (port->kind_ != PortKind::outport && port->kind_ != PortKind::inport) return nullptr;
  return port;
}

int PortBase::fail(int code, const char* format, ...) const noexcept {
  // Formatted on the stack: failing must not allocate (the callers are noexcept).
  char text[1024];
  const int prefix = std::snprintf(text, sizeof text, "topic '%s': ", topic_.c_str());
  if (prefix > 0 && static_cast<std::size_t>(prefix) < sizeof text) {
    va_list args;
    va_start(args, format);
    std::vsnprintf(text + prefix, sizeof text - static_cast<std::size_t>(prefix), format, args);
    va_end(args);
  }
  errors_.set(text);
  return -code;
}

// ------------------------------------------------------------------- OutPort

OutPort::~OutPort() {
  std::lock_guard<std::mutex> lock(senders_mutex_);
  senders_.clear();
}

void OutPort::set_remote_targets(const std::vector<RemoteTarget>& targets) {
  std::map<RemoteTarget, std::unique_ptr<RemoteSender>> kept;
  std::lock_guard<std::mutex> lock(senders_mutex_);
  for (const RemoteTarget& target : targets) {
    auto existing = senders_.find(target);
    if (existing != senders_.end()) {
      kept.emplace(target, std::move(existing->second));
    } else if (!kept.count(target)) {
      kept.emplace(target, std::make_unique<RemoteSender>(*this, target));
    }
  }
  senders_.swap(kept);  // the senders left in `kept` stop here
}

std::uint32_t OutPort::history_limit() const noexcept {
  if (segment_limit_ == 0) return transport::layout::kMaxHistory;
  // The largest history whose segment fits (segments grow with history).
  std::uint32_t fits = 0, too_big = transport::layout::kMaxHistory + 1;
  while (too_big - fits > 1) {
    const std::uint32_t middle = fits + (too_big - fits) / 2;
    const std::uint64_t size = transport::topic_segment_size(message_size_, middle);
    if (size != 0 && size <= segment_limit_)
      fits = middle;
    else
      too_big = middle;
  }
  return std::max<std::uint32_t>(fits, 1);  // the manager refused anything that needs more than that
}

std::unique_ptr<transport::ShmWriter> OutPort::make_writer(std::uint32_t message_size, std::uint32_t history,
                                                           std::uint64_t first_sequence, const char* what) const {
  transport::RingConfig config;
  config.message_size = std::max<std::uint32_t>(message_size, 1);  // the ring needs a byte; empty packets still count
  config.history = std::max<std::uint32_t>(history, 1);
  config.borrow_slots = transport::kTopicBorrowSlots;
  config.first_sequence = first_sequence;
  config.debug_name = "ln:" + topic_;
  try {
    return std::make_unique<transport::ShmWriter>(transport::ShmWriter::create(config));
  } catch (const ShmError& error) {
    throw Failure(failure_code_of(error),
                  std::string(what) + " the shared-memory segment of topic '" + topic_ + "': " + error.what());
  }
}

void OutPort::create_segment(std::uint32_t message_size, const std::string& hash, std::uint32_t history) {
  message_size_ = message_size;
  hash_ = hash;
  auto writer = make_writer(message_size, std::min(history, history_limit()), 1, "creating");
  std::lock_guard<std::mutex> lock(write_mutex_);
  writer_ = std::move(writer);
  generation_ = next_segment_generation();
  first_sequence_ = 1;
  stream_ = new_stream_id();
}

bool OutPort::ensure_history(std::uint32_t wanted) {
  const std::uint32_t history = std::min(wanted, history_limit());
  {
    std::lock_guard<std::mutex> lock(write_mutex_);
    if (!writer_ || writer_->history() >= history) return false;
  }
  // Made and pre-faulted without the lock (a segment of many buffers of
  // large packets takes a while); writes go on into the current segment
  // meanwhile. It starts right after the current segment's last packet,
  // numbered when it takes over.
  std::unique_ptr<transport::ShmWriter> bigger = make_writer(message_size_, history, 1, "growing");
  std::lock_guard<std::mutex> lock(write_mutex_);
  if (!writer_ || writer_->history() >= history) return false;
  if (!bigger->renumber(writer_->last_sequence() + 1))
    throw Failure(LNE_INTERNAL_ERROR, "growing the shared-memory segment of topic '" + topic_ + "': cannot number it");
  switch_segment_locked(std::move(bigger));
  return true;
}

void OutPort::switch_segment_locked(std::unique_ptr<transport::ShmWriter> next) {
  writer_->close_replaced();
  if (loan_ != nullptr) {
    retired_ = std::move(writer_);
    retired_loan_ = loan_;
    loan_ = nullptr;
  }
  first_sequence_ = next->last_sequence() + 1;
  writer_ = std::move(next);
  generation_ = next_segment_generation();
}

bool OutPort::recover_segment_locked() noexcept {
  try {
    switch_segment_locked(make_writer(message_size_, writer_->history(), writer_->last_sequence() + 1, "re-creating"));
    recoveries_.fetch_add(1, std::memory_order_relaxed);
    if (recovery_handler_) recovery_handler_();
    return true;
  } catch (...) {
    return false;  // out of memory or descriptors: the write fails and the next one tries again
  }
}

void OutPort::want_history(std::uint32_t history) noexcept {
  std::uint32_t known = wanted_history_.load();
  while (history > known && !wanted_history_.compare_exchange_weak(known, history)) {
  }
}

std::int64_t OutPort::generation() const {
  std::lock_guard<std::mutex> lock(write_mutex_);
  return generation_;
}

std::uint64_t OutPort::packets_written() const noexcept {
  // write() may replace the writer (a corrupted segment) from any thread.
  std::unique_lock<std::mutex> lock(write_mutex_, std::try_to_lock);
  if (lock.owns_lock() && writer_)
    last_packets_written_.store(writer_->published_sequence(), std::memory_order_relaxed);
  return last_packets_written_.load(std::memory_order_relaxed);
}

bool OutPort::check_segment() noexcept {
  std::unique_lock<std::mutex> lock(write_mutex_, std::try_to_lock);
  if (!lock.owns_lock() || !writer_ || writer_->shared_state_intact()) return false;
  return recover_segment_locked();
}

std::uint64_t OutPort::newest_sequence() const {
  std::lock_guard<std::mutex> lock(write_mutex_);
  return writer_ ? writer_->last_sequence() : 0;
}

OutPort::SegmentOffer OutPort::offer_segment() const {
  std::lock_guard<std::mutex> lock(write_mutex_);
  SegmentOffer offer;
  if (!writer_) return offer;
  // A duplicate shares the writer's open file description, so passing it
  // does not disturb the publisher's liveness lock.
  offer.fd = UniqueFd(::fcntl(writer_->fd(), F_DUPFD_CLOEXEC, 0));
  offer.slots = writer_->history();
  offer.generation = generation_;
  offer.last_sequence = writer_->last_sequence();
  offer.first_sequence = first_sequence_;
  offer.stream = stream_;
  return offer;
}

int OutPort::write(const void* packet, unsigned size, const double* timestamp) noexcept {
  if (size > message_size_)
    return fail(LNE_PACKET_TOO_LARGE, "packet of %u bytes is larger than the message size %u", size, message_size_);
  if (packet == nullptr && size > 0) return fail(LNE_INVALID_PARAMETER, "write of a NULL packet");
  const double stamp = timestamp != nullptr ? *timestamp : wall_clock_now();
  std::lock_guard<std::mutex> lock(write_mutex_);
  if (!writer_) return fail(LNE_INVALID_PORT_OBJECT, "the port has no segment");
  WriteStatus status;
  if (loan_ != nullptr && packet == loan_) {
    status = writer_->commit(size, stamp);
    loan_ = nullptr;
  } else {
    if (loan_ != nullptr) {
      writer_->discard_loan();
      loan_ = nullptr;
    }
    status = writer_->write(packet, size, stamp);
    if (status == WriteStatus::no_free_slot && recover_segment_locked()) status = writer_->write(packet, size, stamp);
    if (retired_) {  // the packet may live in the retired writer's loan: copied by now
      retired_->discard_loan();
      retired_.reset();
      retired_loan_ = nullptr;
    }
  }
  switch (status) {
    case WriteStatus::ok:
      return 0;
    case WriteStatus::packet_too_large:
      return fail(LNE_PACKET_TOO_LARGE, "packet larger than the segment's slots");
    default:
      return fail(LNE_INTERNAL_ERROR, "shared-memory write failed: %s", transport::to_string(status));
  }
}

int OutPort::next_buffer(void** buffer, unsigned* length) noexcept {
  if (buffer == nullptr) return fail(LNE_INVALID_PARAMETER, "ln_outport_get_next_buffer without a buffer pointer");
  std::lock_guard<std::mutex> lock(write_mutex_);
  if (!writer_) return fail(LNE_INVALID_PORT_OBJECT, "the port has no segment");
  if (loan_ == nullptr) loan_ = writer_->loan();
  if (loan_ == nullptr && recover_segment_locked()) loan_ = writer_->loan();
  if (loan_ == nullptr) return fail(LNE_INTERNAL_ERROR, "no buffer available in the shared-memory segment");
  *buffer = loan_;
  if (length != nullptr) *length = message_size_;
  return 0;
}

// -------------------------------------------------------------------- InPort

namespace {

/// LN's read timeout in seconds: < 0 (or NaN) waits without limit, 0 polls.
transport::WaitDeadline wait_deadline(double timeout_seconds) {
  if (timeout_seconds < 0 || std::isnan(timeout_seconds)) return transport::WaitDeadline(transport::kWaitForever);
  const double capped = std::min(timeout_seconds, 1e9);  // ~31 years: "forever" without overflow
  return transport::WaitDeadline(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::duration<double>(capped)));
}

}  // namespace

InPort::InPort(ErrorSlot& errors, std::string topic, std::string md_name, double rate, std::uint32_t buffers,
               bool reliable)
    : PortBase(PortKind::inport, errors, std::move(topic), std::move(md_name)),
      rate_(rate),
      buffers_(std::max<std::uint32_t>(buffers, 1)),
      reliable_(reliable),
      on_request_(rate == RATE_ON_REQUEST_LAST) {}

InPort::~InPort() {
  std::lock_guard<std::mutex> lock(loan_mutex_);
  loan_.release();
}

void InPort::set_has_publisher(bool present) noexcept { has_publisher_.store(present, std::memory_order_relaxed); }

bool InPort::knows_segment(const SegmentIdentity& identity) const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  return (reader_ && current_ == identity) || (pending_ && pending_->identity == identity);
}

namespace {
std::atomic<std::uint32_t> segment_changes{0};
}  // namespace

const std::atomic<std::uint32_t>* InPort::segment_change_word() noexcept { return &segment_changes; }

void InPort::offer_segment(UniqueFd fd, SegmentIdentity identity, std::uint32_t slots,
                           std::optional<std::uint64_t> written_before) {
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    const bool other_publisher = reader_ && identity.publisher_socket != current_.publisher_socket;
    pending_ = PendingSegment{std::move(fd), std::move(identity), slots, written_before};
    has_pending_.store(true, std::memory_order_release);
    // A reader blocked on a segment of another publisher would wait there in
    // vain: wake it so that it switches. (A segment of the same publisher
    // replaces its predecessor, which wakes its readers itself when closed.)
    if (other_publisher) reader_->unblock();
    state_changed_.notify_all();
  }
  // Multi-waiters: a waiter that loaded the word before checking this port
  // either saw pending_ (stored before this increment) or sleeps on a stale
  // value and gets woken. Only an offer can make a port without a readable
  // segment readable: a closed or replaced segment changes its own wake word.
  segment_changes.fetch_add(1, std::memory_order_seq_cst);
  transport::futex_wake_all(&segment_changes);
}

void InPort::fail_stream(int code, const std::string& text) {
  std::lock_guard<std::mutex> lock(state_mutex_);
  stream_failure_text_ = text;
  stream_failure_.store(code, std::memory_order_release);
  state_changed_.notify_all();
}

void InPort::forget_pending_segment() {
  std::lock_guard<std::mutex> lock(state_mutex_);
  pending_.reset();
  has_pending_.store(false, std::memory_order_release);
}

void InPort::unblock() noexcept {
  std::lock_guard<std::mutex> lock(state_mutex_);
  user_unblock_ = true;
  if (reader_) reader_->unblock();
  state_changed_.notify_all();
}

void InPort::drop_reader() {
  std::lock_guard<std::mutex> lock(state_mutex_);
  reader_.reset();
  current_ = SegmentIdentity();
}

void InPort::adopt_pending_segment() {
  // The common case, checked without the lock: nothing was handed over.
  if (!has_pending_.load(std::memory_order_acquire)) return;
  std::unique_lock<std::mutex> lock(state_mutex_);
  if (!pending_) return;
  // The same publisher's next segment waits until the current one is drained
  // (it then reports segment_replaced); another publisher takes over at once.
  if (reader_ && pending_->identity.publisher_socket == current_.publisher_socket) return;
  PendingSegment segment = std::move(*pending_);
  pending_.reset();
  has_pending_.store(false, std::memory_order_release);
  lock.unlock();

  transport::ReaderOptions options;
  options.buffers = std::min(buffers_, std::max<std::uint32_t>(segment.slots, 1));
  options.max_borrows = 1;
  // A subscriber that may write where it must not (while debugging one)
  // faults at the write instead of corrupting the publisher's packets.
  const char* protect = std::getenv("LN_SHM_WRITE_PROTECT");
  options.write_protect = protect != nullptr && *protect != '\0' && std::string(protect) != "0";
  const bool continues = !resume_socket_.empty() && resume_socket_ == segment.identity.publisher_socket;
  // An on-request read returns the newest packet, also one written before
  // this subscription (as LN 2.9 fetches it from the publisher).
  options.resume_after = continues     ? std::optional<std::uint64_t>(resume_after_)
                         : on_request_ ? std::optional<std::uint64_t>(0)
                                       : segment.written_before;
  resume_after_ = 0;
  resume_socket_.clear();
  std::unique_ptr<transport::ShmReader> attached;
  try {
    attached = std::make_unique<transport::ShmReader>(transport::ShmReader::attach(std::move(segment.fd), options));
  } catch (const ShmError& error) {
    fail(failure_code_of(error), "cannot attach to the publisher's segment: %s", error.what());
    return;
  } catch (const std::bad_alloc&) {
    return;
  }
  if (attached->message_size() < std::max<std::uint32_t>(message_size_, 1)) {
    fail(LNE_SHM_IS_TOO_SMALL, "the publisher's segment holds smaller packets than the topic's message size");
    return;
  }
  if (!continues) {
    // Timestamps and packets of another publisher say nothing about this one.
    delivered_any_ = false;
    have_cached_ = false;
  }
  lock.lock();
  reader_ = std::move(attached);
  current_ = std::move(segment.identity);
}

int InPort::wait_for_segment(transport::WaitDeadline& deadline) {
  std::unique_lock<std::mutex> lock(state_mutex_);
  auto changed = [&] { return pending_.has_value() || user_unblock_ || stream_failure_.load() != 0; };
  if (deadline.polls()) return pending_ ? 1 : 0;
  if (deadline.forever()) {
    state_changed_.wait(lock, changed);
  } else if (!state_changed_.wait_until(lock, deadline.at(Clock::now()), changed)) {
    return 0;
  }
  if (pending_ || stream_failure_.load() != 0) return 1;
  user_unblock_ = false;
  return -LNE_PORT_UNBLOCKED;
}

void InPort::leave_segment(ReadStatus status) {
  if (status == ReadStatus::segment_replaced) {
    resume_after_ = reader_->last_sequence();
    resume_socket_ = current_.publisher_socket;
    drop_reader();
    return;
  }
  drop_reader();
  std::lock_guard<std::mutex> lock(state_mutex_);
  if (!pending_) has_publisher_.store(false, std::memory_order_relaxed);
}

void InPort::settle_segment(transport::ShmWakeWatch* watch) {
  adopt_pending_segment();
  // Watched before anything about the segment is looked at: whatever
  // changes after this (a close, a packet) changes the watched word.
  if (reader_ && watch != nullptr) *watch = reader_->watch_wake_word();
  // The state before the data: once the segment is seen closed, no packet can follow.
  if (!reader_ || !has_pending_.load(std::memory_order_acquire) || reader_->publisher_alive() ||
      reader_->has_new_data()) {
    return;
  }
  // Drained and closed: a non-blocking read only reports why (nothing is
  // consumed, the buffer is untouched).
  unsigned char unused = 0;
  SampleInfo info;
  const ReadStatus status = reader_->read(&unused, sizeof unused, info, transport::kNoWait);
  if (status != ReadStatus::segment_replaced && status != ReadStatus::publisher_gone) return;
  leave_segment(status);
  adopt_pending_segment();
  if (watch == nullptr) return;
  if (reader_) {
    *watch = reader_->watch_wake_word();
  } else {
    watch->withdraw();
  }
}

template <typename Attempt>
int InPort::next_packet(transport::WaitDeadline& deadline, Attempt&& attempt, SampleInfo& info) {
  for (;;) {
    if (const int code = stream_failure_.load(std::memory_order_acquire); code != 0) {
      std::lock_guard<std::mutex> lock(state_mutex_);
      return fail(code, "%s", stream_failure_text_.c_str());
    }
    adopt_pending_segment();
    if (!reader_) {
      const int changed = wait_for_segment(deadline);
      if (changed <= 0) return changed;
      continue;
    }
    const ReadStatus status = attempt(*reader_, deadline, info);
    switch (status) {
      case ReadStatus::ok:
        return 1;
      case ReadStatus::no_data:
      case ReadStatus::timeout:
        return 0;
      case ReadStatus::unblocked: {
        std::lock_guard<std::mutex> lock(state_mutex_);
        if (user_unblock_) {
          user_unblock_ = false;
          return -LNE_PORT_UNBLOCKED;
        }
        continue;  // woken to switch to another publisher's segment
      }
      case ReadStatus::segment_replaced:
      case ReadStatus::publisher_gone:
        leave_segment(status);
        continue;
      case ReadStatus::borrow_limit:
        return fail(LNE_INVALID_PARAMETER, "no borrow slot free in the publisher's segment");
      case ReadStatus::buffer_too_small:
      case ReadStatus::corrupt_segment:
        drop_reader();
        return fail(LNE_SHM_READ_ERROR, "reading the publisher's segment failed: %s", transport::to_string(status));
    }
  }
}

bool InPort::passes_rate_limit(const SampleInfo& info) {
  if (rate_ > 0 && delivered_any_) {
    const double since_last = info.timestamp - last_delivered_timestamp_;
    // Timestamps that go backwards (a restarted clock) are let through.
    if (since_last >= 0 && since_last < 1.0 / rate_) {
      lost_carry_ += info.lost + 1;
      return false;
    }
  }
  last_delivered_timestamp_ = info.timestamp;
  delivered_any_ = true;
  return true;
}

void InPort::deliver_info(const SampleInfo& info, ln_sample_info* out) {
  if (out != nullptr) {
    out->sequence = info.sequence;
    out->lost = info.lost + lost_carry_;
    out->timestamp = info.timestamp;
  }
  lost_carry_ = 0;
}

int InPort::read(void* packet, unsigned size, ln_sample_info* info, double timeout) noexcept {
  if (packet == nullptr) return fail(LNE_INVALID_PARAMETER, "read into a NULL packet buffer");
  if (on_request_) return read_on_request(packet, size, info);
  try {
    std::lock_guard<std::mutex> reading(read_mutex_);
    transport::WaitDeadline deadline = wait_deadline(timeout);
    // Straight into the caller's buffer unless a packet may still be
    // rejected (rate limit) or may not fit: a read copies all or nothing.
    const bool direct = rate_ <= 0 && size >= message_size_;
    if (!direct && bounce_.size() < std::max<std::uint32_t>(message_size_, 1))
      bounce_.resize(std::max<std::uint32_t>(message_size_, 1));
    void* target = direct ? packet : bounce_.data();
    const std::size_t capacity = direct ? size : bounce_.size();
    SampleInfo received;
    for (;;) {
      const int got = next_packet(
          deadline,
          [&](transport::ShmReader& reader, transport::WaitDeadline& wait, SampleInfo& out) {
            return reader.read(target, capacity, out, wait);
          },
          received);
      if (got <= 0) return got;
      if (!passes_rate_limit(received)) continue;
      if (!direct) std::memcpy(packet, bounce_.data(), std::min<std::size_t>(size, received.size));
      deliver_info(received, info);
      return 1;
    }
  } catch (const std::bad_alloc&) {
    return -LNE_NO_MEM;
  } catch (const std::system_error&) {
    return -LNE_INTERNAL_ERROR;
  }
}

int InPort::read_on_request(void* packet, unsigned size, ln_sample_info* info) noexcept {
  try {
    std::lock_guard<std::mutex> reading(read_mutex_);
    const std::size_t capacity = std::max<std::uint32_t>(message_size_, 1);
    if (bounce_.size() < capacity) bounce_.resize(capacity);
    SampleInfo received;
    transport::WaitDeadline no_wait(transport::kNoWait);
    const int got = next_packet(
        no_wait,
        [&](transport::ShmReader& reader, transport::WaitDeadline&, SampleInfo& out) {
          return reader.read(bounce_.data(), capacity, out, transport::kNoWait, ReadMode::newest);
        },
        received);
    if (got < 0) return got;
    if (got == 1) {
      have_cached_ = true;
      cached_info_ = received;
    } else if (!have_cached_ || !reader_) {
      return 0;  // nothing published yet, or the publisher is gone
    } else {
      cached_info_.lost = 0;  // the same packet once more
    }
    std::memcpy(packet, bounce_.data(), std::min<std::size_t>(size, cached_info_.size));
    deliver_info(cached_info_, info);
    return 1;
  } catch (const std::bad_alloc&) {
    return -LNE_NO_MEM;
  } catch (const std::system_error&) {
    return -LNE_INTERNAL_ERROR;
  }
}

int InPort::borrow(const void** packet, unsigned* size, ln_sample_info* info, double timeout) noexcept {
  if (packet == nullptr) return fail(LNE_INVALID_PARAMETER, "ln_read_borrow without a packet pointer");
  try {
    {
      std::lock_guard<std::mutex> lock(loan_mutex_);
      if (loan_.valid() || loan_is_copy_)
        return fail(LNE_INVALID_PARAMETER, "the previous borrowed packet was not released (ln_read_release)");
    }
    if (on_request_) {
      // No shared slot to pin: lend the port's own copy of the newest packet.
      std::vector<unsigned char> copy(std::max<std::uint32_t>(message_size_, 1));
      ln_sample_info got_info{};
      const int got = read_on_request(copy.data(), static_cast<unsigned>(copy.size()), &got_info);
      if (got != 1) return got;
      std::lock_guard<std::mutex> lock(loan_mutex_);
      loan_copy_ = std::move(copy);
      loan_is_copy_ = true;
      *packet = loan_copy_.data();
      if (size != nullptr) *size = std::min<unsigned>(cached_info_.size, static_cast<unsigned>(loan_copy_.size()));
      if (info != nullptr) *info = got_info;
      return 1;
    }
    std::lock_guard<std::mutex> reading(read_mutex_);
    transport::WaitDeadline deadline = wait_deadline(timeout);
    transport::BorrowedSample sample;
    SampleInfo received;
    for (;;) {
      const int got = next_packet(
          deadline,
          [&](transport::ShmReader& reader, transport::WaitDeadline& wait, SampleInfo& out) {
            const ReadStatus status = reader.borrow(sample, wait);
            if (status == ReadStatus::ok) out = sample.info();
            return status;
          },
          received);
      if (got <= 0) return got;
      if (!passes_rate_limit(received)) {
        sample.release();
        continue;
      }
      deliver_info(received, info);
      std::lock_guard<std::mutex> lock(loan_mutex_);
      *packet = sample.data();
      if (size != nullptr) *size = static_cast<unsigned>(sample.size());
      loan_ = std::move(sample);
      return 1;
    }
  } catch (const std::bad_alloc&) {
    return -LNE_NO_MEM;
  } catch (const std::system_error&) {
    return -LNE_INTERNAL_ERROR;
  }
}

int InPort::release_borrow() noexcept {
  std::lock_guard<std::mutex> lock(loan_mutex_);
  if (!loan_.valid() && !loan_is_copy_) return fail(LNE_INVALID_PARAMETER, "ln_read_release without a borrowed packet");
  loan_.release();
  loan_is_copy_ = false;
  return 0;
}

InPort::WaitCheck InPort::check(transport::ShmWakeWatch* watch) noexcept {
  std::unique_lock<std::mutex> reading(read_mutex_, std::try_to_lock);
  if (!reading.owns_lock()) return WaitCheck::busy;
  try {
    settle_segment(watch);
  } catch (...) {
    return WaitCheck::busy;  // out of memory: check again later
  }
  return reader_ && reader_->has_new_data() ? WaitCheck::readable : WaitCheck::not_readable;
}

bool InPort::readable_now() noexcept { return check(nullptr) == WaitCheck::readable; }

InPort::WaitCheck InPort::check_before_sleep(transport::ShmWakeWatch& watch) noexcept { return check(&watch); }

}  // namespace ln::clientlib
