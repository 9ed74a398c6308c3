// A sample of a topic logger as LN 2.9 lays it out: in downloads
// (logger_download_data), in ln.h's logger_sample, in logger data files and
// in raw files. Host byte order, packed:
//   f64 log_ts          when the recorder copied the packet (wall clock)
//   f64 src_ts          the publisher's timestamp of the packet
//   u32 packet_counter  the publisher's packet counter (low 32 bits)
//   the packet (message size bytes; absent when the logger records only
//   timestamps)
// so a topic's sample size is 20 + message size, or 20 with only_ts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace ln::protocol::logger {

inline constexpr std::size_t kSampleHeaderSize = 8 + 8 + 4;
/// Largest data of one logger_download_data answer: well below the
/// manager's output queue limit, so a download never stalls the manager.
inline constexpr std::size_t kDownloadChunk = 4u << 20;

struct SampleHeader {
  double log_ts = 0;
  double src_ts = 0;
  std::uint32_t packet_counter = 0;
};

inline void write_sample_header(unsigned char* out, const SampleHeader& header) {
  std::memcpy(out, &header.log_ts, 8);
  std::memcpy(out + 8, &header.src_ts, 8);
  std::memcpy(out + 16, &header.packet_counter, 4);
}

inline SampleHeader read_sample_header(const unsigned char* in) {
  SampleHeader header;
  std::memcpy(&header.log_ts, in, 8);
  std::memcpy(&header.src_ts, in + 8, 8);
  std::memcpy(&header.packet_counter, in + 16, 4);
  return header;
}

}  // namespace ln::protocol::logger
