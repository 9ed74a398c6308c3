// MCAP files that ROS 2 tools read: a chunked, indexed writer.
//
// What it writes (the MCAP format, https://mcap.dev/spec, profile "ros2"):
//
//   magic, Header,
//   Chunk, MessageIndex per channel of that chunk, Chunk, MessageIndex..., (the data section)
//   DataEnd (CRC of the data section),
//   Schema..., Channel..., Statistics, ChunkIndex... (the summary), SummaryOffset..., Footer, magic.
//
// Chunks are not compressed (this machine has no zstd/lz4 library for C++;
// a chunk is written with one write()). A Schema or Channel record goes into
// the chunk of its first message, so every chunk on disk is self-contained in
// order: a file cut off (SIGKILL, power loss, full disk) stays readable
// sequentially up to its last complete chunk.
//
// Producer and disk are decoupled: a closed chunk goes to an I/O thread through
// a queue bounded in bytes; the producer waits only when the queue is full.
// An I/O error (full disk, file size limit) is sticky: the file is cut back to
// its last complete chunk, the producer's calls fail from then on with the
// error, and close() still tries to write the summary (which fails too when
// the disk has no room at all, leaving the file readable sequentially).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace ln_bag {

/// Any failure of a recording or of a file: the message names the file and
/// what is wrong.
class BagError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct WriterOptions {
  /// A chunk is closed when its records reach this many bytes (a bigger
  /// message gets a chunk of its own).
  std::size_t chunk_size = 1u << 20;
  /// Closed chunks waiting for the disk, at most this many bytes (at least
  /// one chunk); beyond it the producer waits.
  std::size_t queue_bytes = 64u << 20;
  std::string profile = "ros2";
  std::string library = "ln_core ln_bag";
};

/// What has reached the file (chunks written by the I/O thread).
struct WrittenStats {
  std::uint64_t messages = 0;
  std::uint64_t chunks = 0;
  std::uint64_t file_bytes = 0;  ///< the size of the file so far
  double write_seconds = 0;      ///< time the I/O thread spent writing (and checksumming) chunks
};

class McapWriter {
 public:
  /// Creates (truncates) `path` and writes magic and Header. Throws BagError.
  McapWriter(std::string path, WriterOptions options = {});
  /// close()s, ignoring errors (call close() to see them).
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// Ids start at 1 (0 means "no schema" to MCAP readers).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata);

  /// Room for the data of one message of at most `max_size` bytes in the
  /// current chunk, valid until commit_message() or the next reserve. Throws
  /// BagError after an I/O error.
  std::uint8_t* reserve_message(std::size_t max_size);
  /// Adds the message whose `size` bytes were written into the last reserve.
  void commit_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                      std::uint64_t publish_time, std::size_t size);
  /// reserve_message() + copy + commit_message().
  void add_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
                   const void* data, std::size_t size);

  /// Hands the current chunk (if it holds anything) to the I/O thread.
  void flush_chunk();
  /// Nanoseconds (log time) of the current chunk's first message, 0 if empty.
  std::uint64_t chunk_start_time() const;

  /// Flushes, waits for the disk, writes DataEnd, summary and footer, closes
  /// the file. Throws BagError on any I/O error (also an earlier one); the
  /// file then holds every chunk written before it. Idempotent.
  void close();

  /// Messages and bytes committed by the producer (not necessarily on disk).
  std::uint64_t committed_messages() const;
  std::uint64_t committed_bytes() const;
  WrittenStats written() const;
  /// The first I/O error ("" while there is none).
  std::string error() const;
  const std::string& path() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ln_bag
