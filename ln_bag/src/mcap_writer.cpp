#include "ln_bag/mcap_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <thread>

#include "byte_buffer.hpp"
#include "crc32.hpp"

namespace ln_bag {
namespace {

constexpr char magic[] = "\x89MCAP0\r\n";
constexpr std::size_t magic_size = 8;

enum Opcode : std::uint8_t {
  op_header = 0x01,
  op_footer = 0x02,
  op_schema = 0x03,
  op_channel = 0x04,
  op_message = 0x05,
  op_chunk = 0x06,
  op_message_index = 0x07,
  op_chunk_index = 0x08,
  op_statistics = 0x0B,
  op_summary_offset = 0x0E,
  op_data_end = 0x0F,
};

// opcode + length + start, end, uncompressed size, crc, compression "", records length
constexpr std::size_t chunk_header_size = 1 + 8 + 8 + 8 + 8 + 4 + 4 + 8;
constexpr std::size_t chunk_crc_at = 1 + 8 + 8 + 8 + 8;
// opcode + length + channel, sequence, log time, publish time
constexpr std::size_t message_header_size = 1 + 8 + 2 + 4 + 8 + 8;

// A record whose length is filled in by finish().
class Record {
 public:
  Record(ByteBuffer& out, std::uint8_t opcode) : out_(out) {
    out_.u8(opcode);
    length_at_ = out_.size();
    out_.u64(0);
  }
  void finish() { store_le<std::uint64_t>(out_.data() + length_at_, out_.size() - length_at_ - 8); }

 private:
  ByteBuffer& out_;
  std::size_t length_at_;
};

void put_string_map(ByteBuffer& out, const std::map<std::string, std::string>& map) {
  std::size_t bytes = 0;
  for (const auto& [key, value] : map) bytes += 8 + key.size() + value.size();
  out.u32(static_cast<std::uint32_t>(bytes));
  for (const auto& [key, value] : map) {
    out.str(key);
    out.str(value);
  }
}

struct SchemaInfo {
  std::uint16_t id;
  std::string name, encoding, data;
};
struct ChannelInfo {
  std::uint16_t id, schema_id;
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};
struct IndexEntry {
  std::uint64_t log_time, offset;
};

void put_schema(ByteBuffer& out, const SchemaInfo& s) {
  Record r(out, op_schema);
  out.u16(s.id);
  out.str(s.name);
  out.str(s.encoding);
  out.str(s.data);
  r.finish();
}

void put_channel(ByteBuffer& out, const ChannelInfo& c) {
  Record r(out, op_channel);
  out.u16(c.id);
  out.u16(c.schema_id);
  out.str(c.topic);
  out.str(c.message_encoding);
  put_string_map(out, c.metadata);
  r.finish();
}

// A closed chunk with its message indexes, as it goes to the file.
struct ChunkBlob {
  ByteBuffer bytes;
  std::size_t chunk_record_size = 0;
  std::size_t records_size = 0;
  std::uint64_t start_time = 0, end_time = 0, messages = 0;
  std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;  // channel -> offset in `bytes`
  std::vector<std::pair<std::uint16_t, std::uint64_t>> channel_counts;
};

struct ChunkIndexInfo {
  std::uint64_t start_time, end_time, offset, chunk_length, index_length, records_size;
  std::vector<std::pair<std::uint16_t, std::uint64_t>> index_offsets;  // channel -> file offset
};

std::string errno_text(int error) { return std::strerror(error); }

}  // namespace

struct McapWriter::Impl {
  std::string path;
  WriterOptions options;
  int fd = -1;
  bool closed = false;

  // ---- producer side
  std::vector<SchemaInfo> schemas;
  std::vector<ChannelInfo> channels;
  ByteBuffer chunk;  // chunk_header_size reserved bytes, then records
  bool chunk_open = false;
  std::uint64_t chunk_start = 0, chunk_end = 0, chunk_messages = 0;
  std::vector<std::vector<IndexEntry>> chunk_index;  // by channel id
  std::vector<std::uint16_t> chunk_channels;         // channels with messages in this chunk
  std::atomic<std::uint64_t> committed_messages{0}, committed_bytes{0};

  // ---- shared with the I/O thread
  mutable std::mutex mutex;
  std::condition_variable changed;
  std::deque<ChunkBlob> queue;
  std::size_t queued_bytes = 0;
  std::vector<ByteBuffer> spare;  // buffers of written chunks, for reuse
  bool stopping = false;
  std::string error;
  WrittenStats written;

  // ---- I/O thread (read by close() after join)
  std::uint64_t file_offset = 0;  // end of the last complete record group on disk
  std::uint32_t data_crc = 0;
  std::vector<ChunkIndexInfo> chunk_indexes;
  std::map<std::uint16_t, std::uint64_t> channel_counts;
  std::uint64_t start_time = 0, end_time = 0;
  std::thread io;

  void fail_locked(const std::string& what) {
    if (error.empty()) error = what;
  }

  void check() const {
    std::lock_guard<std::mutex> lock(mutex);
    if (!error.empty()) throw BagError(error);
  }

  // Writes `size` bytes at the end of the file; false (and errno) on failure.
  bool write_all(const std::uint8_t* data, std::size_t size) {
    while (size > 0) {
      const ssize_t n = ::write(fd, data, size);
      if (n < 0) {
        if (errno == EINTR) continue;
        return false;
      }
      if (n == 0) {
        errno = EIO;
        return false;
      }
      data += n;
      size -= static_cast<std::size_t>(n);
    }
    return true;
  }

  // After a failed write: the file ends with its last complete chunk again.
  void cut_back() {
    if (::ftruncate(fd, static_cast<off_t>(file_offset)) == 0) ::lseek(fd, static_cast<off_t>(file_offset), SEEK_SET);
  }

  std::string write_error(int e) const { return "writing " + path + ": " + errno_text(e); }

  void io_loop() {
    for (;;) {
      ChunkBlob blob;
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return stopping || !queue.empty(); });
        if (queue.empty()) return;
        blob = std::move(queue.front());
        queue.pop_front();
        queued_bytes -= blob.bytes.size();
        changed.notify_all();
        if (!error.empty()) continue;  // after an error nothing more reaches the file
      }
      const auto began = std::chrono::steady_clock::now();
      std::uint8_t* bytes = blob.bytes.data();
      const std::uint32_t records_crc = crc32(0, bytes + chunk_header_size, blob.records_size);
      store_le<std::uint32_t>(bytes + chunk_crc_at, records_crc);
      if (!write_all(bytes, blob.bytes.size())) {
        const int e = errno;
        cut_back();
        std::lock_guard<std::mutex> lock(mutex);
        fail_locked(write_error(e));
        continue;
      }
      // The data section's CRC from the pieces: the records are not checksummed twice.
      const std::size_t tail = blob.bytes.size() - blob.chunk_record_size;
      std::uint32_t blob_crc = crc32(0, bytes, chunk_header_size);
      blob_crc = crc32_combine(blob_crc, records_crc, blob.records_size);
      blob_crc = crc32_combine(blob_crc, crc32(0, bytes + blob.chunk_record_size, tail), tail);
      data_crc = crc32_combine(data_crc, blob_crc, blob.bytes.size());
      ChunkIndexInfo index{blob.start_time,
                           blob.end_time,
                           file_offset,
                           blob.chunk_record_size,
                           blob.bytes.size() - blob.chunk_record_size,
                           blob.records_size,
                           {}};
      for (const auto& [channel, offset] : blob.index_offsets)
        index.index_offsets.emplace_back(channel, file_offset + offset);
      chunk_indexes.push_back(std::move(index));
      for (const auto& [channel, count] : blob.channel_counts) channel_counts[channel] += count;
      if (blob.messages) {
        start_time = written.messages ? std::min(start_time, blob.start_time) : blob.start_time;
        end_time = std::max(end_time, blob.end_time);
      }
      file_offset += blob.bytes.size();
      const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
      std::lock_guard<std::mutex> lock(mutex);
      written.messages += blob.messages;
      written.chunks += 1;
      written.file_bytes = file_offset;
      written.write_seconds += took;
      if (spare.size() < 4) {
        blob.bytes.clear();
        spare.push_back(std::move(blob.bytes));
      }
    }
  }

  void open_chunk() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!spare.empty()) {
        chunk = std::move(spare.back());
        spare.pop_back();
      }
    }
    chunk.clear();
    chunk.reserve(options.chunk_size + chunk_header_size + 4096);
    chunk.extend(chunk_header_size);
    chunk_open = true;
    chunk_start = chunk_end = chunk_messages = 0;
  }

  std::size_t records_size() const { return chunk_open ? chunk.size() - chunk_header_size : 0; }

  void seal_and_queue() {
    if (!chunk_open) return;
    ChunkBlob blob;
    blob.records_size = records_size();
    blob.start_time = chunk_start;
    blob.end_time = chunk_end;
    blob.messages = chunk_messages;
    std::uint8_t* h = chunk.data();
    h[0] = op_chunk;
    store_le<std::uint64_t>(h + 1, chunk_header_size - 9 + blob.records_size);
    store_le<std::uint64_t>(h + 9, chunk_start);
    store_le<std::uint64_t>(h + 17, chunk_end);
    store_le<std::uint64_t>(h + 25, blob.records_size);
    store_le<std::uint32_t>(h + chunk_crc_at, 0);  // the I/O thread computes it
    store_le<std::uint32_t>(h + 37, 0);            // compression: "" (none)
    store_le<std::uint64_t>(h + 41, blob.records_size);
    blob.chunk_record_size = chunk.size();
    std::sort(chunk_channels.begin(), chunk_channels.end());
    for (std::uint16_t channel : chunk_channels) {
      std::vector<IndexEntry>& entries = chunk_index[channel];
      blob.index_offsets.emplace_back(channel, chunk.size());
      blob.channel_counts.emplace_back(channel, entries.size());
      Record r(chunk, op_message_index);
      chunk.u16(channel);
      chunk.u32(static_cast<std::uint32_t>(entries.size() * 16));
      chunk.put(entries.data(), entries.size() * 16);
      r.finish();
      entries.clear();
    }
    chunk_channels.clear();
    blob.bytes = std::move(chunk);
    chunk_open = false;

    std::unique_lock<std::mutex> lock(mutex);
    const std::size_t size = blob.bytes.size();
    changed.wait(lock, [&] { return queue.empty() || queued_bytes + size <= options.queue_bytes || !error.empty(); });
    if (!error.empty()) throw BagError(error);
    queued_bytes += size;
    queue.push_back(std::move(blob));
    changed.notify_all();
  }

  // The summary section after DataEnd; returns the bytes from DataEnd to the closing magic.
  ByteBuffer summary() const {
    ByteBuffer out;
    {
      Record r(out, op_data_end);
      out.u32(data_crc);
      r.finish();
    }
    const std::uint64_t summary_start = file_offset + out.size();
    struct Group {
      std::uint8_t opcode;
      std::uint64_t start, length;
    };
    std::vector<Group> groups;
    auto group = [&](std::uint8_t opcode, auto&& put) {
      const std::size_t before = out.size();
      put();
      if (out.size() > before) groups.push_back({opcode, file_offset + before, out.size() - before});
    };
    group(op_schema, [&] {
      for (const auto& s : schemas) put_schema(out, s);
    });
    group(op_channel, [&] {
      for (const auto& c : channels) put_channel(out, c);
    });
    group(op_statistics, [&] {
      Record r(out, op_statistics);
      out.u64(written.messages);
      out.u16(static_cast<std::uint16_t>(schemas.size()));
      out.u32(static_cast<std::uint32_t>(channels.size()));
      out.u32(0);  // attachments
      out.u32(0);  // metadata
      out.u32(static_cast<std::uint32_t>(chunk_indexes.size()));
      out.u64(start_time);
      out.u64(end_time);
      out.u32(static_cast<std::uint32_t>(channels.size() * 10));
      for (const auto& c : channels) {
        out.u16(c.id);
        const auto it = channel_counts.find(c.id);
        out.u64(it == channel_counts.end() ? 0 : it->second);
      }
      r.finish();
    });
    group(op_chunk_index, [&] {
      for (const auto& c : chunk_indexes) {
        Record r(out, op_chunk_index);
        out.u64(c.start_time);
        out.u64(c.end_time);
        out.u64(c.offset);
        out.u64(c.chunk_length);
        out.u32(static_cast<std::uint32_t>(c.index_offsets.size() * 10));
        for (const auto& [channel, offset] : c.index_offsets) {
          out.u16(channel);
          out.u64(offset);
        }
        out.u64(c.index_length);
        out.str("");
        out.u64(c.records_size);  // compressed size: no compression
        out.u64(c.records_size);
        r.finish();
      }
    });
    const std::uint64_t summary_offset_start = file_offset + out.size();
    for (const Group& g : groups) {
      Record r(out, op_summary_offset);
      out.u8(g.opcode);
      out.u64(g.start);
      out.u64(g.length);
      r.finish();
    }
    out.u8(op_footer);
    out.u64(8 + 8 + 4);
    out.u64(summary_start);  // never empty: Statistics is always there
    out.u64(summary_offset_start);
    const std::size_t summary_from = summary_start - file_offset;
    out.u32(crc32(0, out.data() + summary_from, out.size() - summary_from));
    out.put(magic, magic_size);
    return out;
  }
};

McapWriter::McapWriter(std::string path, WriterOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.path = std::move(path);
  m.options = std::move(options);
  if (m.options.chunk_size == 0) m.options.chunk_size = 1;
  m.fd = ::open(m.path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (m.fd < 0) throw BagError("cannot create " + m.path + ": " + errno_text(errno));
  ByteBuffer head;
  head.put(magic, magic_size);
  Record r(head, op_header);
  head.str(m.options.profile);
  head.str(m.options.library);
  r.finish();
  if (!m.write_all(head.data(), head.size())) {
    const int e = errno;
    ::close(m.fd);
    m.fd = -1;
    throw BagError(m.write_error(e));
  }
  m.file_offset = head.size();
  m.data_crc = crc32(0, head.data(), head.size());
  m.written.file_bytes = m.file_offset;
  m.io = std::thread([&m] { m.io_loop(); });
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (...) {
  }
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  Impl& m = *impl_;
  m.check();
  if (m.schemas.size() >= 0xFFFE) throw BagError(m.path + ": too many schemas");
  SchemaInfo s{static_cast<std::uint16_t>(m.schemas.size() + 1), name, encoding, data};
  if (!m.chunk_open) m.open_chunk();
  put_schema(m.chunk, s);
  m.schemas.push_back(std::move(s));
  return m.schemas.back().id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  Impl& m = *impl_;
  m.check();
  if (schema_id > m.schemas.size()) throw BagError(m.path + ": channel '" + topic + "' uses an unknown schema");
  if (m.channels.size() >= 0xFFFE) throw BagError(m.path + ": too many channels");
  ChannelInfo c{static_cast<std::uint16_t>(m.channels.size() + 1), schema_id, topic, message_encoding, metadata};
  if (!m.chunk_open) m.open_chunk();
  put_channel(m.chunk, c);
  m.channels.push_back(std::move(c));
  m.chunk_index.resize(m.channels.size() + 1);
  return m.channels.back().id;
}

std::uint8_t* McapWriter::reserve_message(std::size_t max_size) {
  Impl& m = *impl_;
  if (m.closed) throw BagError(m.path + ": already closed");
  m.check();
  if (m.chunk_messages && m.records_size() + message_header_size + max_size > m.options.chunk_size) m.seal_and_queue();
  if (!m.chunk_open) m.open_chunk();
  m.chunk.reserve(m.chunk.size() + message_header_size + max_size);
  return m.chunk.data() + m.chunk.size() + message_header_size;
}

void McapWriter::commit_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                                std::uint64_t publish_time, std::size_t size) {
  Impl& m = *impl_;
  if (channel_id == 0 || channel_id > m.channels.size()) throw BagError(m.path + ": message on an unknown channel");
  const std::uint64_t offset = m.records_size();
  std::uint8_t* h = m.chunk.extend(message_header_size + size);
  h[0] = op_message;
  store_le<std::uint64_t>(h + 1, message_header_size - 9 + size);
  store_le<std::uint16_t>(h + 9, channel_id);
  store_le<std::uint32_t>(h + 11, sequence);
  store_le<std::uint64_t>(h + 15, log_time);
  store_le<std::uint64_t>(h + 23, publish_time);
  std::vector<IndexEntry>& entries = m.chunk_index[channel_id];
  if (entries.empty()) m.chunk_channels.push_back(channel_id);
  entries.push_back({log_time, offset});
  if (m.chunk_messages == 0) {
    m.chunk_start = m.chunk_end = log_time;
  } else {
    m.chunk_start = std::min(m.chunk_start, log_time);
    m.chunk_end = std::max(m.chunk_end, log_time);
  }
  ++m.chunk_messages;
  m.committed_messages.fetch_add(1, std::memory_order_relaxed);
  m.committed_bytes.fetch_add(size, std::memory_order_relaxed);
  if (m.records_size() >= m.options.chunk_size) m.seal_and_queue();
}

void McapWriter::add_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                             std::uint64_t publish_time, const void* data, std::size_t size) {
  std::uint8_t* at = reserve_message(size);
  if (size) std::memcpy(at, data, size);
  commit_message(channel_id, sequence, log_time, publish_time, size);
}

void McapWriter::flush_chunk() {
  Impl& m = *impl_;
  if (m.chunk_open && m.records_size() > 0) m.seal_and_queue();
}

std::uint64_t McapWriter::chunk_start_time() const {
  const Impl& m = *impl_;
  return m.chunk_messages ? m.chunk_start : 0;
}

void McapWriter::close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.closed = true;
  std::string failure;
  try {
    flush_chunk();
  } catch (const BagError& e) {
    failure = e.what();
  }
  {
    std::lock_guard<std::mutex> lock(m.mutex);
    m.stopping = true;
    m.changed.notify_all();
  }
  m.io.join();
  if (failure.empty()) failure = m.error;
  const ByteBuffer tail = m.summary();
  bool indexed = m.write_all(tail.data(), tail.size());
  if (!indexed) {
    const int e = errno;
    m.cut_back();
    if (failure.empty()) failure = m.write_error(e);
  } else {
    m.written.file_bytes = m.file_offset + tail.size();
  }
  if (::close(m.fd) != 0 && failure.empty()) failure = "closing " + m.path + ": " + errno_text(errno);
  m.fd = -1;
  if (!failure.empty()) {
    throw BagError(failure + " (" + m.path + " keeps the " + std::to_string(m.written.messages) +
                   " messages written before; " +
                   (indexed ? "it is complete and indexed)"
                            : "it has no index: tools read it sequentially, 'ln bag convert' rewrites it indexed)"));
  }
}

std::uint64_t McapWriter::committed_messages() const {
  return impl_->committed_messages.load(std::memory_order_relaxed);
}
std::uint64_t McapWriter::committed_bytes() const { return impl_->committed_bytes.load(std::memory_order_relaxed); }

WrittenStats McapWriter::written() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->written;
}

std::string McapWriter::error() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->error;
}

const std::string& McapWriter::path() const { return impl_->path; }

}  // namespace ln_bag
