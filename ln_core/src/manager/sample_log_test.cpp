#include "manager/sample_log.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

using protocol::logger::SampleHeader;

void append(SampleLog& log, std::uint32_t counter) {
  SampleHeader header{counter + 0.5, counter + 0.25, counter};
  const std::uint32_t payload[2] = {counter * 10, counter * 10 + 1};
  log.append(header, payload, sizeof payload);
}

std::vector<std::uint32_t> counters(const SampleLog& log) {
  std::vector<std::uint32_t> out;
  for (std::uint64_t i = 0; i < log.count(); ++i) out.push_back(log.header(i).packet_counter);
  return out;
}

TEST(SampleLog, KeepsTheNewestSamplesOldestFirst) {
  auto log = SampleLog::create(3, 28);
  EXPECT_EQ(log->count(), 0u);
  for (std::uint32_t i = 1; i <= 2; ++i) append(*log, i);
  EXPECT_EQ(counters(*log), (std::vector<std::uint32_t>{1, 2}));
  for (std::uint32_t i = 3; i <= 7; ++i) append(*log, i);
  EXPECT_EQ(counters(*log), (std::vector<std::uint32_t>{5, 6, 7}));
  EXPECT_DOUBLE_EQ(log->header(0).log_ts, 5.5);
  EXPECT_DOUBLE_EQ(log->header(0).src_ts, 5.25);
}

TEST(SampleLog, CopiesOutAcrossTheRingsEnd) {
  auto log = SampleLog::create(3, 28);
  for (std::uint32_t i = 1; i <= 4; ++i) append(*log, i);  // slots: 4 2 3
  std::vector<unsigned char> all(3 * 28);
  log->copy_out(0, all.data(), all.size());
  for (std::uint32_t i = 0; i < 3; ++i) {
    const auto header = protocol::logger::read_sample_header(all.data() + i * 28);
    EXPECT_EQ(header.packet_counter, i + 2);
    std::uint32_t payload[2];
    std::memcpy(payload, all.data() + i * 28 + 20, sizeof payload);
    EXPECT_EQ(payload[0], (i + 2) * 10);
    EXPECT_EQ(payload[1], (i + 2) * 10 + 1);
  }
  // A piece that starts within one sample and ends within the next.
  std::vector<unsigned char> piece(30);
  log->copy_out(40, piece.data(), piece.size());
  EXPECT_TRUE(std::equal(piece.begin(), piece.end(), all.begin() + 40));
}

TEST(SampleLog, PadsShortPacketsAndCutsLongOnes) {
  auto log = SampleLog::create(2, 24);
  const unsigned char long_packet[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  log->append({}, long_packet, sizeof long_packet);
  log->append({}, long_packet, 2);
  std::vector<unsigned char> all(48);
  log->copy_out(0, all.data(), all.size());
  EXPECT_EQ(std::vector<unsigned char>(all.begin() + 20, all.begin() + 24), (std::vector<unsigned char>{1, 2, 3, 4}));
  EXPECT_EQ(std::vector<unsigned char>(all.begin() + 44, all.end()), (std::vector<unsigned char>{1, 2, 0, 0}));
}

TEST(SampleLog, HeaderOnlySamples) {
  auto log = SampleLog::create(2, 20);
  const unsigned char packet[4] = {9, 9, 9, 9};
  log->append({1, 2, 3}, packet, sizeof packet);
  EXPECT_EQ(log->count(), 1u);
  EXPECT_EQ(log->header(0).packet_counter, 3u);
}

TEST(SampleLog, SnapshotsDoNotChangeWithLaterSamples) {
  auto log = SampleLog::create(4, 28);
  for (std::uint32_t i = 1; i <= 5; ++i) append(*log, i);
  auto snapshot = log->snapshot();
  append(*log, 6);
  EXPECT_EQ(counters(*snapshot), (std::vector<std::uint32_t>{2, 3, 4, 5}));
  EXPECT_EQ(counters(*log), (std::vector<std::uint32_t>{3, 4, 5, 6}));
  EXPECT_EQ(SampleLog::create(4, 28)->snapshot()->count(), 0u);
}

TEST(SampleLog, RefusesLogsBeyondTheMemoryWithAClearReason) {
  try {
    SampleLog::create(std::uint64_t{1} << 40, 36);
    FAIL() << "a 36 TiB log was reserved";
  } catch (const RequestError& error) {
    EXPECT_EQ(error.code(), LNE_NO_MEM);
    EXPECT_NE(std::string(error.what()).find("do not fit into the"), std::string::npos) << error.what();
  }
  // Sizes whose product overflows 64 bits are refused the same way.
  EXPECT_THROW(check_log_fits(~std::uint64_t{0}, 1u << 20, "x"), RequestError);
  EXPECT_THROW(SampleLog::create(0, 36), RequestError);
  EXPECT_THROW(SampleLog::create(1, 19), RequestError);
}

}  // namespace
}  // namespace ln::manager
