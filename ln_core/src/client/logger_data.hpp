// Logger contents on the client side (ln_logger_data): the recorded topics
// as ln.h's logger_topic structs, downloaded from the manager or loaded from
// a file, and the file format of ln_logger_data_save/load.
//
// The file format is LN 2.9's, so files interchange both ways (checked by
// tests/ln29_behaviour). Host byte order:
//   u16 0x0420 (byte order mark), u32 version (3), u32 n + n bytes of
//   comment, u32 topic count, then per topic:
//     u32 n + name, u64 log_size, u32 divisor, u32 n_samples, u32 sample_size,
//     u32 n + md_name, u32 n + md (LN's Python dict notation), then
//     n_samples * sample_size bytes of samples (protocol/logger_samples.hpp)
// Version 2 files (LN before 64-bit log sizes) differ only in a u32 log_size
// and are read as well. Loading checks every length against the file, so a
// damaged file is refused with the reason, never read beyond its end.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "client/c_api.hpp"

namespace ln::clientlib {

class LoggerData {
 public:
  struct Topic {
    std::string name;
    std::uint64_t log_size = 0;
    std::uint32_t divisor = 1;
    std::uint32_t n_samples = 0;
    std::uint32_t sample_size = 0;
    std::string md_name;
    std::string md;
    std::vector<unsigned char> samples;  ///< n_samples * sample_size bytes
  };

  /// Throws Failure (LNE_INVALID_PARAMETER) when a topic's samples do not
  /// match its n_samples and sample_size.
  explicit LoggerData(std::vector<Topic> topics);
  ~LoggerData();
  // The logger_topic structs point into the topics: never copied or moved.
  LoggerData(const LoggerData&) = delete;
  LoggerData& operator=(const LoggerData&) = delete;

  /// True while `handle` is a LoggerData that has not been destroyed.
  static bool alive(const void* handle);
  /// True for data made by load() or copy() (the caller frees it), false
  /// for a download (its logger does).
  bool loaded() const { return loaded_; }

  std::size_t size() const { return topics_.size(); }
  const Topic& contents(std::size_t index) const { return topics_.at(index); }
  /// The ln.h view of topic `index`, or nullptr when out of range.
  logger_topic* topic(std::size_t index);

  /// Writes the file (version 3). Throws Failure (LNE_CHECK_ERRNO with the
  /// system's reason when the file cannot be written).
  void save(const std::string& filename) const;
  /// Reads a file. Throws Failure: LNE_CHECK_ERRNO (cannot read),
  /// LNE_WRONG_BYTE_ORDER (written on a host of the other byte order),
  /// LNE_LOG_FILE_TOO_NEW (a later version), LNE_INVALID_PARAMETER (not
  /// logger data, or damaged: the text says where).
  static std::unique_ptr<LoggerData> load(const std::string& filename);
  /// The same contents, owned by the caller (loaded() is true).
  std::unique_ptr<LoggerData> copy() const;

 private:
  std::vector<Topic> topics_;
  std::vector<logger_topic> views_;
  bool loaded_ = false;
};

}  // namespace ln::clientlib
