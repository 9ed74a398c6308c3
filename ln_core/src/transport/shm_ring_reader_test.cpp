// The shared-memory ring from the reader's side: borrowing slots, blocking
// reads (timeouts, wake-ups, spinning and backing off), streamed copies of
// large packets behind the writer, and ShmWakeWatch. Children are forked by
// the test that needs them and reaped (or killed by pid) by it.
#include "transport/shm_ring_test_support.hpp"

namespace ln::transport {
namespace {

using namespace ringtest;

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
  ReaderOptions options = with_buffers(4);
  options.max_borrows = 2;
  ShmReader first = ShmReader::attach(writer.fd(), options);
  ShmReader second = ShmReader::attach(writer.fd(), options);
  write_packets(writer, 1, 4);

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
  write_packets(writer, 5, 50);
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
  ReaderOptions options = with_buffers(4);
  options.optimistic_copies = 0;
  ShmReader reader = ShmReader::attach(writer.fd(), options);
  write_packets(writer, 1, 3);
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
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(4));
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
  ReaderOptions options = with_buffers(256);
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
  std::optional<UnblockAfter> bound;  // declared before `reading`: the read ends before the bound goes
  std::future<ReadStatus> reading;

  StallingWriterAndReader(int writer_cpu, int reader_cpu_)
      : reader_cpu(reader_cpu_),
        publisher(stall::writer_body(sockets.child.get(), writer_cpu, kSize)),
        reader(ShmReader::attach(receive_fd(sockets.parent.get()))) {}
  int parent_socket() const { return sockets.parent.get(); }

  // Starts a read into `buffer` on the reader's CPU, then lets the writer write.
  std::future<ReadStatus> read_while_writing(std::chrono::nanoseconds timeout) {
    std::promise<void> reader_started;
    std::future<void> started = reader_started.get_future();
    std::future<ReadStatus> result = std::async(std::launch::async, [this, timeout, &reader_started] {
      PinnedThread pinned(reader_cpu);
      reader_started.set_value();
      return reader.read(buffer.data(), kSize, info, timeout);
    });
    started.wait();
    send_byte(parent_socket(), 'r');
    return result;
  }
  // read_while_writing(timeout) into `reading`, then waits until the writer stalls mid-packet:
  // true when it did. A read without deadline is bounded (UnblockAfter, 30 s).
  bool read_until_stalled(std::chrono::nanoseconds timeout) {
    if (timeout == kWaitForever) bound.emplace(reader, 30s);
    reading = read_while_writing(timeout);
    return receive_byte(parent_socket(), 10s) == 'S';
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
  ASSERT_TRUE(setup.read_until_stalled(300ms));  // it did stall mid-packet
  EXPECT_EQ(setup.reading.get(), ReadStatus::timeout);
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
  ASSERT_TRUE(setup.read_until_stalled(kWaitForever));
  // Until the reader sleeps again (it gave up following), the writer stays stalled.
  EXPECT_TRUE(wait_until(
      [&] {
        send_byte(setup.parent_socket(), 'q');
        return receive_byte(setup.parent_socket(), 10s) == '1';
      },
      10s));
  EXPECT_NE(setup.reading.wait_for(0ms), std::future_status::ready);
  send_byte(setup.parent_socket(), 'c');
  ASSERT_EQ(setup.reading.get(), ReadStatus::ok);
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
  ASSERT_TRUE(setup.read_until_stalled(kWaitForever));
  ASSERT_EQ(::kill(setup.publisher.pid(), SIGKILL), 0);
  EXPECT_EQ(setup.reading.get(), ReadStatus::publisher_gone);
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
