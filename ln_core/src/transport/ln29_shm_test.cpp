#include "transport/ln29_shm.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "testing/wait.hpp"

namespace ln::transport::ln29 {
namespace {

using namespace std::chrono_literals;

// A name of our own in /dev/shm, removed again by the fixture.
class Ln29ShmTest : public ::testing::Test {
 protected:
  std::string fresh_name() {
    names_.push_back("ln_core_test_" + std::to_string(::getpid()) + "_" + std::to_string(names_.size()));
    return names_.back();
  }
  void TearDown() override {
    for (const std::string& name : names_) ::shm_unlink(("/" + name).c_str());
  }
  static std::vector<unsigned char> file_bytes(const std::string& name) {
    std::vector<unsigned char> bytes;
    const int fd = ::shm_open(("/" + name).c_str(), O_RDONLY, 0);
    if (fd < 0) return bytes;
    struct stat st {};
    ::fstat(fd, &st);
    bytes.resize(static_cast<std::size_t>(st.st_size));
    if (::pread(fd, bytes.data(), bytes.size(), 0) != static_cast<ssize_t>(bytes.size())) bytes.clear();
    ::close(fd);
    return bytes;
  }
  static void write_file(const std::string& name, const std::string& contents) {
    const int fd = ::shm_open(("/" + name).c_str(), O_RDWR | O_CREAT | O_TRUNC, 0600);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::write(fd, contents.data(), contents.size()), static_cast<ssize_t>(contents.size()));
    ::close(fd);
  }

  std::vector<std::string> names_;
};

ShmErrc open_error(const std::string& name) {
  try {
    Segment::open(name);
  } catch (const ShmError& e) {
    return e.code();
  }
  return ShmErrc::invalid_argument;  // "no error" (never expected here)
}

TEST_F(Ln29ShmTest, SizesAndHeaderAreLn29s) {
  struct Case {
    std::uint32_t element_size, n_elements, version;
    std::size_t size;
  };
  // Sizes of segments LN 2.9's create_shm_target() made.
  for (const Case& c : {Case{16, 3, 3, 240}, Case{8, 2, 3, 184}, Case{8, 2, 2, 168}, Case{0, 2, 3, 168},
                        Case{8, 3, 2, 192}, Case{8, 3, 0, 192}}) {
    const std::string name = fresh_name();
    Segment segment = Segment::create(name, c.element_size, c.n_elements, c.version);
    const auto bytes = file_bytes(name);
    ASSERT_EQ(bytes.size(), c.size) << c.element_size << "x" << c.n_elements << " v" << c.version;
    EXPECT_EQ(std::memcmp(bytes.data(), "LN_SHM\0", 7), 0);
    EXPECT_EQ(bytes[7], c.version);
    std::uint32_t element_size, n_elements;
    std::memcpy(&element_size, &bytes[8], 4);
    std::memcpy(&n_elements, &bytes[12], 4);
    EXPECT_EQ(element_size, c.element_size);
    EXPECT_EQ(n_elements, c.n_elements);
  }
}

TEST_F(Ln29ShmTest, SlotBytesAfterWritesAreLn29s) {
  const std::string name = fresh_name();
  Segment writer = Segment::create(name, 8, 3, 3);
  for (int i = 1; i <= 4; ++i) ASSERT_TRUE(writer.write(100 + i, ("pkt0000" + std::to_string(i)).data(), 8));
  const auto bytes = file_bytes(name);
  auto u32 = [&](std::size_t at) {
    std::uint32_t v;
    std::memcpy(&v, &bytes[at], 4);
    return v;
  };
  EXPECT_EQ(u32(104), 1u) << "next write index";
  EXPECT_EQ(u32(108), 1u) << "ring full";
  EXPECT_EQ(u32(112), 4u) << "packet counter";
  // Slot 0 (stride 32) holds packet 4, slot 1 packet 2.
  EXPECT_EQ(u32(120), 4u);
  EXPECT_EQ(u32(120 + 28), 4u) << "trailing number";
  double ts;
  std::memcpy(&ts, &bytes[128], 8);
  EXPECT_EQ(ts, 104.0);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&bytes[136]), 8), "pkt00004");
  EXPECT_EQ(u32(152), 2u);
}

TEST_F(Ln29ShmTest, ReadsDeliverPacketsInOrderEachOnce) {
  const std::string name = fresh_name();
  Segment writer = Segment::create(name, 16, 3, 3);
  Segment reader = Segment::open(name);
  char data[16] = {};
  double ts = -1;
  std::uint32_t counter = 77;
  auto read = [&] { return reader.read_next(data, sizeof data, ts, counter, 0ns); };
  auto write = [&](std::uint32_t number) {
    writer.write(number * 1.5, std::string(16, static_cast<char>('a' + number)).data(), 16);
  };
  EXPECT_EQ(read(), ReadResult::nothing_new);
  EXPECT_EQ(counter, 77u) << "untouched without a packet";
  EXPECT_EQ(reader.read_last(data, sizeof data, ts, counter), ReadResult::packet);
  EXPECT_EQ(counter, 0u);
  EXPECT_EQ(ts, 0.0);

  write(1);
  write(2);
  EXPECT_EQ(reader.newest_counter(), 2u);
  EXPECT_EQ(read(), ReadResult::packet);
  EXPECT_EQ(counter, 1u);
  EXPECT_EQ(ts, 1.5);
  EXPECT_EQ(std::string(data, 16), std::string(16, 'b'));
  EXPECT_EQ(read(), ReadResult::packet);
  EXPECT_EQ(counter, 2u);
  EXPECT_EQ(read(), ReadResult::nothing_new);

  for (std::uint32_t i = 3; i <= 7; ++i) write(i);  // laps the reader: 5, 6, 7 are left
  for (std::uint32_t expected : {5u, 6u, 7u}) {
    EXPECT_EQ(read(), ReadResult::packet);
    EXPECT_EQ(counter, expected);
    EXPECT_EQ(data[0], static_cast<char>('a' + expected));
  }
  EXPECT_EQ(read(), ReadResult::nothing_new);

  write(8);
  write(9);
  EXPECT_EQ(reader.read_last(data, sizeof data, ts, counter), ReadResult::packet);
  EXPECT_EQ(counter, 9u);
  EXPECT_EQ(read(), ReadResult::nothing_new) << "reads continue after read_last's packet";
  EXPECT_EQ(reader.read_last(data, sizeof data, ts, counter), ReadResult::packet) << "read_last repeats";
  EXPECT_EQ(counter, 9u);

  // A short write changes only its bytes; a short read copies only its bytes.
  writer.write(9, "x", 1);
  char two[2] = {'?', '?'};
  EXPECT_EQ(reader.read_next(two, 1, ts, counter, 0ns), ReadResult::packet);
  EXPECT_EQ(two[0], 'x');
  EXPECT_EQ(two[1], '?');
  EXPECT_FALSE(writer.write(0, data, 17)) << "larger than element_size";

  // A reader that opens later sees only what is written afterwards.
  Segment late = Segment::open(name);
  EXPECT_EQ(late.read_next(data, sizeof data, ts, counter, 0ns), ReadResult::nothing_new);
  write(11);
  EXPECT_EQ(late.read_next(data, sizeof data, ts, counter, 0ns), ReadResult::packet);
  EXPECT_EQ(counter, 11u);
}

TEST_F(Ln29ShmTest, NextBufferIsWrittenInPlace) {
  const std::string name = fresh_name();
  Segment writer = Segment::create(name, 8, 2, 3);
  Segment reader = Segment::open(name);
  std::memcpy(writer.next_buffer(), "inplace!", 8);
  char data[8];
  double ts;
  std::uint32_t counter;
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 0ns), ReadResult::nothing_new) << "not before the commit";
  ASSERT_TRUE(writer.write(3.0, nullptr, 8));
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 0ns), ReadResult::packet);
  EXPECT_EQ(std::string(data, 8), "inplace!");
}

TEST_F(Ln29ShmTest, WaitsEndWithAPacketATimeoutOrUnblock) {
  const std::string name = fresh_name();
  Segment writer = Segment::create(name, 8, 2, 3);
  Segment reader = Segment::open(name);
  char data[8];
  double ts;
  std::uint32_t counter;
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 100ms), ReadResult::timeout);
  EXPECT_GE(std::chrono::steady_clock::now() - started, 100ms);

  const pid_t waiting_thread = test::current_thread_id();
  std::thread late_writer([&] {
    test::wait_until([&] { return test::thread_sleeps(waiting_thread); });  // once the read below waits
    writer.write(1, "woken up", 8);
  });
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 10s), ReadResult::packet);
  late_writer.join();
  EXPECT_EQ(std::string(data, 8), "woken up");

  std::thread unblocker([&] {
    test::wait_until([&] { return test::thread_sleeps(waiting_thread); });
    reader.unblock();
  });
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, -1ns), ReadResult::unblocked);
  unblocker.join();

  reader.unblock();  // nobody waits: the next wait ends at once, once
  EXPECT_EQ(reader.wait_for_packet(counter, 10s), ReadResult::unblocked);
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 50ms), ReadResult::timeout);
}

TEST_F(Ln29ShmTest, WaitForPacketConsumesIt) {
  const std::string name = fresh_name();
  Segment writer = Segment::create(name, 8, 2, 3);
  Segment reader = Segment::open(name);
  writer.write(1, "one.....", 8);
  std::uint32_t counter = 0;
  EXPECT_EQ(reader.wait_for_packet(counter, 0ns), ReadResult::packet);
  EXPECT_EQ(counter, 1u);
  EXPECT_EQ(reader.wait_for_packet(counter, 50ms), ReadResult::timeout);
  char data[8];
  double ts;
  EXPECT_EQ(reader.read_next(data, 8, ts, counter, 0ns), ReadResult::nothing_new) << "as in LN 2.9";
}

TEST_F(Ln29ShmTest, BadSegmentsAndNamesAreRefused) {
  EXPECT_EQ(open_error("ln_core_test_does_not_exist"), ShmErrc::system_error);
  const std::string not_ln = fresh_name();
  write_file(not_ln, std::string(140, 'x'));
  EXPECT_EQ(open_error(not_ln), ShmErrc::bad_magic);
  const std::string truncated = fresh_name();
  write_file(truncated, std::string("LN_SHM\0\3", 8));
  EXPECT_EQ(open_error(truncated), ShmErrc::too_small);
  const std::string short_slots = fresh_name();
  { Segment segment = Segment::create(short_slots, 64, 4, 3); }
  ::truncate(("/dev/shm/" + short_slots).c_str(), 200);
  EXPECT_EQ(open_error(short_slots), ShmErrc::too_small);
  const std::string future = fresh_name();
  std::string header(120, '\0');
  std::memcpy(header.data(), "LN_SHM\0\4", 8);
  write_file(future, header);
  EXPECT_EQ(open_error(future), ShmErrc::bad_version);

  for (const std::string& bad : {std::string(), std::string("a/b"), std::string(300, 'n')}) {
    try {
      Segment::create(bad, 8, 1, 3);
      ADD_FAILURE() << "created '" << bad << "'";
    } catch (const ShmError& e) {
      EXPECT_EQ(e.code(), ShmErrc::system_error);
      EXPECT_EQ(e.sys_errno(), bad.size() > 255 ? ENAMETOOLONG : EINVAL);
    }
  }
  EXPECT_THROW(Segment::create(fresh_name(), 8, 0, 3), ShmError) << "no slots";
  EXPECT_THROW(Segment::create(fresh_name(), 8, 1, 4), ShmError) << "version 4";
}

TEST_F(Ln29ShmTest, CreatingAgainReplacesTheSegment) {
  const std::string name = fresh_name();
  Segment first = Segment::create(name, 8, 2, 3);
  first.write(1, "first...", 8);
  Segment second = Segment::create(name, 16, 4, 3);
  EXPECT_EQ(file_bytes(name).size(), 120u + 4 * 40);
  EXPECT_EQ(Segment::open(name).newest_counter(), 0u);
  first.write(2, "still ok", 8);  // the old mapping stays valid
  EXPECT_EQ(first.newest_counter(), 2u);
}

// A slot a writer is still filling is never delivered: LN 2.9's writers
// number the slot before and after the payload (version 3: leading and
// trailing number), ours also zero the leading number first. Simulated by
// editing the slot's numbers through a second mapping.
TEST_F(Ln29ShmTest, SlotsBeingWrittenAreNotDelivered) {
  for (std::uint32_t version : {2u, 3u}) {
    const std::string name = fresh_name();
    Segment writer = Segment::create(name, 8, 1, version);
    Segment reader = Segment::open(name);
    writer.write(1, "complete", 8);
    const int fd = ::shm_open(("/" + name).c_str(), O_RDWR, 0);
    ASSERT_GE(fd, 0);
    const std::size_t size = file_bytes(name).size();
    auto* bytes = static_cast<unsigned char*>(::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0));
    ::close(fd);
    ASSERT_NE(bytes, MAP_FAILED);
    auto set_u32 = [&](std::size_t at, std::uint32_t value) { std::memcpy(bytes + at, &value, 4); };
    const std::size_t slot = 120, trailing = slot + (version >= 3 ? 28 : 0);
    set_u32(112, 2);                      // a second packet announced ...
    set_u32(slot, version >= 3 ? 2 : 0);  // ... whose slot is half written
    char data[8];
    double ts;
    std::uint32_t counter = 0;
    EXPECT_EQ(reader.read_next(data, 8, ts, counter, 0ns), ReadResult::nothing_new) << "v" << version;
    EXPECT_EQ(reader.read_last(data, 8, ts, counter), ReadResult::torn) << "v" << version;
    set_u32(slot, 2);
    set_u32(trailing, 2);  // finished
    EXPECT_EQ(reader.read_next(data, 8, ts, counter, 0ns), ReadResult::packet) << "v" << version;
    EXPECT_EQ(counter, 2u);
    ::munmap(bytes, size);
  }
}

// A writer process rewrites the slots as fast as it can; every copy the
// reader accepts must be one whole packet (all bytes and the timestamp from
// the same packet), and counters only grow.
TEST_F(Ln29ShmTest, ReadsAcrossProcessesAreNeverTorn) {
  for (std::uint32_t version : {2u, 3u}) {
    const std::string name = fresh_name();
    // One slot: every write rewrites what the reader copies, so where the
    // two processes get CPUs at the same time copies overlap writes.
    constexpr std::size_t kSize = 64 * 1024;
    Segment segment = Segment::create(name, kSize, 1, version);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      Segment writer = Segment::open(name);
      std::vector<unsigned char> packet(kSize);
      const auto end = std::chrono::steady_clock::now() + 2s;  // bounded even if the parent dies
      for (std::uint32_t i = 1; std::chrono::steady_clock::now() < end; ++i) {
        std::memset(packet.data(), static_cast<int>(i & 0xff), packet.size());
        writer.write(i, packet.data(), packet.size());
      }
      ::_exit(0);
    }
    std::vector<unsigned char> data(kSize);
    double ts = 0;
    std::uint32_t counter = 0, previous = 0;
    int packets = 0;
    const auto end = std::chrono::steady_clock::now() + 300ms;
    while (std::chrono::steady_clock::now() < end) {
      if (segment.read_next(data.data(), data.size(), ts, counter, 0ns) != ReadResult::packet) continue;
      ++packets;
      ASSERT_GT(counter, previous);
      previous = counter;
      ASSERT_EQ(static_cast<std::uint32_t>(ts) & 0xff, data[0]) << "v" << version;
      for (unsigned char byte : data) ASSERT_EQ(byte, data[0]) << "torn copy, v" << version;
    }
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    EXPECT_GT(packets, 0) << "v" << version;
  }
}

}  // namespace
}  // namespace ln::transport::ln29
