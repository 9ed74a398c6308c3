// The recording thread on its own: segments written in this process, read
// into sample logs.
#include "manager/recorder.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

using namespace std::chrono_literals;
using transport::ShmReader;
using transport::ShmWriter;

struct Stream {
  explicit Stream(std::uint32_t history = 16) {
    transport::RingConfig config;
    config.message_size = 8;
    config.history = history;
    writer = std::make_unique<ShmWriter>(ShmWriter::create(config));
  }
  std::unique_ptr<ShmReader> reader(std::uint32_t window) const {
    transport::ReaderOptions options;
    options.buffers = window;
    options.on_lag = transport::LagPolicy::keep_latest_window;
    return std::make_unique<ShmReader>(ShmReader::attach(writer->fd(), options));
  }
  void write(std::uint64_t value, double ts) {
    ASSERT_EQ(writer->write(&value, sizeof value, ts), transport::WriteStatus::ok);
  }
  std::unique_ptr<ShmWriter> writer;
};

std::vector<std::uint64_t> values(const SampleLog& log) {
  std::vector<std::uint64_t> out;
  for (std::uint64_t i = 0; i < log.count(); ++i) {
    std::uint64_t value = 0;
    log.copy_out(i * log.sample_size() + 20, &value, sizeof value);
    out.push_back(value);
  }
  return out;
}

class RecorderTest : public ::testing::Test {
 protected:
  Recorder recorder{[this](LogLevel, const std::string& text) {
    std::lock_guard<std::mutex> lock(mutex);
    lines.push_back(text);
  }};
  std::mutex mutex;
  std::vector<std::string> lines;
};

TEST_F(RecorderTest, RecordsEveryPacketWithTheHeaderAndStopsAtDetach) {
  Stream stream(64);  // the window holds every packet, however late the thread looks
  auto log = SampleLog::create(100, 28);
  recorder.attach(1, stream.reader(64), 64, {log, 1, false, "t"});
  for (std::uint64_t i = 1; i <= 40; ++i) stream.write(i * 10, 1000.0 + i);
  recorder.detach(1);  // the packets written before are recorded ...
  stream.write(999, 2000.0);
  EXPECT_EQ(recorder.taps(), 0u);
  ASSERT_EQ(log->count(), 40u);  // ... and none after
  EXPECT_EQ(values(*log).front(), 10u);
  EXPECT_EQ(values(*log).back(), 400u);
  const auto header = log->header(4);
  EXPECT_EQ(header.packet_counter, 5u);
  EXPECT_EQ(header.src_ts, 1005.0);
  EXPECT_GT(header.log_ts, 1.0e9);  // wall clock
}

TEST_F(RecorderTest, DivisorAndTimestampsOnly) {
  Stream stream;
  auto every_third = SampleLog::create(100, 28);
  auto stamps = SampleLog::create(100, 20);
  recorder.attach(1, stream.reader(16), 16, {every_third, 3, false, "third"});
  recorder.attach(2, stream.reader(16), 16, {stamps, 0, true, "stamps"});
  for (std::uint64_t i = 1; i <= 10; ++i) stream.write(i, i);
  recorder.detach(1);
  recorder.detach(2);
  EXPECT_EQ(values(*every_third), (std::vector<std::uint64_t>{3, 6, 9}));
  EXPECT_EQ(stamps->count(), 10u);
  EXPECT_EQ(stamps->header(9).packet_counter, 10u);
}

TEST_F(RecorderTest, DrainsAClosedSegmentThenTheNextOne) {
  Stream first;
  auto log = SampleLog::create(100, 28);
  recorder.attach(1, first.reader(16), 16, {log, 1, false, "t"});
  first.write(1, 1);
  first.write(2, 2);
  first.writer->close();  // the publisher left: what it wrote is still read
  Stream second;
  recorder.attach(1, second.reader(16), 16, {});
  second.write(7, 3);
  recorder.catch_up(1);
  EXPECT_EQ(values(*log), (std::vector<std::uint64_t>{1, 2, 7}));
  recorder.detach(1);
}

TEST_F(RecorderTest, PacketsOverwrittenBeforeItCameAreReportedAndThePeriodShrinks) {
  Stream stream(4);
  auto log = SampleLog::create(1000, 28);
  recorder.attach(1, stream.reader(4), 4, {log, 1, false, "logger 'L', topic 'fast'"});
  // Let it settle to its longest period, then flood the 4-packet window.
  const auto settled = std::chrono::steady_clock::now() + 10s;
  while (recorder.period() < kMaxPeriod && std::chrono::steady_clock::now() < settled) std::this_thread::sleep_for(1ms);
  for (std::uint64_t i = 1; i <= 200; ++i) stream.write(i, i);
  recorder.catch_up(1);
  EXPECT_LT(log->count(), 200u);
  EXPECT_EQ(values(*log).back(), 200u);  // the newest survive
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (recorder.period() == kMaxPeriod && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  EXPECT_LT(recorder.period(), kMaxPeriod);
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines.front().find("overwritten before the recorder read them"), std::string::npos) << lines.front();
  EXPECT_NE(lines.front().find("topic 'fast'"), std::string::npos);
}

TEST(OpenPublisherSegment, AnUnreachablePeerIsAClearError) {
  try {
    open_publisher_segment("ln_core/no/such/peer", 1, "t", 2, 4, 200ms);
    FAIL() << "opened a segment of nobody";
  } catch (const RequestError& error) {
    EXPECT_EQ(error.code(), LNE_REQUEST_FAILED);
    EXPECT_NE(std::string(error.what()).find("own host"), std::string::npos) << error.what();
  }
  EXPECT_EQ(tap_slots(64), kMaxTapSlots);
  EXPECT_EQ(tap_slots(1 << 20), kMinTapSlots);
  EXPECT_EQ(tap_slots(64 << 10), 64u);
}

}  // namespace
}  // namespace ln::manager
