// The recording of one topic of a logger: a ring of the newest `capacity`
// samples (protocol/logger_samples.hpp), oldest overwritten first, as LN 2.9's
// log_size promises. The memory is reserved, not touched, up front: a large
// log costs only what its samples fill.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "protocol/logger_samples.hpp"

namespace ln::manager {

/// Bytes of memory the system could give the manager now (MemAvailable).
std::uint64_t available_memory();

/// Refuses (RequestError LNE_NO_MEM, text naming `what`) `samples` samples of
/// `sample_size` bytes that overflow or do not fit available_memory().
void check_log_fits(std::uint64_t samples, std::uint64_t sample_size, const std::string& what);

class SampleLog {
 public:
  /// Throws RequestError (LNE_NO_MEM) when the ring cannot be reserved.
  static std::shared_ptr<SampleLog> create(std::uint64_t capacity, std::uint32_t sample_size);
  ~SampleLog();
  SampleLog(const SampleLog&) = delete;
  SampleLog& operator=(const SampleLog&) = delete;

  /// Stores one sample: the header and `size` bytes of packet (cut or
  /// zero-padded to the sample size). Thread-safe, as are the readers below.
  void append(const protocol::logger::SampleHeader& header, const void* packet, std::size_t size) noexcept;

  std::uint64_t capacity() const { return capacity_; }
  std::uint32_t sample_size() const { return sample_size_; }
  std::uint64_t count() const;
  /// Bytes [offset, offset + size) of the samples, oldest first; size must
  /// lie within count() * sample_size().
  void copy_out(std::uint64_t offset, void* out, std::size_t size) const;
  /// Sample `index` (0 = oldest).
  protocol::logger::SampleHeader header(std::uint64_t index) const;
  /// A log with the same samples that no later append() changes.
  std::shared_ptr<SampleLog> snapshot() const;

 private:
  SampleLog(std::uint64_t capacity, std::uint32_t sample_size, unsigned char* memory, std::size_t bytes);
  unsigned char* slot(std::uint64_t index) const;  // index-th oldest

  const std::uint64_t capacity_;
  const std::uint32_t sample_size_;
  unsigned char* const memory_;
  const std::size_t bytes_;
  mutable std::mutex mutex_;
  std::uint64_t count_ = 0;  // samples held, <= capacity_
  std::uint64_t next_ = 0;   // slot of the next append
};

}  // namespace ln::manager
