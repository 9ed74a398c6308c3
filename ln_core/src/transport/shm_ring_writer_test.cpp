// The shared-memory ring from the writer's side: configuration, creating
// and attaching segments, and what readers get of what is written (order,
// loss, loans, bigger segments, corrupted state).
#include "transport/shm_ring_test_support.hpp"

namespace ln::transport {
namespace {

using namespace ringtest;

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
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(4));
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
  write_packets(writer, 1, 8);
  for (std::uint64_t s = 1; s <= 8; ++s) {  // lagging by exactly `buffers` loses nothing
    ASSERT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_EQ(buffer, packet(64, s));
    ASSERT_EQ(window.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
    EXPECT_EQ(info.sequence, s);
  }

  write_packets(writer, 9, 28);
  ASSERT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 28u);  // LN: skip to the newest
  EXPECT_EQ(info.lost, 19u);
  EXPECT_EQ(newest.read(buffer.data(), buffer.size(), info), ReadStatus::no_data);

  ASSERT_EQ(window.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 21u);  // KEEP_LAST(8): the oldest of the newest 8
  EXPECT_EQ(info.lost, 12u);
  expect_packets(window, 22, 28);
}

TEST(ShmRingSemantics, ReaderBuffersSmallerThanHistoryAndNewestMode) {
  ShmWriter writer = ShmWriter::create(config(64, 16));
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(4));
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  write_packets(writer, 1, 4);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 1u);
  write_packets(writer, 5, 6);
  // unread 2..6 = 5 > 4 buffers: skip to newest
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 6u);
  EXPECT_EQ(info.lost, 4u);
  write_packets(writer, 7, 9);
  ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info, kNoWait, ReadMode::newest), ReadStatus::ok);
  EXPECT_EQ(info.sequence, 9u);
  EXPECT_EQ(info.lost, 2u);
}

TEST(ShmRingSemantics, WriteErrorsLoansAndShortPackets) {
  ShmWriter writer = ShmWriter::create(config(64, 4));
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(4));
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
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(4));
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
  ReaderOptions options = with_buffers(2);
  ShmReader old_reader = ShmReader::attach(old_writer.fd(), options);
  std::vector<std::byte> buffer(64);
  SampleInfo info;
  write_packets(old_writer, 1, 3);
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
  expect_packets(new_reader, 5, 6);
}

// write_as(): a relayed stream keeps its writer's numbers; numbers it jumps
// over count as lost, for every buffers/lag policy and for borrows.
TEST(ShmRingSemantics, WriteAsJumpsCountAsLost) {
  ShmWriter writer = ShmWriter::create(config(64, 8));
  auto reader = [&](std::uint32_t buffers, LagPolicy on_lag) {
    ReaderOptions options = with_buffers(buffers);
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
  ReaderOptions options = with_buffers(4);
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
  ShmReader reader = ShmReader::attach(writer.fd(), with_buffers(2));
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
    ReaderOptions options = with_buffers(2);
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

}  // namespace
}  // namespace ln::transport
