// Unit and cross-process tests of the shared-memory topic transport.
// Every child process is forked by the test that needs it, arms alarm() as a
// last resort, and is reaped (or killed by pid) by that test. Waiting for the
// other side is always a condition with a deadline, never a fixed sleep.

#include <dirent.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <functional>
#include <future>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "testing/wait.hpp"
#include "transport/shm_ring.hpp"

namespace ln::transport {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// ------------------------------------------------------------------ helpers

std::vector<std::byte> packet(std::size_t size, std::uint64_t sequence) {
  std::vector<std::byte> bytes(size);
  for (std::size_t i = 0; i < size; ++i) bytes[i] = static_cast<std::byte>((sequence * 131 + i * 7) & 0xff);
  return bytes;
}

// Payload whose every byte depends on the sequence number stored in its first 8 bytes.
void fill_pattern(void* destination, std::size_t size, std::uint64_t sequence) {
  auto* bytes = static_cast<unsigned char*>(destination);
  std::memcpy(bytes, &sequence, sizeof(sequence));
  for (std::size_t i = sizeof(sequence); i < size; ++i) {
    bytes[i] = static_cast<unsigned char>((sequence * 131 + i * 7) & 0xff);
  }
}

bool pattern_intact(const void* source, std::size_t size, std::uint64_t sequence) {
  const auto* bytes = static_cast<const unsigned char*>(source);
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes, sizeof(stored));
  if (stored != sequence) return false;
  for (std::size_t i = sizeof(sequence); i < size; ++i) {
    if (bytes[i] != static_cast<unsigned char>((sequence * 131 + i * 7) & 0xff)) return false;
  }
  return true;
}

using ln::test::wait_until;

struct SocketPair {
  UniqueFd parent;
  UniqueFd child;
  SocketPair() {
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) throw std::runtime_error("socketpair");
    parent.reset(fds[0]);
    child.reset(fds[1]);
  }
};

void send_byte(int socket, char value = 'x') {
  if (::send(socket, &value, 1, MSG_NOSIGNAL) != 1) throw std::runtime_error("send_byte");
}

// Returns the byte, or -1 on timeout / EOF.
int receive_byte(int socket, std::chrono::milliseconds timeout) {
  pollfd entry{socket, POLLIN, 0};
  if (::poll(&entry, 1, static_cast<int>(timeout.count())) != 1) return -1;
  char value = 0;
  return ::recv(socket, &value, 1, 0) == 1 ? value : -1;
}

// A forked child running `body`; its return value is the exit code.
class Child {
 public:
  explicit Child(const std::function<int()>& body) {
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      ::alarm(30);  // last resort if the parent never lets us finish
      int code = 98;
      try {
        code = body();
      } catch (...) {
        code = 99;
      }
      ::_exit(code);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  // Exit code, or -1 if it did not exit in time (then it is killed), -2 if killed by a signal.
  int wait(std::chrono::milliseconds timeout = 20s) {
    int status = 0;
    const bool exited = wait_until([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; }, timeout);
    if (!exited) return -1;
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -2;
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
};

std::set<std::string> dev_shm_entries() {
  std::set<std::string> names;
  if (DIR* directory = ::opendir("/dev/shm")) {
    while (dirent* entry = ::readdir(directory)) names.insert(entry->d_name);
    ::closedir(directory);
  }
  return names;
}

// A sealed memfd holding `contents`, for attaching to damaged copies of a segment.
UniqueFd sealed_copy(const std::vector<std::byte>& contents) {
  UniqueFd fd(::memfd_create("test_copy", MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!contents.empty() &&
      ::pwrite(fd.get(), contents.data(), contents.size(), 0) != static_cast<ssize_t>(contents.size())) {
    throw std::runtime_error("pwrite");
  }
  ::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW);
  return fd;
}

std::vector<std::byte> file_contents(int fd) {
  const off_t size = ::lseek(fd, 0, SEEK_END);
  std::vector<std::byte> contents(static_cast<std::size_t>(size));
  if (::pread(fd, contents.data(), contents.size(), 0) != size) throw std::runtime_error("pread");
  return contents;
}

ShmErrc attach_error(int fd, const ReaderOptions& options = {}) {
  try {
    ShmReader::attach(fd, options);
  } catch (const ShmError& error) {
    return error.code();
  }
  ADD_FAILURE() << "attach unexpectedly succeeded";
  return ShmErrc::system_error;
}

RingConfig config(std::uint32_t message_size, std::uint32_t history = 1, std::uint32_t borrow_slots = 2) {
  RingConfig result;
  result.message_size = message_size;
  result.history = history;
  result.borrow_slots = borrow_slots;
  return result;
}

// ------------------------------------------------------------------ creation and attach

TEST(ShmRingConfig, RejectsOutOfRangeParameters) {
  const auto error_of = [](RingConfig c) {
    try {
      ShmWriter::create(c);
    } catch (const ShmError& error) {
      return error.code();
    }
    return ShmErrc::system_error;
  };
  EXPECT_EQ(error_of(config(0)), ShmErrc::invalid_config);
  EXPECT_EQ(error_of(config(64, 0)), ShmErrc::invalid_config);
  EXPECT_EQ(error_of(config(64, 1, 64)), ShmErrc::invalid_config);
  EXPECT_EQ(error_of(config((1u << 30) + 1)), ShmErrc::invalid_config);
  RingConfig zero_sequence = config(64);
  zero_sequence.first_sequence = 0;
  EXPECT_EQ(error_of(zero_sequence), ShmErrc::invalid_config);
}

TEST(ShmRingAttach, AcceptsValidSegmentAndChecksReaderOptions) {
  ShmWriter writer = ShmWriter::create(config(100, 4));
  ShmReader reader = ShmReader::attach(writer.fd());
  EXPECT_EQ(reader.message_size(), 100u);
  EXPECT_EQ(reader.history(), 4u);
  ReaderOptions too_many;
  too_many.buffers = 5;
  EXPECT_EQ(attach_error(writer.fd(), too_many), ShmErrc::invalid_argument);
  ReaderOptions zero;
  zero.buffers = 0;
  EXPECT_EQ(attach_error(writer.fd(), zero), ShmErrc::invalid_argument);
}

TEST(ShmRingAttach, RejectsForeignAndDamagedSegments) {
  ShmWriter writer = ShmWriter::create(config(64, 2));
  const std::vector<std::byte> good = file_contents(writer.fd());

  {  // an intact copy attaches
    UniqueFd copy = sealed_copy(good);
    EXPECT_NO_THROW(ShmReader::attach(copy.get()));
  }
  {  // not a memfd at all
    int pipe_fds[2];
    ASSERT_EQ(::pipe(pipe_fds), 0);
    UniqueFd read_end(pipe_fds[0]), write_end(pipe_fds[1]);
    EXPECT_EQ(attach_error(read_end.get()), ShmErrc::not_sealed);
  }
  {  // a memfd without the size seal could shrink under our mapping
    UniqueFd unsealed(::memfd_create("unsealed", MFD_CLOEXEC));
    ASSERT_EQ(::ftruncate(unsealed.get(), static_cast<off_t>(good.size())), 0);
    EXPECT_EQ(attach_error(unsealed.get()), ShmErrc::not_sealed);
  }
  {  // smaller than a header
    UniqueFd tiny = sealed_copy(std::vector<std::byte>(16));
    EXPECT_EQ(attach_error(tiny.get()), ShmErrc::too_small);
  }
  {  // zeros: someone else's memory
    UniqueFd zeros = sealed_copy(std::vector<std::byte>(good.size()));
    EXPECT_EQ(attach_error(zeros.get()), ShmErrc::bad_magic);
  }
  {  // a future layout version
    std::vector<std::byte> bytes = good;
    bytes[8] = std::byte{99};
    UniqueFd fd = sealed_copy(bytes);
    EXPECT_EQ(attach_error(fd.get()), ShmErrc::bad_version);
  }
  {  // message_size changed: checksum catches it
    std::vector<std::byte> bytes = good;
    bytes[48] = std::byte{0xff};
    UniqueFd fd = sealed_copy(bytes);
    EXPECT_EQ(attach_error(fd.get()), ShmErrc::bad_layout);
  }
  {  // truncated: the header promises more than the file has
    std::vector<std::byte> bytes(good.begin(), good.end() - 64);
    UniqueFd fd = sealed_copy(bytes);
    EXPECT_EQ(attach_error(fd.get()), ShmErrc::too_small);
  }
}

TEST(ShmRingAttach, LeavesNothingInDevShm) {
  const std::set<std::string> before = dev_shm_entries();
  {
    ShmWriter writer = ShmWriter::create(config(4096, 8));
    ShmReader reader = ShmReader::attach(writer.fd());
    ASSERT_EQ(writer.write(packet(4096, 1).data(), 4096), WriteStatus::ok);
    std::vector<std::byte> buffer(4096);
    SampleInfo info;
    ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(dev_shm_entries(), before);
  }
  EXPECT_EQ(dev_shm_entries(), before);
}

// ------------------------------------------------------------------ delivery semantics

TEST(ShmRingSemantics, SingleBufferDeliversOnlyTheNewest) {
  ShmWriter writer = ShmWriter::create(config(64, 1));
  ShmReader reader = ShmReader::attach(writer.fd());
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::no_data);

  for (std::uint64_t s = 1; s <= 3; ++s) {
    ASSERT_EQ(writer.write(packet(64, s).data(), 64, 10.0 + static_cast<double>(s)), WriteStatus::ok);
  }
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 3u);
  EXPECT_EQ(info.lost, 2u);
  EXPECT_EQ(info.timestamp, 13.0);
  EXPECT_EQ(info.size, 64u);
  EXPECT_EQ(buffer, packet(64, 3));
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::no_data);

  ASSERT_EQ(writer.write(packet(64, 4).data(), 64), WriteStatus::ok);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 4u);
  EXPECT_EQ(info.lost, 0u);
  EXPECT_GT(info.timestamp, 1.6e9);  // wall clock seconds by default
}

TEST(ShmRingSemantics, NoLatchedValueForLateSubscribers) {
  ShmWriter writer = ShmWriter::create(config(64, 4));
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  ReaderOptions options;
  options.buffers = 4;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  EXPECT_FALSE(reader.has_new_data());
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 20ms), ReadStatus::timeout);
  ASSERT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::ok);
  EXPECT_TRUE(reader.has_new_data());
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 2u);
  EXPECT_EQ(info.lost, 0u);
}

TEST(ShmRingSemantics, BuffersDeliverInOrderAndSkipToNewestWhenLagging) {
  ShmWriter writer = ShmWriter::create(config(64, 8));
  ReaderOptions newest_options;
  newest_options.buffers = 8;
  ShmReader newest = ShmReader::attach(writer.fd(), newest_options);
  ReaderOptions window_options = newest_options;
  window_options.on_lag = LagPolicy::keep_latest_window;
  ShmReader window = ShmReader::attach(writer.fd(), window_options);

  std::vector<std::byte> buffer(64);
  SampleInfo info;
  for (std::uint64_t s = 1; s <= 8; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  for (std::uint64_t s = 1; s <= 8; ++s) {  // lagging by exactly `buffers` loses nothing
    ASSERT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_EQ(buffer, packet(64, s));
    ASSERT_EQ(window.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
  }

  for (std::uint64_t s = 9; s <= 28; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  ASSERT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 28u);  // LN: skip to the newest
  EXPECT_EQ(info.lost, 19u);
  EXPECT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::no_data);

  ASSERT_EQ(window.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 21u);  // KEEP_LAST(8): the oldest of the newest 8
  EXPECT_EQ(info.lost, 12u);
  for (std::uint64_t s = 22; s <= 28; ++s) {
    ASSERT_EQ(window.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_EQ(buffer, packet(64, s));
  }
}

TEST(ShmRingSemantics, ReaderBuffersSmallerThanHistoryAndNewestMode) {
  ShmWriter writer = ShmWriter::create(config(64, 16));
  ReaderOptions options;
  options.buffers = 4;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  for (std::uint64_t s = 1; s <= 4; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 1u);
  for (std::uint64_t s = 5; s <= 6; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  // unread 2..6 = 5 > 4 buffers: skip to newest
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 6u);
  EXPECT_EQ(info.lost, 4u);
  for (std::uint64_t s = 7; s <= 9; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, kNoWait, ReadMode::newest), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 9u);
  EXPECT_EQ(info.lost, 2u);
}

TEST(ShmRingSemantics, WriteErrorsLoansAndShortPackets) {
  ShmWriter writer = ShmWriter::create(config(64, 4));
  ReaderOptions options;
  options.buffers = 4;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  std::vector<std::byte> big(65);
  EXPECT_EQ(writer.write(big.data(), big.size()), WriteStatus::packet_too_large);
  EXPECT_EQ(writer.commit(10), WriteStatus::no_loan);

  void* loan = writer.loan();
  ASSERT_NE(loan, nullptr);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(loan) % 32, 0u);
  EXPECT_EQ(writer.loan(), nullptr);
  EXPECT_EQ(writer.write(big.data(), 10), WriteStatus::loan_outstanding);
  EXPECT_FALSE(reader.has_new_data());  // not visible before commit
  std::memcpy(loan, packet(64, 1).data(), 64);
  EXPECT_EQ(writer.commit(65), WriteStatus::packet_too_large);
  ASSERT_EQ(writer.commit(64, 5.0), WriteStatus::ok);

  ASSERT_NE(writer.loan(), nullptr);
  writer.discard_loan();  // nothing published, sequence not consumed
  ASSERT_EQ(writer.write(packet(10, 2).data(), 10), WriteStatus::ok);

  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 1u);
  EXPECT_EQ(info.timestamp, 5.0);
  EXPECT_EQ(buffer, packet(64, 1));

  std::vector<std::byte> small(8, std::byte{0x5a});
  EXPECT_EQ(reader.read(small.data(), small.size(), info), ReadStatus::buffer_too_small);
  EXPECT_EQ(info.size, 10u);
  EXPECT_EQ(small, std::vector<std::byte>(8, std::byte{0x5a}));  // untouched, not consumed
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 2u);
  EXPECT_EQ(info.size, 10u);
  EXPECT_TRUE(std::equal(buffer.begin(), buffer.begin() + 10, packet(10, 2).begin()));

  std::vector<std::byte> sentinel(64, std::byte{0x33});
  EXPECT_EQ(reader.read(sentinel.data(), sentinel.size(), info), ReadStatus::no_data);
  EXPECT_EQ(sentinel, std::vector<std::byte>(64, std::byte{0x33}));

  writer.close();
  EXPECT_EQ(writer.write(packet(64, 3).data(), 64), WriteStatus::closed);
  EXPECT_EQ(writer.loan(), nullptr);
}

TEST(ShmRingSemantics, CloseDrainsThenReportsPublisherGone) {
  ShmWriter writer = ShmWriter::create(config(64, 4));
  ReaderOptions options;
  options.buffers = 4;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  ASSERT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::ok);
  EXPECT_TRUE(reader.publisher_alive());
  writer.close();
  EXPECT_FALSE(reader.publisher_alive());
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, 1s), ReadStatus::ok);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, 1s), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 2u);
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, kWaitForever), ReadStatus::publisher_gone);
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::publisher_gone);
}

TEST(ShmRingSemantics, SwitchingToABiggerSegmentLosesNothing) {
  ShmWriter old_writer = ShmWriter::create(config(64, 2));
  ReaderOptions options;
  options.buffers = 2;
  ShmReader old_reader = ShmReader::attach(old_writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  for (std::uint64_t s = 1; s <= 3; ++s) ASSERT_EQ(old_writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  ASSERT_EQ(old_reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 3u);  // lagged 3 > 2: skipped to the newest

  ASSERT_EQ(old_writer.write(packet(64, 4).data(), 64), WriteStatus::ok);
  RingConfig bigger = config(64, 8);
  bigger.first_sequence = old_writer.last_sequence() + 1;
  ShmWriter new_writer = ShmWriter::create(bigger);
  ASSERT_EQ(new_writer.write(packet(64, 5).data(), 64), WriteStatus::ok);  // before the subscriber moved
  old_writer.close_replaced();

  ASSERT_EQ(old_reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 4u);
  EXPECT_EQ(old_reader.read(buffer.data(), buffer.size(), info, 1s), ReadStatus::segment_replaced);

  ReaderOptions resume = options;
  resume.buffers = 8;
  resume.resume_after = old_reader.last_sequence();
  ShmReader new_reader = ShmReader::attach(new_writer.fd(), resume);
  ASSERT_EQ(new_writer.write(packet(64, 6).data(), 64), WriteStatus::ok);
  for (std::uint64_t s = 5; s <= 6; ++s) {
    ASSERT_EQ(new_reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_EQ(buffer, packet(64, s));
  }
}

// write_as(): a relayed stream keeps its writer's numbers; numbers it jumps
// over count as lost, for every buffers/lag policy and for borrows.
TEST(ShmRingSemantics, WriteAsJumpsCountAsLost) {
  ShmWriter writer = ShmWriter::create(config(64, 8));
  auto reader = [&](std::uint32_t buffers, LagPolicy on_lag) {
    ReaderOptions options;
    options.buffers = buffers;
    options.on_lag = on_lag;
    return ShmReader::attach(writer.fd(), options);
  };
  ShmReader single = reader(1, LagPolicy::skip_to_newest);
  ShmReader newest = reader(8, LagPolicy::skip_to_newest);
  ShmReader window = reader(8, LagPolicy::keep_latest_window);
  ShmReader borrower = reader(8, LagPolicy::skip_to_newest);

  std::vector<std::byte> buffer(64);
  SampleInfo info;
  auto write_as = [&](std::uint64_t s) { return writer.write_as(s, packet(64, s).data(), 64, double(s)); };
  auto expect_read = [&](ShmReader& from, std::uint64_t sequence, std::uint64_t lost) {
    ASSERT_EQ(from.read(buffer.data(), buffer.size(), info), ReadStatus::ok) << sequence;
    EXPECT_EQ(info.sequence, sequence);
    EXPECT_EQ(info.lost, lost) << sequence;
    EXPECT_EQ(buffer, packet(64, sequence));
    EXPECT_EQ(info.timestamp, double(sequence));
  };
  auto expect_borrow = [&](std::uint64_t sequence, std::uint64_t lost) {
    BorrowedSample sample;
    ASSERT_EQ(borrower.borrow(sample), ReadStatus::ok) << sequence;
    EXPECT_EQ(sample.info().sequence, sequence);
    EXPECT_EQ(sample.info().lost, lost) << sequence;
    EXPECT_EQ(std::memcmp(sample.data(), packet(64, sequence).data(), 64), 0);
  };

  ASSERT_EQ(write_as(3), WriteStatus::ok);  // a fresh ring may start anywhere
  EXPECT_EQ(writer.last_sequence(), 3u);
  expect_read(single, 3, 2);
  ASSERT_EQ(write_as(4), WriteStatus::ok);
  ASSERT_EQ(write_as(7), WriteStatus::ok);  // 5, 6 never existed
  ASSERT_EQ(write_as(8), WriteStatus::ok);
  expect_read(single, 8, 4);
  for (ShmReader* buffered : {&newest, &window}) {
    expect_read(*buffered, 3, 2);
    expect_read(*buffered, 4, 0);
    expect_read(*buffered, 7, 2);
    expect_read(*buffered, 8, 0);
    EXPECT_EQ(buffered->read(buffer.data(), buffer.size(), info), ReadStatus::no_data);
  }
  expect_borrow(3, 2);
  expect_borrow(4, 0);
  expect_borrow(7, 2);

  EXPECT_EQ(write_as(8), WriteStatus::bad_sequence);  // never backwards or twice
  EXPECT_EQ(write_as(2), WriteStatus::bad_sequence);
  EXPECT_EQ(writer.write_as(std::uint64_t{1} << 63, buffer.data(), 64, 0), WriteStatus::bad_sequence);
  std::vector<std::byte> big(65);
  EXPECT_EQ(writer.write_as(9, big.data(), big.size(), 0), WriteStatus::packet_too_large);
  EXPECT_EQ(writer.last_sequence(), 8u);  // a failed write_as changes nothing

  // Jumps within the window (3 of 8 slots skipped) ...
  ASSERT_EQ(write_as(9), WriteStatus::ok);
  ASSERT_EQ(write_as(13), WriteStatus::ok);
  ASSERT_EQ(writer.write(packet(64, 14).data(), 64, 14.0), WriteStatus::ok);  // write() continues after it
  for (ShmReader* buffered : {&newest, &window}) {
    expect_read(*buffered, 9, 0);
    expect_read(*buffered, 13, 3);
    expect_read(*buffered, 14, 0);
  }
  expect_borrow(8, 0);
  expect_borrow(9, 0);
  expect_borrow(13, 3);
  expect_borrow(14, 0);
  expect_read(single, 14, 5);

  // ... and beyond it: the lag policies apply, the window's oldest slots
  // may be numbers that never existed.
  ASSERT_EQ(write_as(15), WriteStatus::ok);
  ASSERT_EQ(write_as(30), WriteStatus::ok);
  ASSERT_EQ(write_as(31), WriteStatus::ok);
  expect_read(newest, 31, 16);  // skip to the newest
  expect_read(window, 30, 15);  // the window 24..31 holds only 30 and 31
  expect_read(window, 31, 0);
  expect_read(single, 31, 16);
  expect_borrow(31, 16);  // borrowers with buffers 8 skip like readers
}

// A reader that resumes after a point the ring never reached still starts
// right there, and one that resumes inside a gap counts only its part.
TEST(ShmRingSemantics, WriteAsFromAStartingPoint) {
  RingConfig start = config(64, 4);
  start.first_sequence = 101;  // the stream's packets up to 100 are not this ring's
  ShmWriter writer = ShmWriter::create(start);
  ReaderOptions options;
  options.buffers = 4;
  options.resume_after = 100;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  ReaderOptions late = options;
  late.resume_after = 103;
  ShmReader late_reader = ShmReader::attach(writer.fd(), late);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(writer.write_as(105, packet(64, 105).data(), 64, 0), WriteStatus::ok);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 105u);
  EXPECT_EQ(info.lost, 4u);  // 101..104 lost
  ASSERT_EQ(late_reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 105u);
  EXPECT_EQ(info.lost, 1u);  // only 104 was its
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 20ms), ReadStatus::timeout);
}

TEST(ShmRingSemantics, CorruptSharedStateGivesErrorsNotCrashes) {
  ShmWriter writer = ShmWriter::create(config(64, 2));
  ReaderOptions options;
  options.buffers = 2;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);

  // A second mapping of the same segment plays the part of a buggy peer.
  const std::size_t size = static_cast<std::size_t>(::lseek(writer.fd(), 0, SEEK_END));
  void* raw = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, writer.fd(), 0);
  ASSERT_NE(raw, MAP_FAILED);
  auto* base = static_cast<unsigned char*>(raw);
  std::uint64_t ring_offset = 0;
  std::memcpy(&ring_offset, base + 24, sizeof(ring_offset));
  std::uint32_t saved = 0;
  std::memcpy(&saved, base + ring_offset + 4, sizeof(saved));  // ring[1] names packet 1's slot
  const std::uint32_t bogus = 0xffffffffu;
  EXPECT_TRUE(writer.shared_state_intact());
  std::memcpy(base + ring_offset + 4, &bogus, sizeof(bogus));
  EXPECT_FALSE(writer.shared_state_intact()) << "the writer notices (its owner then replaces the segment)";

  std::vector<std::byte> buffer(64);
  SampleInfo info;
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::corrupt_segment);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample), ReadStatus::corrupt_segment);
  std::memcpy(base + ring_offset + 4, &saved, sizeof(saved));
  EXPECT_TRUE(writer.shared_state_intact());
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  std::uint64_t head = 0;
  std::memcpy(&head, base + 128, sizeof head);  // SegmentHeader::head_sequence (its own cache line)
  EXPECT_EQ(head, 1u);
  const std::uint64_t wrong = 77;
  std::memcpy(base + 128, &wrong, sizeof wrong);
  EXPECT_FALSE(writer.shared_state_intact());
  std::memcpy(base + 128, &head, sizeof head);
  ::munmap(raw, size);
}

TEST(ShmRingSemantics, WriteProtectedReadersCannotWriteThePublishersPart) {
  ShmWriter writer = ShmWriter::create(config(64, 2));
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  // A subscriber that writes into a packet it may only read dies of it
  // (SIGSEGV, reported here as exit code 42, also under the sanitizers),
  // and the packet is unchanged for everyone else.
  Child child([&] {
    ::signal(SIGSEGV, [](int) { ::_exit(42); });
    ReaderOptions options;
    options.buffers = 2;
    options.resume_after = 0;
    options.write_protect = true;
    ShmReader reader = ShmReader::attach(writer.fd(), options);
    BorrowedSample sample;
    if (reader.borrow(sample) != ReadStatus::ok) return 3;
    std::memset(const_cast<void*>(sample.data()), 0xee, 64);
    return 0;  // not reached: the page is read-only
  });
  EXPECT_EQ(child.wait(), 42);
  ReaderOptions options;
  options.resume_after = 0;
  options.buffers = 2;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(buffer, packet(64, 1));
}

TEST(ShmRingSemantics, GarbageInTheReaderAreaStopsTheWriterWithoutHarm) {
  ShmWriter writer = ShmWriter::create(config(64, 2));
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  // What a subscriber can write: every borrow state set, so every spare
  // looks pinned. The writer refuses to write instead of overwriting a
  // packet someone might read; its owner replaces the segment.
  const std::size_t size = static_cast<std::size_t>(::lseek(writer.fd(), 0, SEEK_END));
  void* raw = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, writer.fd(), 0);
  ASSERT_NE(raw, MAP_FAILED);
  std::uint64_t shared_offset = 0;
  std::memcpy(&shared_offset, static_cast<unsigned char*>(raw) + 48, sizeof shared_offset);
  ASSERT_GT(shared_offset, 0u);
  ASSERT_LT(shared_offset, size);
  std::memset(static_cast<unsigned char*>(raw) + shared_offset, 0xff, size - shared_offset);
  EXPECT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::no_free_slot);
  EXPECT_EQ(writer.loan(), nullptr);
  ::munmap(raw, size);
  // The replacement continues the numbering; readers drain and follow.
  RingConfig next = config(64, 2);
  next.first_sequence = writer.last_sequence() + 1;
  ShmWriter replacement = ShmWriter::create(next);
  writer.close_replaced();
  ASSERT_EQ(replacement.write(packet(64, 2).data(), 64), WriteStatus::ok);
  EXPECT_EQ(replacement.last_sequence(), 2u);
}

TEST(ShmRingSemantics, ASegmentMadeAheadTakesOverTheNumbering) {
  ShmWriter writer = ShmWriter::create(config(64, 2));
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  ShmWriter bigger = ShmWriter::create(config(64, 8));
  ASSERT_TRUE(bigger.renumber(writer.last_sequence() + 1));
  EXPECT_EQ(bigger.last_sequence(), 1u);
  ReaderOptions options;
  options.resume_after = 1;
  ShmReader reader = ShmReader::attach(bigger.fd(), options);
  ASSERT_EQ(bigger.write(packet(64, 2).data(), 64), WriteStatus::ok);
  EXPECT_FALSE(bigger.renumber(5)) << "only before the first packet";
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 2u);
  EXPECT_EQ(info.lost, 0u);
}

// ------------------------------------------------------------------ borrowing

TEST(ShmRingBorrow, BorrowedSlotIsNeverOverwritten) {
  ShmWriter writer = ShmWriter::create(config(256, 1, 2));
  ShmReader reader = ShmReader::attach(writer.fd());
  ASSERT_EQ(writer.write(packet(256, 1).data(), 256, 1.5), WriteStatus::ok);
  BorrowedSample sample;
  ASSERT_EQ(reader.borrow(sample), ReadStatus::ok);
  ASSERT_TRUE(sample.valid());
  EXPECT_EQ(sample.info().sequence, 1u);
  EXPECT_EQ(sample.info().timestamp, 1.5);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(sample.data()) % 32, 0u);
  const std::vector<std::byte> expected = packet(256, 1);

  for (std::uint64_t s = 2; s <= 200; ++s) {  // many times around all slots
    ASSERT_EQ(writer.write(packet(256, s).data(), 256), WriteStatus::ok);
    ASSERT_EQ(std::memcmp(sample.data(), expected.data(), 256), 0) << "after write " << s;
  }
  // Copying reads still work while a slot is pinned.
  std::vector<std::byte> buffer(256);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 200u);
  EXPECT_EQ(buffer, packet(256, 200));
  sample.release();
  EXPECT_FALSE(sample.valid());
}

TEST(ShmRingBorrow, LimitsPerReaderAndPerSegment) {
  ShmWriter writer = ShmWriter::create(config(64, 4, 3));
  ReaderOptions options;
  options.buffers = 4;
  options.max_borrows = 2;
  ShmReader first = ShmReader::attach(writer.fd(), options);
  ShmReader second = ShmReader::attach(writer.fd(), options);
  for (std::uint64_t s = 1; s <= 4; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);

  BorrowedSample a, b, c, d, e;
  ASSERT_EQ(first.borrow(a), ReadStatus::ok);
  ASSERT_EQ(first.borrow(b), ReadStatus::ok);
  EXPECT_EQ(first.borrow(c), ReadStatus::borrow_limit);  // reader's own limit
  EXPECT_EQ(a.info().sequence, 1u);
  EXPECT_EQ(b.info().sequence, 2u);

  ASSERT_EQ(second.borrow(c), ReadStatus::ok);  // third and last token of the segment
  EXPECT_EQ(second.borrow(d), ReadStatus::borrow_limit);
  a.release();
  ASSERT_EQ(second.borrow(d), ReadStatus::ok);  // the token first gave back
  EXPECT_EQ(d.info().sequence, 2u);

  // The writer keeps going with 3 slots pinned.
  for (std::uint64_t s = 5; s <= 50; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  EXPECT_EQ(std::memcmp(b.data(), packet(64, 2).data(), 64), 0);
  EXPECT_EQ(std::memcmp(c.data(), packet(64, 1).data(), 64), 0);

  // Moving keeps the pin; a sample may outlive its reader.
  e = std::move(b);
  EXPECT_FALSE(b.valid());
  first = ShmReader::attach(writer.fd(), options);
  EXPECT_EQ(std::memcmp(e.data(), packet(64, 2).data(), 64), 0);
  e.release();
}

TEST(ShmRingBorrow, PinnedCopiesUseATokenOnlyWhileCopying) {
  ShmWriter writer = ShmWriter::create(config(64, 4, 1));
  ReaderOptions options;
  options.buffers = 4;
  options.optimistic_copies = 0;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  for (std::uint64_t s = 1; s <= 3; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(reader.stats().pinned_copies, 1u);
  EXPECT_EQ(buffer, packet(64, 1));
  BorrowedSample sample;  // the only token is free again
  ASSERT_EQ(reader.borrow(sample), ReadStatus::ok);
  EXPECT_EQ(sample.info().sequence, 2u);
  // With the token borrowed, copies fall back to optimistic ones.
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 3u);
  EXPECT_EQ(reader.stats().pinned_copies, 1u);
  EXPECT_EQ(buffer, packet(64, 3));
}

TEST(ShmRingBorrow, NoBorrowSlotsMeansNoBorrowing) {
  ShmWriter writer = ShmWriter::create(config(64, 1, 0));
  ShmReader reader = ShmReader::attach(writer.fd());
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample), ReadStatus::borrow_limit);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
}

// ------------------------------------------------------------------ blocking

TEST(ShmRingBlocking, TimeoutReturnsInTime) {
  ShmWriter writer = ShmWriter::create(config(64));
  ShmReader reader = ShmReader::attach(writer.fd());
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  const auto start = Clock::now();
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 50ms), ReadStatus::timeout);
  const auto elapsed = Clock::now() - start;
  EXPECT_GE(elapsed, 50ms);
  EXPECT_LT(elapsed, 2s);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample, 10ms), ReadStatus::timeout);
}

TEST(ShmRingBlocking, UnblockWakesABlockedReader) {
  ShmWriter writer = ShmWriter::create(config(64));
  ShmReader reader = ShmReader::attach(writer.fd());
  std::atomic<int> result{-1};
  std::thread blocked([&] {
    std::vector<std::byte> buffer(64);
    SampleInfo info;
    result = static_cast<int>(reader.read(buffer.data(), buffer.size(), info, kWaitForever));
  });
  const bool asleep = wait_until([&] { return writer.sleeping_readers() == 1; }, 5s);
  reader.unblock();
  blocked.join();
  ASSERT_TRUE(asleep);
  EXPECT_EQ(result.load(), static_cast<int>(ReadStatus::unblocked));
  EXPECT_EQ(writer.sleeping_readers(), 0u);

  // An unblock with nobody blocked is kept for the next read that would block;
  // data that is already there is delivered first.
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  reader.unblock();
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 5s), ReadStatus::ok);
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 5s), ReadStatus::unblocked);
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 10ms), ReadStatus::timeout);
}

// The publisher in a child process waits until the reader sleeps, then writes once.
void expect_write_wakes_sleeping_reader(const SpinPolicy& spin) {
  SocketPair sockets;
  Child publisher([&] {
    ShmWriter writer = ShmWriter::create(config(64));
    send_fd(sockets.child.get(), writer.fd());
    if (receive_byte(sockets.child.get(), 10s) != 'a') return 2;  // reader attached
    if (!wait_until([&] { return writer.sleeping_readers() == 1; }, 10s)) return 3;
    if (writer.write(packet(64, 1).data(), 64) != WriteStatus::ok) return 4;
    return receive_byte(sockets.child.get(), 10s) == 'd' ? 0 : 5;
  });
  ReaderOptions options;
  options.spin = spin;
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()), options);
  send_byte(sockets.parent.get(), 'a');
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  const auto start = Clock::now();
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, 10s), ReadStatus::ok);
  EXPECT_LT(Clock::now() - start, 9s);
  EXPECT_EQ(info.sequence, 1u);
  EXPECT_EQ(buffer, packet(64, 1));
  EXPECT_GE(reader.stats().futex_sleeps, 1u);
  send_byte(sockets.parent.get(), 'd');
  EXPECT_EQ(publisher.wait(), 0);
}

TEST(ShmRingBlocking, WriteWakesSleepingReaderWithoutSpinning) {
  SpinPolicy no_spin;
  no_spin.min_spin = 0ns;
  no_spin.max_spin = 0ns;
  expect_write_wakes_sleeping_reader(no_spin);
}

TEST(ShmRingBlocking, WriteWakesSleepingReaderAfterSpinning) { expect_write_wakes_sleeping_reader(SpinPolicy{}); }

// Pins the calling thread to one CPU for its lifetime.
class PinnedThread {
 public:
  explicit PinnedThread(int cpu) {
    ::sched_getaffinity(0, sizeof(previous_), &previous_);
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    ::sched_setaffinity(0, sizeof(one), &one);
  }
  ~PinnedThread() { ::sched_setaffinity(0, sizeof(previous_), &previous_); }
  PinnedThread(const PinnedThread&) = delete;
  PinnedThread& operator=(const PinnedThread&) = delete;

 private:
  cpu_set_t previous_;
};

// The first two CPUs this process may run on, or {-1, -1}.
std::pair<int, int> two_allowed_cpus() {
  cpu_set_t allowed;
  if (::sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return {-1, -1};
  std::vector<int> cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE && cpus.size() < 2; ++cpu) {
    if (CPU_ISSET(cpu, &allowed)) cpus.push_back(cpu);
  }
  return cpus.size() == 2 ? std::make_pair(cpus[0], cpus[1]) : std::make_pair(-1, -1);
}

// A reader learns its spin limit from when packets come, not from when it
// got a CPU back after sleeping: here its wake-up is delayed (SIGSTOP) far
// beyond max_spin although the packet came soon, and it must still spin
// longer afterwards. Long limits (20..200 ms) keep scheduling noise out;
// reader and writer on different CPUs, where readers spin (not yield).
TEST(ShmRingBlocking, LateWakeUpDoesNotShortenSpinning) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  PinnedThread pinned(writer_cpu);
  SocketPair sockets;
  ShmWriter writer = ShmWriter::create(config(64));
  Child reader_process([&, reader_cpu = reader_cpu] {
    PinnedThread reader_pinned(reader_cpu);
    ReaderOptions options;
    options.spin.min_spin = 20ms;
    options.spin.max_spin = 200ms;
    ShmReader reader = ShmReader::attach(writer.fd(), options);
    std::vector<std::byte> buffer(64);
    SampleInfo info;
    std::uint64_t spins_before_last = 0;
    for (int i = 0; i < 6; ++i) {
      spins_before_last = reader.stats().spin_wakeups;
      send_byte(sockets.child.get(), 'r');  // about to read
      if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
    }
    return reader.stats().spin_wakeups == spins_before_last + 1 ? 0 : 10;  // the last packet caught spinning?
  });
  std::uint64_t sequence = 0;
  auto write_when_asleep = [&](std::chrono::milliseconds after) {
    ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'r');
    ASSERT_TRUE(wait_until([&] { return writer.sleeping_readers() == 1; }, 10s));
    std::this_thread::sleep_for(after);
    ASSERT_EQ(writer.write(packet(64, ++sequence).data(), 64), WriteStatus::ok);
  };
  // Packets long after max_spin halve the limit down to min_spin (200 -> 20 ms).
  for (int i = 0; i < 4; ++i) {
    write_when_asleep(220ms);
    ASSERT_FALSE(HasFatalFailure());
  }
  // A packet right after the reader fell asleep, but the reader gets no CPU for 250 ms.
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'r');
  ASSERT_TRUE(wait_until([&] { return writer.sleeping_readers() == 1; }, 10s));
  ASSERT_EQ(::kill(reader_process.pid(), SIGSTOP), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(reader_process.pid(), &status, WUNTRACED), reader_process.pid());
  ASSERT_TRUE(WIFSTOPPED(status));
  ASSERT_EQ(writer.write(packet(64, ++sequence).data(), 64), WriteStatus::ok);
  std::this_thread::sleep_for(250ms);
  ASSERT_EQ(::kill(reader_process.pid(), SIGCONT), 0);
  // It came ~20 ms after the wait began, so the limit doubled to 40 ms: a
  // packet 30 ms into the next wait is caught spinning (at 20 ms it would sleep).
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'r');
  std::this_thread::sleep_for(30ms);
  ASSERT_EQ(writer.write(packet(64, ++sequence).data(), 64), WriteStatus::ok);
  EXPECT_EQ(reader_process.wait(), 0);
}

TEST(ShmRingBlocking, PublisherDeathEndsBlockingRead) {
  SocketPair sockets;
  Child publisher([&] {
    ShmWriter writer = ShmWriter::create(config(64));
    send_fd(sockets.child.get(), writer.fd());
    if (receive_byte(sockets.child.get(), 10s) != 'a') return 2;
    if (!wait_until([&] { return writer.sleeping_readers() == 1; }, 10s)) return 3;
    ::kill(::getpid(), SIGKILL);  // die without closing anything
    return 4;
  });
  ReaderOptions options;
  options.liveness_check_interval = 20ms;
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()), options);
  EXPECT_TRUE(reader.publisher_alive());
  send_byte(sockets.parent.get(), 'a');
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  const auto start = Clock::now();
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, kWaitForever), ReadStatus::publisher_gone);
  EXPECT_LT(Clock::now() - start, 10s);
  EXPECT_FALSE(reader.publisher_alive());
  EXPECT_EQ(publisher.wait(), -2);
}

// Consecutive reads given one WaitDeadline share it, and its clock starts
// only when a read first has to wait.
TEST(ShmRingBlocking, SharedWaitDeadline) {
  ShmWriter writer = ShmWriter::create(config(64, 4));
  ReaderOptions options;
  options.buffers = 4;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  WaitDeadline deadline(50ms);
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  std::this_thread::sleep_for(100ms);  // longer than the timeout, but nobody waited yet
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, deadline), ReadStatus::ok);
  auto start = Clock::now();
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, deadline), ReadStatus::timeout);
  EXPECT_GE(Clock::now() - start, 50ms);
  // Expired: the next read only looks once (never sleeps: a count, not a time,
  // which a loaded machine stretches), and still gets a packet that is there.
  const std::uint64_t sleeps = reader.stats().futex_sleeps;
  const auto expired_at = deadline.at(Clock::now());
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, deadline), ReadStatus::timeout);
  ASSERT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::ok);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample, deadline), ReadStatus::ok);
  EXPECT_EQ(sample.info().sequence, 2u);
  EXPECT_EQ(reader.stats().futex_sleeps, sleeps);
  EXPECT_EQ(deadline.at(Clock::now()), expired_at);
}

// The first CPU this process may run on.
int first_allowed_cpu() {
  cpu_set_t allowed;
  if (::sched_getaffinity(0, sizeof(allowed), &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) return cpu;
    }
  }
  return 0;
}

// Ping-pong on one CPU, the partner working 200 µs (far beyond max_spin) per
// echo: each wait brings exactly one packet, so the reader keeps handing the
// CPU over by yielding and never backs off to futex sleeps for it.
TEST(ShmRingBlocking, SameCpuPartnerThatWorksLongIsNotAHog) {
  PinnedThread pinned(first_allowed_cpu());  // the child inherits it
  SocketPair sockets;
  ShmWriter ping = ShmWriter::create(config(64));
  Child echo([&] {
    ShmWriter pong = ShmWriter::create(config(64));
    send_fd(sockets.child.get(), pong.fd());
    ShmReader reader = ShmReader::attach(ping.fd());
    send_byte(sockets.child.get(), 'a');
    std::vector<std::byte> buffer(64);
    SampleInfo info;
    for (int i = 0; i < 50; ++i) {
      if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
      const auto busy_until = Clock::now() + 200us;
      while (Clock::now() < busy_until) {
      }
      if (pong.write(buffer.data(), buffer.size()) != WriteStatus::ok) return 3;
    }
    return receive_byte(sockets.child.get(), 10s) == 'd' ? 0 : 4;  // keep pong open until read
  });
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()));
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'a');
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  for (std::uint64_t s = 1; s <= 50; ++s) {
    ASSERT_EQ(ping.write(packet(64, s).data(), 64), WriteStatus::ok);
    ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, 10s), ReadStatus::ok);
    ASSERT_EQ(buffer, packet(64, s));
  }
  send_byte(sockets.parent.get(), 'd');
  EXPECT_EQ(reader.stats().yield_backoffs, 0u);
  EXPECT_EQ(echo.wait(), 0);
}

// A publisher streaming on the reader's CPU writes many packets during a
// yield: the reader then sleeps in the kernel for a while instead.
TEST(ShmRingBlocking, SameCpuStreamingPublisherMakesTheReaderBackOff) {
  PinnedThread pinned(first_allowed_cpu());  // the child inherits it
  SocketPair sockets;
  Child publisher([&] {
    ShmWriter stream = ShmWriter::create(config(64, 256));
    send_fd(sockets.child.get(), stream.fd());
    if (receive_byte(sockets.child.get(), 10s) != 'a') return 2;
    std::uint64_t s = 0;
    const auto end = Clock::now() + 5s;
    for (;;) {  // until told to stop (or 5 s): a byte on the socket ends it
      for (int i = 0; i < 1000; ++i) stream.write(packet(64, ++s).data(), 64);
      if (receive_byte(sockets.child.get(), 0ms) == 'd') return 0;
      if (Clock::now() >= end) return 3;
    }
  });
  ReaderOptions options;
  options.buffers = 256;
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()), options);
  send_byte(sockets.parent.get(), 'a');
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  const auto end = Clock::now() + 3s;
  while (reader.stats().yield_backoffs == 0 && Clock::now() < end) {
    ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, 1s), ReadStatus::ok);
  }
  send_byte(sockets.parent.get(), 'd');
  EXPECT_GT(reader.stats().yield_backoffs, 0u);
  EXPECT_EQ(publisher.wait(), 0);
}

// ------------------------------------------------------------------ streamed copies

// Bounds a read without deadline: unblocks `reader` unless destroyed within `limit`.
class UnblockAfter {
 public:
  UnblockAfter(ShmReader& reader, std::chrono::seconds limit)
      : thread_([this, &reader, limit] {
          std::unique_lock<std::mutex> lock(mutex_);
          if (!done_changed_.wait_for(lock, limit, [this] { return done_; })) reader.unblock();
        }) {}
  ~UnblockAfter() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    done_changed_.notify_all();
    thread_.join();
  }
  UnblockAfter(const UnblockAfter&) = delete;
  UnblockAfter& operator=(const UnblockAfter&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable done_changed_;
  bool done_ = false;
  std::thread thread_;
};

// A reader without deadline on another CPU copies each large packet while
// the writer is still copying it in; every byte arrives intact and in order.
TEST(ShmRingStream, ReaderOnAnotherCpuCopiesBehindTheWriter) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  constexpr std::uint32_t kSize = 4 << 20;
  constexpr std::uint64_t kPackets = 40;
  SocketPair sockets;
  Child publisher([&, writer_cpu = writer_cpu] {
    PinnedThread pinned(writer_cpu);
    ShmWriter writer = ShmWriter::create(config(kSize, 1, 0));
    send_fd(sockets.child.get(), writer.fd());
    std::vector<std::byte> staging(kSize);
    for (std::uint64_t s = 1; s <= kPackets; ++s) {
      fill_pattern(staging.data(), kSize, s);
      if (receive_byte(sockets.child.get(), 10s) != 'r') return 2;  // the reader waits for it
      if (writer.write(staging.data(), kSize) != WriteStatus::ok) return 3;
    }
    return 0;
  });
  PinnedThread pinned(reader_cpu);
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()));
  UnblockAfter bound(reader, 30s);
  std::vector<std::byte> buffer(kSize);
  for (std::uint64_t s = 1; s <= kPackets; ++s) {
    send_byte(sockets.parent.get(), 'r');
    SampleInfo info;
    ASSERT_EQ(reader.read(buffer.data(), kSize, info, kWaitForever), ReadStatus::ok);
    ASSERT_EQ(info.sequence, s);
    ASSERT_EQ(info.lost, 0u);
    ASSERT_EQ(info.size, kSize);
    ASSERT_TRUE(pattern_intact(buffer.data(), kSize, s)) << "packet " << s;
  }
  EXPECT_EQ(publisher.wait(), 0);
  // Each write starts while the reader waits for it; only scheduling noise can make it miss one.
  EXPECT_GT(reader.stats().streamed_copies, 0u);
  std::printf("    %llu of %llu packets copied behind the writer\n",
              static_cast<unsigned long long>(reader.stats().streamed_copies),
              static_cast<unsigned long long>(kPackets));
}

// A writer stalled in the middle of a packet, deterministically: its source
// buffer has an inaccessible page half-way, and the SIGSEGV handler reports
// the stall ('S') and holds the writer until the parent says go on ('c');
// meanwhile 'q' asks it how many readers sleep on the segment (a digit).
namespace stall {
int socket = -1;
std::byte* page = nullptr;
long page_size = 0;
const ShmWriter* writer = nullptr;

void on_fault(int, siginfo_t* info, void*) {
  auto* address = static_cast<std::byte*>(info->si_addr);
  if (address < page || address >= page + page_size) {
    ::signal(SIGSEGV, SIG_DFL);  // a real crash: fault again and die of it
    return;
  }
  char byte = 'S';
  if (::write(socket, &byte, 1) != 1) ::_exit(7);
  for (;;) {
    if (::read(socket, &byte, 1) != 1) ::_exit(8);
    if (byte == 'c') break;
    if (byte == 'q') {
      const char sleeping = static_cast<char>('0' + std::min<std::uint32_t>(writer->sleeping_readers(), 9));
      if (::write(socket, &sleeping, 1) != 1) ::_exit(9);
    }
  }
  ::mprotect(page, static_cast<std::size_t>(page_size), PROT_READ | PROT_WRITE);
}

// Body of a child that writes one patterned packet of `size` bytes (sequence 1)
// when the parent sends 'r', stalling half-way as described above.
std::function<int()> writer_body(int socket_fd, int cpu, std::uint32_t size) {
  return [=] {
    PinnedThread pinned(cpu);
    ShmWriter segment = ShmWriter::create(config(size, 1, 0));
    writer = &segment;
    page_size = ::sysconf(_SC_PAGESIZE);
    void* staging = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (staging == MAP_FAILED) return 2;
    fill_pattern(staging, size, 1);
    socket = socket_fd;
    page = static_cast<std::byte*>(staging) + size / 2;
    struct sigaction action {};
    action.sa_sigaction = on_fault;
    action.sa_flags = SA_SIGINFO;
    if (::sigaction(SIGSEGV, &action, nullptr) != 0) return 3;
    if (::mprotect(page, static_cast<std::size_t>(page_size), PROT_NONE) != 0) return 4;
    send_fd(socket_fd, segment.fd());
    if (receive_byte(socket_fd, 10s) != 'r') return 5;
    return segment.write(staging, size) == WriteStatus::ok ? 0 : 6;
  };
}
}  // namespace stall

// A stall::writer_body child on one CPU and a reader of its segment whose
// reads run in a thread pinned to another.
struct StallingWriterAndReader {
  static constexpr std::uint32_t kSize = 4 << 20;
  const int reader_cpu;
  SocketPair sockets;
  Child publisher;
  ShmReader reader;
  std::vector<std::byte> buffer = std::vector<std::byte>(kSize, std::byte{0x5a});
  SampleInfo info;

  StallingWriterAndReader(int writer_cpu, int reader_cpu_)
      : reader_cpu(reader_cpu_),
        publisher(stall::writer_body(sockets.child.get(), writer_cpu, kSize)),
        reader(ShmReader::attach(receive_fd(sockets.parent.get()))) {}
  int parent_socket() const { return sockets.parent.get(); }

  // Starts a read into `buffer` on the reader's CPU, then lets the writer write.
  std::future<ReadStatus> read_while_writing(std::chrono::nanoseconds timeout) {
    std::promise<void> reading;
    std::future<void> started = reading.get_future();
    std::future<ReadStatus> result = std::async(std::launch::async, [this, timeout, &reading] {
      PinnedThread pinned(reader_cpu);
      reading.set_value();
      return reader.read(buffer.data(), kSize, info, timeout);
    });
    started.wait();
    send_byte(parent_socket(), 'r');
    return result;
  }
  bool untouched() const {
    return std::all_of(buffer.begin(), buffer.end(), [](std::byte b) { return b == std::byte{0x5a}; });
  }
  // After the release: the buffer holds the whole packet 1, and the writer finished.
  void expect_whole_packet() {
    EXPECT_EQ(info.sequence, 1u);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_TRUE(pattern_intact(buffer.data(), kSize, 1));
    EXPECT_EQ(publisher.wait(), 0);
  }
};

// A read with a deadline does not follow a streamed write: when it times out
// while the writer is stalled mid-packet, the buffer is untouched (LN: a read
// that returns false leaves the buffer alone).
TEST(ShmRingStream, TimedReadLeavesTheBufferUntouchedWhileAWriteIsStalled) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  StallingWriterAndReader setup(writer_cpu, reader_cpu);
  std::future<ReadStatus> reading = setup.read_while_writing(300ms);
  ASSERT_EQ(receive_byte(setup.parent_socket(), 10s), 'S');  // it did stall mid-packet
  EXPECT_EQ(reading.get(), ReadStatus::timeout);
  EXPECT_TRUE(setup.untouched());
  EXPECT_EQ(setup.reader.stats().streamed_copies, 0u);
  send_byte(setup.parent_socket(), 'c');
  ASSERT_EQ(setup.reader.read(setup.buffer.data(), setup.kSize, setup.info, 10s), ReadStatus::ok);
  setup.expect_whole_packet();
}

// A read without deadline that follows a stream whose writer stalls gives up
// after max_spin and sleeps until the commit; the packet then arrives whole.
TEST(ShmRingStream, StalledWriterIsLeftToTheOrdinaryWait) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  StallingWriterAndReader setup(writer_cpu, reader_cpu);
  UnblockAfter bound(setup.reader, 30s);
  std::future<ReadStatus> reading = setup.read_while_writing(kWaitForever);
  ASSERT_EQ(receive_byte(setup.parent_socket(), 10s), 'S');
  // Until the reader sleeps again (it gave up following), the writer stays stalled.
  EXPECT_TRUE(wait_until(
      [&] {
        send_byte(setup.parent_socket(), 'q');
        return receive_byte(setup.parent_socket(), 10s) == '1';
      },
      10s));
  EXPECT_NE(reading.wait_for(0ms), std::future_status::ready);
  send_byte(setup.parent_socket(), 'c');
  ASSERT_EQ(reading.get(), ReadStatus::ok);
  const ReaderStats stats = setup.reader.stats();
  // It followed and gave up, unless it was still asleep from before the write when asked.
  EXPECT_EQ(stats.abandoned_streams + stats.streamed_copies, 1u);
  std::printf("    abandoned %llu, streamed %llu\n", static_cast<unsigned long long>(stats.abandoned_streams),
              static_cast<unsigned long long>(stats.streamed_copies));
  setup.expect_whole_packet();
}

// A writer that dies in the middle of a streamed packet: the follower gives
// up on the stream and its read ends with publisher_gone, not a hang.
TEST(ShmRingStream, WriterDyingMidPacketEndsTheRead) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  StallingWriterAndReader setup(writer_cpu, reader_cpu);
  UnblockAfter bound(setup.reader, 10s);
  std::future<ReadStatus> reading = setup.read_while_writing(kWaitForever);
  ASSERT_EQ(receive_byte(setup.parent_socket(), 10s), 'S');
  ASSERT_EQ(::kill(setup.publisher.pid(), SIGKILL), 0);
  EXPECT_EQ(reading.get(), ReadStatus::publisher_gone);
  EXPECT_EQ(setup.publisher.wait(), -2);
}

// The reader is waiting when a writer thread on another CPU streams a packet.
void write_when_reader_sleeps(ShmWriter& writer, int cpu, const std::vector<std::byte>& packet_bytes,
                              std::uint32_t readers = 1) {
  PinnedThread pinned(cpu);
  if (!wait_until([&] { return writer.sleeping_readers() == readers; }, 10s)) return;
  writer.write(packet_bytes.data(), packet_bytes.size());
}

// A streamed packet larger than the reader's buffer is not followed: the
// read reports buffer_too_small after the commit and leaves the buffer alone.
TEST(ShmRingStream, PacketLargerThanTheBufferIsReportedNotFollowed) {
  const auto [writer_cpu, reader_cpu] = two_allowed_cpus();
  if (writer_cpu < 0) GTEST_SKIP() << "needs two CPUs";
  constexpr std::uint32_t kSize = 1 << 20;
  ShmWriter writer = ShmWriter::create(config(kSize, 1, 0));
  PinnedThread pinned(reader_cpu);
  ShmReader reader = ShmReader::attach(writer.fd());
  UnblockAfter bound(reader, 30s);
  const std::vector<std::byte> big = packet(kSize, 1);
  std::thread publisher([&, cpu = writer_cpu] { write_when_reader_sleeps(writer, cpu, big); });
  std::vector<std::byte> buffer(kSize / 2, std::byte{0x5a});
  SampleInfo info;
  EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, kWaitForever), ReadStatus::buffer_too_small);
  publisher.join();
  EXPECT_EQ(info.size, kSize);
  EXPECT_TRUE(std::all_of(buffer.begin(), buffer.end(), [](std::byte b) { return b == std::byte{0x5a}; }));
  EXPECT_EQ(reader.stats().streamed_copies, 0u);
  // Still unread: a big enough buffer gets it.
  std::vector<std::byte> whole(kSize);
  ASSERT_EQ(reader.read(whole.data(), whole.size(), info), ReadStatus::ok);
  EXPECT_EQ(whole, big);
}

// On the writer's CPU a reader would only keep the writer from running: it
// waits for the commit instead of following.
TEST(ShmRingStream, ReaderOnTheWritersCpuDoesNotFollow) {
  const int cpu = first_allowed_cpu();
  ASSERT_GE(cpu, 0);
  constexpr std::uint32_t kSize = 1 << 20;
  ShmWriter writer = ShmWriter::create(config(kSize, 1, 0));
  PinnedThread pinned(cpu);
  ShmReader reader = ShmReader::attach(writer.fd());
  UnblockAfter bound(reader, 30s);
  std::vector<std::byte> buffer(kSize);
  for (std::uint64_t s = 1; s <= 5; ++s) {
    const std::vector<std::byte> bytes = packet(kSize, s);
    std::thread publisher([&] { write_when_reader_sleeps(writer, cpu, bytes); });
    SampleInfo info;
    EXPECT_EQ(reader.read(buffer.data(), buffer.size(), info, kWaitForever), ReadStatus::ok);
    publisher.join();
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(buffer, bytes);
  }
  EXPECT_EQ(reader.stats().streamed_copies, 0u);
}

// ------------------------------------------------------------------ cross-process

TEST(ShmRingCrossProcess, DescriptorPassingOverSocketpair) {
  SocketPair sockets;
  ShmWriter writer = ShmWriter::create(config(128, 4));
  Child subscriber([&] {
    ReaderOptions options;
    options.buffers = 4;
    ShmReader reader = ShmReader::attach(receive_fd(sockets.child.get()), options);
    send_byte(sockets.child.get(), 'a');
    std::vector<std::byte> buffer(128);
    SampleInfo info;
    for (std::uint64_t s = 1; s <= 3; ++s) {
      if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
      if (info.sequence != s || info.lost != 0 || buffer != packet(128, s)) return 3;
    }
    return 0;
  });
  send_fd(sockets.parent.get(), writer.fd());
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'a');
  for (std::uint64_t s = 1; s <= 3; ++s) ASSERT_EQ(writer.write(packet(128, s).data(), 128), WriteStatus::ok);
  EXPECT_EQ(subscriber.wait(), 0);
}

TEST(ShmRingCrossProcess, ReceiveFdErrors) {
  {
    SocketPair sockets;
    send_byte(sockets.child.get());  // data without a descriptor
    EXPECT_THROW(receive_fd(sockets.parent.get()), ShmError);
  }
  {
    SocketPair sockets;
    sockets.child.reset();
    EXPECT_THROW(receive_fd(sockets.parent.get()), ShmError);
  }
}

TEST(ShmRingCrossProcess, ManySubscribersGetEveryPacketInOrder) {
  constexpr int kSubscribers = 4;
  constexpr std::uint64_t kPackets = 2000;
  ShmWriter writer = ShmWriter::create(config(96, kPackets, 0));
  std::vector<std::unique_ptr<SocketPair>> sockets;
  std::vector<std::unique_ptr<Child>> children;
  for (int i = 0; i < kSubscribers; ++i) {
    sockets.push_back(std::make_unique<SocketPair>());
    SocketPair& pair = *sockets.back();
    children.push_back(std::make_unique<Child>([&pair] {
      ReaderOptions options;
      options.buffers = static_cast<std::uint32_t>(kPackets);
      ShmReader reader = ShmReader::attach(receive_fd(pair.child.get()), options);
      send_byte(pair.child.get(), 'a');
      std::vector<std::byte> buffer(96);
      SampleInfo info;
      for (std::uint64_t s = 1; s <= kPackets; ++s) {
        if (reader.read(buffer.data(), buffer.size(), info, 10s) != ReadStatus::ok) return 2;
        if (info.sequence != s || info.lost != 0 || !pattern_intact(buffer.data(), 96, s)) return 3;
      }
      std::vector<std::byte> rest(96);
      return reader.read(rest.data(), rest.size(), info, 10s) == ReadStatus::publisher_gone ? 0 : 4;
    }));
  }
  for (auto& pair : sockets) {
    send_fd(pair->parent.get(), writer.fd());
    ASSERT_EQ(receive_byte(pair->parent.get(), 10s), 'a');
  }
  std::vector<std::byte> buffer(96);
  for (std::uint64_t s = 1; s <= kPackets; ++s) {
    fill_pattern(buffer.data(), buffer.size(), s);
    ASSERT_EQ(writer.write(buffer.data(), buffer.size()), WriteStatus::ok);
  }
  writer.close();
  for (auto& child : children) EXPECT_EQ(child->wait(), 0);
}

// A publisher child writes patterned packets as fast as it can until the
// parent has checked `target` packets (or 3 s passed); the parent checks
// every byte of everything it receives.

struct HammerResult {
  std::uint64_t received = 0;
  std::uint64_t torn = 0;
  std::uint64_t out_of_order = 0;
  std::uint64_t bad_loss_count = 0;
  ReaderStats stats;
};

HammerResult hammer(std::uint32_t message_size, std::uint32_t history, std::uint32_t borrow_slots, bool borrow,
                    bool zero_copy_writes, std::uint32_t optimistic_copies = 3, std::uint64_t target = 2000) {
  SocketPair sockets;
  Child publisher([&] {
    ShmWriter writer = ShmWriter::create(config(message_size, history, borrow_slots));
    send_fd(sockets.child.get(), writer.fd());
    if (receive_byte(sockets.child.get(), 10s) != 'a') return 2;
    std::vector<unsigned char> staging(message_size);
    const auto end = Clock::now() + 3s;
    while (Clock::now() < end) {
      if (writer.last_sequence() % 64 == 0 && receive_byte(sockets.child.get(), 0ms) == 's') break;
      const std::uint64_t sequence = writer.last_sequence() + 1;
      if (zero_copy_writes) {
        void* slot = writer.loan();
        if (slot == nullptr) return 3;
        fill_pattern(slot, message_size, sequence);
        if (writer.commit(message_size) != WriteStatus::ok) return 4;
      } else {
        fill_pattern(staging.data(), message_size, sequence);
        if (writer.write(staging.data(), message_size) != WriteStatus::ok) return 5;
      }
    }
    return 0;  // the destructor closes the segment
  });

  ReaderOptions options;
  options.buffers = history;
  options.on_lag = LagPolicy::keep_latest_window;
  options.optimistic_copies = optimistic_copies;
  ShmReader reader = ShmReader::attach(receive_fd(sockets.parent.get()), options);
  UnblockAfter bound(reader, 30s);
  send_byte(sockets.parent.get(), 'a');
  HammerResult result;
  std::vector<unsigned char> buffer(message_size);
  std::uint64_t previous = 0;
  for (;;) {
    SampleInfo info;
    ReadStatus status;
    if (borrow) {
      BorrowedSample sample;
      status = reader.borrow(sample, 5s);
      if (status != ReadStatus::ok) break;
      info = sample.info();
      bool intact = pattern_intact(sample.data(), message_size, info.sequence);
      for (int i = 0; i < 2000; ++i) std::atomic_signal_fence(std::memory_order_seq_cst);  // hold it a moment
      intact = intact && pattern_intact(sample.data(), message_size, info.sequence);
      if (!intact) ++result.torn;
    } else {
      status = reader.read(buffer.data(), buffer.size(), info, kWaitForever);  // ends when the publisher closes
      if (status != ReadStatus::ok) break;
      if (!pattern_intact(buffer.data(), message_size, info.sequence)) ++result.torn;
    }
    if (++result.received == target) send_byte(sockets.parent.get(), 's');
    if (info.sequence <= previous) ++result.out_of_order;
    if (previous != 0 && info.lost != info.sequence - previous - 1) ++result.bad_loss_count;
    previous = info.sequence;
  }
  EXPECT_EQ(publisher.wait(), 0);
  result.stats = reader.stats();
  return result;
}

void expect_clean(const HammerResult& result) {
  EXPECT_GE(result.received, 50u);  // normally the target; a heavily loaded machine gets fewer
  EXPECT_EQ(result.torn, 0u);
  EXPECT_EQ(result.out_of_order, 0u);
  EXPECT_EQ(result.bad_loss_count, 0u);
  std::printf("    received %llu, torn copies retried %llu, pinned copies %llu, streamed copies %llu\n",
              static_cast<unsigned long long>(result.received),
              static_cast<unsigned long long>(result.stats.torn_copies),
              static_cast<unsigned long long>(result.stats.pinned_copies),
              static_cast<unsigned long long>(result.stats.streamed_copies));
}

TEST(ShmRingCrossProcess, NoTornCopiesSingleBufferLargePackets) { expect_clean(hammer(65536, 1, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornCopiesWithPinFallback) { expect_clean(hammer(65536, 1, 2, false, true)); }
TEST(ShmRingCrossProcess, NoTornPinnedCopies) {
  const HammerResult result = hammer(65536, 1, 2, false, false, 0);
  expect_clean(result);
  EXPECT_EQ(result.stats.torn_copies, 0u);  // pinned before copying: nothing to retry
  EXPECT_EQ(result.stats.pinned_copies, result.received);
}
// Streamed writes (>= 64 KiB) that lap their followers: the follower's final check must catch it.
TEST(ShmRingCrossProcess, NoTornStreamedCopiesSingleBuffer) { expect_clean(hammer(1 << 20, 1, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornStreamedCopiesManyBuffers) { expect_clean(hammer(256 << 10, 4, 0, false, false)); }
TEST(ShmRingCrossProcess, NoTornCopiesSmallPacketsManyBuffers) {
  expect_clean(hammer(64, 64, 2, false, false, 3, 200000));
}
TEST(ShmRingCrossProcess, NoTornBorrowsSingleBuffer) { expect_clean(hammer(16384, 1, 1, true, false)); }
TEST(ShmRingCrossProcess, NoTornBorrowsManyBuffers) { expect_clean(hammer(4096, 8, 4, true, true)); }

// A reader that dies while holding a borrow must not cost the segment a token.
TEST(ShmRingCrossProcess, DeadBorrowerTokenIsReclaimed) {
  ShmWriter writer = ShmWriter::create(config(64, 1, 1));
  SocketPair sockets;
  Child subscriber([&] {
    ShmReader reader = ShmReader::attach(receive_fd(sockets.child.get()));
    send_byte(sockets.child.get(), 'a');
    BorrowedSample sample;
    if (reader.borrow(sample, 10s) != ReadStatus::ok) return 2;
    send_byte(sockets.child.get(), 'b');
    if (receive_byte(sockets.child.get(), 10s) != 'k') return 3;
    ::kill(::getpid(), SIGKILL);  // die holding the pin and the token
    return 4;
  });
  send_fd(sockets.parent.get(), writer.fd());
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'a');
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  ASSERT_EQ(receive_byte(sockets.parent.get(), 10s), 'b');

  ShmReader reader = ShmReader::attach(writer.fd());
  ASSERT_EQ(writer.write(packet(64, 2).data(), 64), WriteStatus::ok);
  BorrowedSample sample;
  EXPECT_EQ(reader.borrow(sample), ReadStatus::borrow_limit);  // the only token is held by a live reader
  send_byte(sockets.parent.get(), 'k');
  EXPECT_EQ(subscriber.wait(), -2);
  for (std::uint64_t s = 3; s <= 20; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
  ASSERT_EQ(reader.borrow(sample), ReadStatus::ok);  // token taken over from the dead reader
  EXPECT_EQ(sample.info().sequence, 20u);
  EXPECT_EQ(std::memcmp(sample.data(), packet(64, 20).data(), 64), 0);
  sample.release();
  // The stale pin was cleared: the writer has all its spares again.
  for (std::uint64_t s = 21; s <= 40; ++s) ASSERT_EQ(writer.write(packet(64, s).data(), 64), WriteStatus::ok);
}

// ------------------------------------------------------------ ShmWakeWatch

TEST(ShmWakeWatch, CountsTheWatcherAndSeesEveryLaterWrite) {
  ShmWriter writer = ShmWriter::create({64, 4, 1, 1, "wake_watch"});
  std::optional<ShmReader> reader(ShmReader::attach(writer.fd()));
  ShmWakeWatch watch = reader->watch_wake_word();
  ASSERT_TRUE(watch.active());
  EXPECT_EQ(writer.sleeping_readers(), 1u);
  EXPECT_EQ(watch.word()->load(), watch.expected());
  ASSERT_EQ(writer.write(packet(64, 1).data(), 64), WriteStatus::ok);
  EXPECT_NE(watch.word()->load(), watch.expected());
  EXPECT_TRUE(reader->has_new_data());

  // Moving transfers the count; the watch keeps the mapping alive.
  ShmWakeWatch moved = std::move(watch);
  EXPECT_FALSE(watch.active());  // NOLINT(bugprone-use-after-move): documented state
  reader.reset();
  EXPECT_EQ(writer.sleeping_readers(), 1u);
  const std::uint32_t before_close = moved.word()->load();
  writer.close();
  EXPECT_NE(moved.word()->load(), before_close);
  moved.withdraw();
  moved.withdraw();
  EXPECT_EQ(writer.sleeping_readers(), 0u);
}

// The protocol of the class comment, with a futex sleep: a write from
// another thread always ends it, however the two interleave.
TEST(ShmWakeWatch, WritesWakeASleeperPromptly) {
  ShmWriter writer = ShmWriter::create({64, 4, 1, 1, "wake_watch"});
  ShmReader reader = ShmReader::attach(writer.fd());
  for (std::uint64_t round = 1; round <= 200; ++round) {
    std::atomic<bool> woke{false};
    std::thread sleeper([&] {
      const auto deadline = Clock::now() + 10s;
      while (Clock::now() < deadline) {
        ShmWakeWatch watch = reader.watch_wake_word();
        if (reader.has_new_data()) break;
        futex_wait(watch.word(), watch.expected(), deadline - Clock::now());
      }
      woke = true;
    });
    if (round % 2 == 0) std::this_thread::yield();
    ASSERT_EQ(writer.write(packet(64, round).data(), 64), WriteStatus::ok);
    const auto start = Clock::now();
    sleeper.join();
    EXPECT_TRUE(woke);
    EXPECT_LT(Clock::now() - start, 2s) << "round " << round;
    SampleInfo info;
    std::vector<std::byte> buffer(64);
    ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  }
  EXPECT_EQ(writer.sleeping_readers(), 0u);
}

}  // namespace
}  // namespace ln::transport
