#include "transport/ln29_shm.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>

namespace ln::transport::ln29 {
namespace {

constexpr char kMagic[7] = {'L', 'N', '_', 'S', 'H', 'M', '\0'};
constexpr std::size_t kSlotHeaderSize = 16;  // number, padding, timestamp
constexpr std::uint32_t kMaxElementSize = 1u << 30;
constexpr std::uint64_t kMaxSegmentSize = std::uint64_t{1} << 40;
// Shared memory object names are file names below /dev/shm.
constexpr std::size_t kMaxNameLength = 254;
// A writer fills a slot in well under a microsecond unless it is preempted;
// a reader that still finds it torn after this many attempts waits for the
// writer's commit (or, without waiting, gives up).
constexpr int kCopyAttempts = 64;
// Bound on one futex sleep: unblock() sets a flag and wakes the futex, which
// a reader that checked the flag but was not asleep yet would miss.
constexpr std::chrono::milliseconds kUnblockCheckInterval{20};

[[noreturn]] void throw_errno(const std::string& what, int error) {
  throw ShmError(ShmErrc::system_error, what + ": " + std::strerror(error), error);
}

// "/<name>" for shm_open; LN 2.9 prepends the slash itself, so a name that
// already has one is accepted too.
std::string object_path(const std::string& name) {
  const std::string bare = !name.empty() && name[0] == '/' ? name.substr(1) : name;
  if (bare.empty() || bare.find('/') != std::string::npos)
    throw_errno("shared-memory name '" + name + "' must be non-empty and contain no '/'", EINVAL);
  if (bare.size() > kMaxNameLength) throw_errno("shared-memory name '" + name + "'", ENAMETOOLONG);
  return "/" + bare;
}

std::uint64_t slot_stride(std::uint32_t element_size, std::uint32_t version) {
  const std::uint64_t bytes = kSlotHeaderSize + std::uint64_t{element_size} + (version >= 3 ? 4 : 0);
  return (bytes + 7) / 8 * 8;
}

void pause_briefly(int attempt) noexcept {
  if (attempt % 8 == 7) ::sched_yield();
}

}  // namespace

struct Segment::Header {
  char magic[7];
  std::uint8_t version;
  std::uint32_t element_size;
  std::uint32_t n_elements;
  std::byte lock_area[88];
  std::atomic<std::uint32_t> write_index;
  std::atomic<std::uint32_t> full;
  std::atomic<std::uint32_t> counter;
  std::uint32_t padding;
};

Segment::Header& Segment::header() const noexcept {
  static_assert(sizeof(Header) == kHeaderSize, "LN 2.9's header is 120 bytes");
  return *reinterpret_cast<Header*>(mapping_.data());
}

Segment::Segment(std::string name, UniqueFd fd, Mapping mapping) noexcept
    : name_(std::move(name)), fd_(std::move(fd)), mapping_(std::move(mapping)) {}

Segment::Segment(Segment&& other) noexcept
    : name_(std::move(other.name_)),
      fd_(std::move(other.fd_)),
      mapping_(std::move(other.mapping_)),
      element_size_(other.element_size_),
      n_elements_(other.n_elements_),
      version_(other.version_),
      stride_(other.stride_),
      last_seen_(other.last_seen_),
      unblocked_(other.unblocked_.load()) {}

Segment::~Segment() = default;

Segment Segment::create(const std::string& name, std::uint32_t element_size, std::uint32_t n_elements,
                        std::uint32_t version) {
  const std::string path = object_path(name);
  if (version > kNewestVersion)
    throw ShmError(ShmErrc::bad_version, "shared-memory version " + std::to_string(version) + " is newer than " +
                                             std::to_string(kNewestVersion));
  if (n_elements == 0) throw ShmError(ShmErrc::invalid_config, "a segment needs at least one element");
  const std::uint64_t stride = slot_stride(element_size, version);
  if (element_size > kMaxElementSize || n_elements > kMaxSegmentSize / stride)
    throw ShmError(ShmErrc::invalid_config, "segment of " + std::to_string(n_elements) + " elements of " +
                                                std::to_string(element_size) + " bytes is too large");
  const std::uint64_t size = kHeaderSize + n_elements * stride;

  // Replace, never resize in place: processes that still map an old segment
  // of this name keep it (ftruncate would pull pages from under them).
  if (::shm_unlink(path.c_str()) != 0 && errno != ENOENT) throw_errno("removing the old '" + path + "'", errno);
  UniqueFd fd(::shm_open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
  if (!fd.valid()) throw_errno("creating shared memory '" + path + "'", errno);
  if (::ftruncate(fd.get(), static_cast<off_t>(size)) != 0) {
    const int error = errno;
    ::shm_unlink(path.c_str());
    throw_errno("sizing shared memory '" + path + "'", error);
  }
  Mapping mapping = Mapping::map_shared(fd.get(), static_cast<std::size_t>(size));
  auto* header = reinterpret_cast<Header*>(mapping.data());
  header->version = static_cast<std::uint8_t>(version);
  header->element_size = element_size;
  header->n_elements = n_elements;
  std::memcpy(header->magic, kMagic, sizeof kMagic);  // the magic last: a complete header before it
  Segment segment(path, std::move(fd), std::move(mapping));
  segment.element_size_ = element_size;
  segment.n_elements_ = n_elements;
  segment.version_ = version;
  segment.stride_ = stride;
  return segment;
}

Segment Segment::open(const std::string& name) {
  const std::string path = object_path(name);
  UniqueFd fd(::shm_open(path.c_str(), O_RDWR | O_CLOEXEC, 0));
  if (!fd.valid()) throw_errno("opening shared memory '" + path + "'", errno);
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) throw_errno("reading the size of '" + path + "'", errno);
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < kHeaderSize)
    throw ShmError(ShmErrc::too_small, "shared memory '" + path + "' has " + std::to_string(size) +
                                           " bytes, less than the 120 of a header");
  Mapping mapping = Mapping::map_shared(fd.get(), static_cast<std::size_t>(size));
  // Read once, validated, never trusted again from shared memory.
  const Header& shared = *reinterpret_cast<const Header*>(mapping.data());
  const std::uint8_t version = shared.version;
  const std::uint32_t element_size = shared.element_size;
  const std::uint32_t n_elements = shared.n_elements;
  if (std::memcmp(shared.magic, kMagic, sizeof kMagic) != 0)
    throw ShmError(ShmErrc::bad_magic, "shared memory '" + path + "' is no LN segment (no LN_SHM magic)");
  if (version > kNewestVersion)
    throw ShmError(ShmErrc::bad_version, "shared memory '" + path + "' has version " + std::to_string(version) +
                                             ", newer than " + std::to_string(kNewestVersion));
  const std::uint64_t stride = slot_stride(element_size, version);
  if (n_elements == 0 || element_size > kMaxElementSize || n_elements > (size - kHeaderSize) / stride)
    throw ShmError(ShmErrc::too_small, "shared memory '" + path + "' has " + std::to_string(size) +
                                           " bytes, too few for its " + std::to_string(n_elements) + " elements of " +
                                           std::to_string(element_size) + " bytes");
  Segment segment(path, std::move(fd), std::move(mapping));
  segment.element_size_ = element_size;
  segment.n_elements_ = n_elements;
  segment.version_ = version;
  segment.stride_ = stride;
  segment.last_seen_ = segment.newest_counter();  // only packets written from now on
  return segment;
}

int Segment::unlink() noexcept { return ::shm_unlink(name_.c_str()) == 0 ? 0 : errno; }

std::byte* Segment::slot(std::uint32_t index) const noexcept {
  return mapping_.data() + kHeaderSize + (index % n_elements_) * stride_;
}

std::atomic<std::uint32_t>& Segment::leading_number(std::byte* slot) const noexcept {
  return *reinterpret_cast<std::atomic<std::uint32_t>*>(slot);
}

std::atomic<std::uint32_t>& Segment::trailing_number(std::byte* slot) const noexcept {
  return *reinterpret_cast<std::atomic<std::uint32_t>*>(slot + stride_ - 4);
}

// ---------------------------------------------------------------- writer

void* Segment::next_buffer() noexcept {
  std::byte* target = slot(header().write_index.load(std::memory_order_relaxed));
  leading_number(target).store(0, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  return target + kSlotHeaderSize;
}

bool Segment::write(double timestamp, const void* data, std::size_t size) noexcept {
  if (size > element_size_) return false;
  Header& head = header();
  const std::uint32_t index = head.write_index.load(std::memory_order_relaxed) % n_elements_;
  std::byte* target = slot(index);
  std::uint32_t number = head.counter.load(std::memory_order_relaxed) + 1;
  if (number == 0) number = 1;  // 0 marks "no packet" / "being written"
  leading_number(target).store(0, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  std::memcpy(target + 8, &timestamp, sizeof timestamp);
  if (data != nullptr && size > 0) std::memcpy(target + kSlotHeaderSize, data, size);
  if (version_ >= 3) trailing_number(target).store(number, std::memory_order_release);
  leading_number(target).store(number, std::memory_order_release);
  const std::uint32_t next = index + 1 == n_elements_ ? 0 : index + 1;
  if (next == 0) head.full.store(1, std::memory_order_relaxed);
  head.write_index.store(next, std::memory_order_release);
  head.counter.store(number, std::memory_order_release);
  futex_wake_all(&head.counter);
  return true;
}

// ---------------------------------------------------------------- reader

std::uint32_t Segment::newest_counter() const noexcept { return header().counter.load(std::memory_order_acquire); }

Segment::Copy Segment::copy_slot(std::uint32_t index, std::uint32_t expected, void* data, std::size_t capacity,
                                 double& timestamp) noexcept {
  std::byte* source = slot(index);
  const std::size_t bytes = std::min<std::size_t>(capacity, element_size_);
  for (int attempt = 0; attempt < kCopyAttempts; ++attempt, pause_briefly(attempt)) {
    const std::uint32_t leading = leading_number(source).load(std::memory_order_acquire);
    const std::uint32_t trailing = version_ >= 3 ? trailing_number(source).load(std::memory_order_acquire) : leading;
    if (leading == 0 || leading != trailing) continue;  // being written
    if (expected != 0 && leading != expected) return Copy::other_packet;
    double stamp;
    std::memcpy(&stamp, source + 8, sizeof stamp);
    if (bytes > 0) std::memcpy(data, source + kSlotHeaderSize, bytes);
    std::atomic_thread_fence(std::memory_order_acquire);
    if (leading_number(source).load(std::memory_order_relaxed) == leading &&
        (version_ < 3 || trailing_number(source).load(std::memory_order_relaxed) == trailing)) {
      timestamp = stamp;
      copied_number_ = leading;
      return Copy::ok;
    }
  }
  return Copy::torn;
}

bool Segment::copy_next(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter) noexcept {
  for (int attempt = 0; attempt < kCopyAttempts; ++attempt) {
    const std::uint32_t newest = newest_counter();
    // Packet numbers and slots advance together from 0, so packet k lies in
    // slot (k - 1) % n until the writer laps it; a reader that fell behind
    // by n or more continues with the oldest packet still in the ring.
    std::uint32_t wanted = last_seen_ + 1;
    if (newest - wanted >= n_elements_) wanted = newest - (n_elements_ - 1);
    switch (copy_slot((wanted - 1) % n_elements_, wanted, data, capacity, timestamp)) {
      case Copy::ok:
        counter = wanted;
        last_seen_ = wanted;
        return true;
      case Copy::other_packet:  // overwritten since: look again
        break;
      case Copy::torn:
        return false;
    }
  }
  // Lapped on every attempt (a writer much faster than us on a small ring):
  // take the newest packet as a whole.
  const std::uint32_t index = header().write_index.load(std::memory_order_acquire) + n_elements_ - 1;
  if (copy_slot(index % n_elements_, 0, data, capacity, timestamp) != Copy::ok) return false;
  counter = last_seen_ = copied_number_;
  return true;
}

bool Segment::wait(std::uint32_t seen, std::chrono::steady_clock::time_point deadline, bool forever,
                   ReadResult& why) noexcept {
  if (unblocked_.exchange(false)) {
    why = ReadResult::unblocked;
    return false;
  }
  const auto now = std::chrono::steady_clock::now();
  if (!forever && now >= deadline) {
    why = ReadResult::timeout;
    return false;
  }
  const std::chrono::nanoseconds slice =
      forever ? std::chrono::nanoseconds(kUnblockCheckInterval)
              : std::min<std::chrono::nanoseconds>(deadline - now, kUnblockCheckInterval);
  futex_wait(&header().counter, seen, slice);
  if (unblocked_.exchange(false)) {
    why = ReadResult::unblocked;
    return false;
  }
  return true;
}

ReadResult Segment::read_next(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter,
                              std::chrono::nanoseconds timeout) noexcept {
  const bool forever = timeout < std::chrono::nanoseconds::zero();
  const auto deadline =
      forever ? std::chrono::steady_clock::time_point::max() : std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const std::uint32_t newest = newest_counter();
    // A torn copy means the writer is busy with that very slot: wait for its commit.
    if (newest != last_seen_ && copy_next(data, capacity, timestamp, counter)) return ReadResult::packet;
    if (timeout == std::chrono::nanoseconds::zero()) return ReadResult::nothing_new;
    ReadResult why = ReadResult::timeout;
    if (!wait(newest, deadline, forever, why)) return why;
  }
}

ReadResult Segment::read_last(void* data, std::size_t capacity, double& timestamp, std::uint32_t& counter) noexcept {
  for (int round = 0; round < kCopyAttempts; ++round) {
    const std::uint32_t newest = newest_counter();
    if (newest == 0) {
      std::memset(data, 0, std::min<std::size_t>(capacity, element_size_));
      timestamp = 0;
      counter = last_seen_ = 0;
      return ReadResult::packet;
    }
    if (copy_slot((newest - 1) % n_elements_, newest, data, capacity, timestamp) == Copy::ok) {
      counter = last_seen_ = newest;
      return ReadResult::packet;
    }
    ::sched_yield();
  }
  return ReadResult::torn;
}

ReadResult Segment::wait_for_packet(std::uint32_t& counter, std::chrono::nanoseconds timeout) noexcept {
  const bool forever = timeout < std::chrono::nanoseconds::zero();
  const auto deadline =
      forever ? std::chrono::steady_clock::time_point::max() : std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const std::uint32_t newest = newest_counter();
    if (newest != counter) {
      counter = newest;
      last_seen_ = newest;
      return ReadResult::packet;
    }
    ReadResult why = ReadResult::timeout;
    if (!wait(newest, deadline, forever, why)) return why;
  }
}

void Segment::unblock() noexcept {
  unblocked_.store(true);
  futex_wake_all(&header().counter);
}

}  // namespace ln::transport::ln29
