// Low-level shared-memory probe of the LN 2.9 behaviour tests
// (create_shm_target, read_from_shm_source, ...), written as for LN 2.9;
// compiled unchanged against LN 2.9 and ln_core. Needs no manager.
//
// usage: lnbt_shm MODE ARGS
//   script NAME VERSION        one process: ln_get_v16_features(), then every
//                              call with its result, one line each ("<step>
//                              ret <r> [errno ...] ...")
//   reader NAME VERSION COUNT  creates the segment as a source (64-byte
//                              elements, 4 of them), "ready", then blocking
//                              reads until packet COUNT arrived (or 5 s
//                              without one): "received packets|nothing last
//                              <counter> bad <packets whose bytes or
//                              timestamp do not match their counter>",
//                              removes the segment
//   reader_open NAME COUNT     as reader, but opens an existing segment
//   writer NAME COUNT          opens the segment as a target and writes
//                              packets 1..COUNT (timestamp = number, every
//                              byte = number & 0xff), 1 ms apart: "wrote N"
//   writer_create NAME VERSION COUNT
//                              creates the segment as a target, "ready",
//                              waits for a line on stdin, then writes as writer
#include <fcntl.h>
#include <ln/ln.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "lnbt_errors.h"
#include "testing/wait.hpp"  // ln_core/src/testing: waiting for a thread to block

namespace {

using lnbt::error_name;

constexpr unsigned kElementSize = 64;

// A return value as the transcript shows it: LN error names for codes below
// -2, the number otherwise, plus errno where it is the answer (-1, and 0
// for a timeout).
std::string result(int ret, int error) {
  std::string text = ret < -2 ? error_name(ret) : std::to_string(ret);
  if (error != 0 && (ret == -1 || ret == 0))
    text += std::string(" errno ") + (error == ETIMEDOUT ? "ETIMEDOUT"
                                      : error == ENOENT  ? "ENOENT"
                                      : error == EINVAL  ? "EINVAL"
                                                         : std::to_string(error));
  return text;
}

#define STEP(label, call)                                          \
  do {                                                             \
    errno = 0;                                                     \
    const int ret_ = (call);                                       \
    const int errno_ = errno;                                      \
    std::printf("%s ret %s", label, result(ret_, errno_).c_str()); \
  } while (0)

void show_packet(double ts, uint32_t counter, const char* data, unsigned len) {
  std::printf(" ts %g counter %u data '", ts, counter);
  for (unsigned i = 0; i < len; ++i) std::putchar(data[i] >= 32 && data[i] < 127 ? data[i] : '.');
  std::printf("'\n");
}

void write_raw(const std::string& name, const std::string& contents) {
  const int fd = ::shm_open(("/" + name).c_str(), O_RDWR | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) return;
  if (::write(fd, contents.data(), contents.size()) < 0) std::perror("write");
  ::close(fd);
}

long segment_size(const std::string& name) {
  struct stat st {};
  return ::stat(("/dev/shm/" + name).c_str(), &st) == 0 ? static_cast<long>(st.st_size) : -1;
}

void script(const std::string& name, unsigned version) {
  shm_target_t target = nullptr;
  shm_source_t source = nullptr;
  double ts = -1;
  uint32_t counter = 0;
  char data[17] = {};
  auto write = [&](const char* label, double stamp, const char* text) {
    STEP(label, write_to_shm_target(target, stamp, const_cast<char*>(text), 16));
    std::printf("\n");
  };
  auto read = [&](const char* label) {
    STEP(label, read_from_shm_source(source, &ts, &counter, data, 16, 0));
    show_packet(ts, counter, data, 16);
  };
  unsigned futex = 7, glibc = 7;
  ln_get_v16_features(&futex, &glibc);
  std::printf("v16_features futex %u glibc_2_25 %u ret -\n", futex, glibc);
  STEP("create_target", create_shm_target(&target, name.c_str(), 16, 3, version));
  std::printf(" size %ld\n", segment_size(name));
  STEP("open_source", open_shm_source(&source, name.c_str()));
  std::printf("\n");
  STEP("last_counter", shm_source_get_last_counter(static_cast<shm_source_t*>(source), &counter));
  std::printf(" counter %u\n", counter);
  STEP("read_before_any", read_from_shm_source(source, &ts, &counter, data, 16, 0));
  std::printf(" ts %g counter %u\n", ts, counter);
  shm_source_t peek = nullptr;
  open_shm_source(&peek, name.c_str());
  uint32_t peeked = 99;
  STEP("read_last_before_any", read_last_from_shm_source(peek, &ts, &peeked, data, 16));
  show_packet(ts, peeked, data, 16);
  write("write_1", 1.5, "abcdefghijklmnop");
  STEP("last_counter", shm_source_get_last_counter(static_cast<shm_source_t*>(source), &peeked));
  std::printf(" counter %u\n", peeked);
  write("write_2", 2.5, "ABCDEFGHIJKLMNOP");
  read("read_1");
  read("read_2");
  read("read_again");
  write("write_3", 3.5, "packet number 3.");
  write("write_4", 4.5, "packet number 4.");
  read("read_3");
  read("read_4");
  STEP("write_short", write_to_shm_target(target, 5.5, const_cast<char*>("x"), 1));
  std::printf("\n");
  read("read_short");
  write("write_6", 6.5, "packet number 6.");
  STEP("read_part", read_from_shm_source(source, &ts, &counter, data, 8, 0));
  std::printf(" counter %u\n", counter);
  void* buffer = nullptr;
  STEP("next_buffer", get_next_buffer_from_shm_target(target, &buffer));
  std::printf("\n");
  std::memcpy(buffer, "zero-copy packet", 16);
  read("read_before_commit");
  STEP("commit", write_to_shm_target(target, 7.5, nullptr, 16));
  std::printf("\n");
  read("read_committed");
  STEP("read_timeout", read_from_shm_source_timeout(source, &ts, &counter, data, 16, 0.1));
  std::printf("\n");
  // The other threads act once this one waits in the call (sleeps in the kernel).
  const pid_t reading_thread = ln::test::current_thread_id();
  const auto once_blocked = [reading_thread] {
    ln::test::wait_until([reading_thread] { return ln::test::thread_sleeps(reading_thread); });
  };
  std::thread late_writer([&] {
    once_blocked();
    write_to_shm_target(target, 8.5, const_cast<char*>("from a thread..."), 16);
  });
  STEP("blocking_read", read_from_shm_source(source, &ts, &counter, data, 16, 1));
  show_packet(ts, counter, data, 16);
  late_writer.join();
  std::thread unblocker([&] {
    once_blocked();
    unblock_shm_source(source);
  });
  STEP("blocking_read_unblocked", read_from_shm_source(source, &ts, &counter, data, 16, 1));
  std::printf("\n");
  unblocker.join();
  STEP("block_only_timeout", block_only_on_shm_source(source, &counter, 0.1));
  std::printf(" counter %u\n", counter);
  write("write_9", 9.5, "for block_only..");
  STEP("block_only_new", block_only_on_shm_source(source, &counter, 1.0));
  std::printf(" counter %u\n", counter);
  read("read_after_block_only");
  std::thread unblocker2([&] {
    once_blocked();
    unblock_shm_source(source);
  });
  STEP("block_only_unblocked", block_only_on_shm_source(source, &counter, 5.0));
  std::printf("\n");
  unblocker2.join();
  STEP("read_last", read_last_from_shm_source(peek, &ts, &peeked, data, 16));
  show_packet(ts, peeked, data, 16);
  shm_source_t second = nullptr;
  STEP("open_second_source", open_shm_source(&second, name.c_str()));
  std::printf("\n");
  STEP("second_reads_only_later", read_from_shm_source(second, &ts, &peeked, data, 16, 0));
  std::printf("\n");
  STEP("close_second", close_shm_source(&second));
  std::printf("\n");
  close_shm_source(&peek);

  // A reader that fell behind by more than the ring holds (the packets
  // after it are 10..16, the ring keeps 14..16): what it reads next.
  for (int i = 10; i <= 16; ++i) {
    char packet[17];
    std::snprintf(packet, sizeof packet, "packet-%09d", i);
    write_to_shm_target(target, i, packet, 16);
  }
  std::printf("lapped");
  while (read_from_shm_source(source, &ts, &counter, data, 16, 0) == 1) std::printf(" %u", counter);
  std::printf("\n");

  shm_target_t other = nullptr;
  STEP("create_version_4", create_shm_target(&other, (name + "_v4").c_str(), 8, 2, 4));
  std::printf("\n");
  STEP("open_missing", open_shm_source(&other, (name + "_missing").c_str()));
  std::printf("\n");
  write_raw(name + "_magic", std::string(140, 'x'));
  STEP("open_bad_magic", open_shm_source(&other, (name + "_magic").c_str()));
  std::printf("\n");
  ::shm_unlink(("/" + name + "_magic").c_str());
  write_raw(name + "_small", std::string("LN_SHM\0\3", 8));
  STEP("open_too_small", open_shm_source(&other, (name + "_small").c_str()));
  std::printf("\n");
  ::shm_unlink(("/" + name + "_small").c_str());
  STEP("create_empty_name", create_shm_target(&other, "", 8, 2, 3));
  std::printf("\n");
  STEP("create_name_with_slash", create_shm_target(&other, "lnbt/shm", 8, 2, 3));
  std::printf("\n");

  STEP("close_target", close_shm_target(&target));
  std::printf(" exists %d\n", segment_size(name) >= 0);
  STEP("destroy_source", destroy_shm_source(&source));
  std::printf(" exists %d\n", segment_size(name) >= 0);
}

// Every byte of packet n is n & 0xff; its timestamp is n.
void fill(char* data, uint32_t number) { std::memset(data, static_cast<int>(number & 0xff), kElementSize); }

bool matches(const char* data, double ts, uint32_t number) {
  if (ts != static_cast<double>(number)) return false;
  for (unsigned i = 0; i < kElementSize; ++i)
    if (static_cast<unsigned char>(data[i]) != (number & 0xff)) return false;
  return true;
}

int read_until(shm_source_t source, uint32_t count) {
  char data[kElementSize];
  double ts = 0;
  uint32_t counter = 0;
  int packets = 0, bad = 0;
  while (counter < count) {
    const int ret = read_from_shm_source_timeout(source, &ts, &counter, data, kElementSize, 5.0);
    if (ret != 1) break;
    ++packets;
    if (!matches(data, ts, counter)) ++bad;
  }
  std::printf("received %s last %u bad %d\n", packets > 0 ? "packets" : "nothing", counter, bad);
  std::fflush(stdout);
  return 0;
}

void write_packets(shm_target_t target, uint32_t count) {
  char data[kElementSize];
  for (uint32_t i = 1; i <= count; ++i) {
    fill(data, i);
    write_to_shm_target(target, i, data, kElementSize);
    ln_sleep_seconds(0.001);
  }
  std::printf("wrote %u\n", count);
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  if (argc < 3) {
    std::fprintf(stderr, "usage: lnbt_shm MODE NAME ...\n");
    return 2;
  }
  const std::string mode = argv[1], name = argv[2];
  auto number = [&](int i) { return i < argc ? static_cast<unsigned>(std::strtoul(argv[i], nullptr, 10)) : 0u; };
  if (mode == "script") {
    script(name, number(3));
  } else if (mode == "reader" || mode == "reader_open") {
    shm_source_t source = nullptr;
    const int ret = mode == "reader" ? create_shm_source(&source, name.c_str(), kElementSize, 4, number(3))
                                     : open_shm_source(&source, name.c_str());
    if (ret != 0) {
      std::printf("source %s\n", result(ret, errno).c_str());
      return 1;
    }
    std::printf("ready\n");
    read_until(source, number(mode == "reader" ? 4 : 3));
    if (mode == "reader")
      destroy_shm_source(&source);
    else
      close_shm_source(&source);
  } else if (mode == "writer" || mode == "writer_create") {
    shm_target_t target = nullptr;
    const bool create = mode == "writer_create";
    const int ret = create ? create_shm_target(&target, name.c_str(), kElementSize, 4, number(3))
                           : open_shm_target(&target, name.c_str());
    if (ret != 0) {
      std::printf("target %s\n", result(ret, errno).c_str());
      return 1;
    }
    if (create) {
      std::printf("ready\n");
      char line[64];
      if (std::fgets(line, sizeof line, stdin) == nullptr) return 1;
    }
    write_packets(target, number(create ? 4 : 3));
    if (create)
      destroy_shm_target(&target);
    else
      close_shm_target(&target);
  } else {
    std::fprintf(stderr, "lnbt_shm: unknown mode '%s'\n", mode.c_str());
    return 2;
  }
  return 0;
}
