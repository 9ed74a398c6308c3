#include "manager/sample_log.hpp"

#include <sys/mman.h>

#include <algorithm>
#include <fstream>
#include <limits>

#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

std::string mebibytes(std::uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

}  // namespace

std::uint64_t available_memory() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  return std::numeric_limits<std::uint64_t>::max();  // no /proc: the reservation itself decides
}

void check_log_fits(std::uint64_t samples, std::uint64_t sample_size, const std::string& what) {
  const std::uint64_t limit = std::min<std::uint64_t>(available_memory(), std::numeric_limits<std::size_t>::max());
  if (sample_size != 0 && samples > limit / sample_size)
    throw RequestError(LNE_NO_MEM, what + ": " + std::to_string(samples) + " samples of " +
                                       std::to_string(sample_size) + " bytes do not fit into the " + mebibytes(limit) +
                                       " of memory available to the manager");
}

std::shared_ptr<SampleLog> SampleLog::create(std::uint64_t capacity, std::uint32_t sample_size) {
  const std::string what = "a log of " + std::to_string(capacity) + " samples";
  if (capacity == 0 || sample_size < protocol::logger::kSampleHeaderSize)
    throw RequestError(LNE_INVALID_PARAMETER, what + " of " + std::to_string(sample_size) + " bytes is impossible");
  check_log_fits(capacity, sample_size, what);
  const std::size_t bytes = static_cast<std::size_t>(capacity) * sample_size;
  // Reserved without committing: pages are taken as samples arrive.
  void* memory = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
  if (memory == MAP_FAILED)
    throw RequestError(LNE_NO_MEM, what + " (" + mebibytes(bytes) + "): the manager cannot reserve that much memory");
  return std::shared_ptr<SampleLog>(new SampleLog(capacity, sample_size, static_cast<unsigned char*>(memory), bytes));
}

SampleLog::SampleLog(std::uint64_t capacity, std::uint32_t sample_size, unsigned char* memory, std::size_t bytes)
    : capacity_(capacity), sample_size_(sample_size), memory_(memory), bytes_(bytes) {}

SampleLog::~SampleLog() { ::munmap(memory_, bytes_); }

void SampleLog::append(const protocol::logger::SampleHeader& header, const void* packet, std::size_t size) noexcept {
  std::lock_guard<std::mutex> lock(mutex_);
  unsigned char* sample = memory_ + next_ * sample_size_;
  protocol::logger::write_sample_header(sample, header);
  const std::size_t room = sample_size_ - protocol::logger::kSampleHeaderSize;
  const std::size_t copied = std::min(size, room);
  if (copied > 0) std::memcpy(sample + protocol::logger::kSampleHeaderSize, packet, copied);
  if (copied < room) std::memset(sample + protocol::logger::kSampleHeaderSize + copied, 0, room - copied);
  next_ = next_ + 1 == capacity_ ? 0 : next_ + 1;
  count_ = std::min(count_ + 1, capacity_);
}

std::uint64_t SampleLog::count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

unsigned char* SampleLog::slot(std::uint64_t index) const {
  const std::uint64_t oldest = count_ < capacity_ ? 0 : next_;
  const std::uint64_t at = oldest + index;
  return memory_ + (at >= capacity_ ? at - capacity_ : at) * sample_size_;
}

void SampleLog::copy_out(std::uint64_t offset, void* out, std::size_t size) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto* target = static_cast<unsigned char*>(out);
  while (size > 0) {
    const std::uint64_t index = offset / sample_size_;
    const std::uint64_t within = offset % sample_size_;
    // Samples up to the end of the memory block lie back to back.
    const unsigned char* from = slot(index) + within;
    const std::size_t contiguous = static_cast<std::size_t>(memory_ + bytes_ - from);
    const std::size_t n = std::min(size, contiguous);
    std::memcpy(target, from, n);
    target += n;
    offset += n;
    size -= n;
  }
}

protocol::logger::SampleHeader SampleLog::header(std::uint64_t index) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return protocol::logger::read_sample_header(slot(index));
}

std::shared_ptr<SampleLog> SampleLog::snapshot() const {
  const std::uint64_t held = count();
  std::shared_ptr<SampleLog> copy = create(std::max<std::uint64_t>(held, 1), sample_size_);
  std::lock_guard<std::mutex> lock(mutex_);
  // Samples may have arrived since count(): take the newest `held`.
  const std::uint64_t skip = count_ - held;
  for (std::uint64_t i = 0; i < held; ++i) std::memcpy(copy->memory_ + i * sample_size_, slot(skip + i), sample_size_);
  copy->count_ = held;
  copy->next_ = held == copy->capacity_ ? 0 : held;
  return copy;
}

}  // namespace ln::manager
