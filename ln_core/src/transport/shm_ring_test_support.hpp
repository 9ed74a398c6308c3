// What the shared-memory ring tests share: packets with a checkable
// pattern, socket pairs and forked children (bounded, reaped by their test),
// CPU pinning, and a guard that bounds reads without deadline.
#ifndef LN_TRANSPORT_SHM_RING_TEST_SUPPORT_HPP
#define LN_TRANSPORT_SHM_RING_TEST_SUPPORT_HPP

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

namespace ln::transport::ringtest {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// ------------------------------------------------------------------ helpers

inline std::vector<std::byte> packet(std::size_t size, std::uint64_t sequence) {
  std::vector<std::byte> bytes(size);
  for (std::size_t i = 0; i < size; ++i) bytes[i] = static_cast<std::byte>((sequence * 131 + i * 7) & 0xff);
  return bytes;
}

// Payload whose every byte depends on the sequence number stored in its first 8 bytes.
inline void fill_pattern(void* destination, std::size_t size, std::uint64_t sequence) {
  auto* bytes = static_cast<unsigned char*>(destination);
  std::memcpy(bytes, &sequence, sizeof(sequence));
  for (std::size_t i = sizeof(sequence); i < size; ++i) {
    bytes[i] = static_cast<unsigned char>((sequence * 131 + i * 7) & 0xff);
  }
}

inline bool pattern_intact(const void* source, std::size_t size, std::uint64_t sequence) {
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

inline void send_byte(int socket, char value = 'x') {
  if (::send(socket, &value, 1, MSG_NOSIGNAL) != 1) throw std::runtime_error("send_byte");
}

// Returns the byte, or -1 on timeout / EOF.
inline int receive_byte(int socket, std::chrono::milliseconds timeout) {
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

inline std::set<std::string> dev_shm_entries() {
  std::set<std::string> names;
  if (DIR* directory = ::opendir("/dev/shm")) {
    while (dirent* entry = ::readdir(directory)) names.insert(entry->d_name);
    ::closedir(directory);
  }
  return names;
}

// A sealed memfd holding `contents`, for attaching to damaged copies of a segment.
inline UniqueFd sealed_copy(const std::vector<std::byte>& contents) {
  UniqueFd fd(::memfd_create("test_copy", MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!contents.empty() &&
      ::pwrite(fd.get(), contents.data(), contents.size(), 0) != static_cast<ssize_t>(contents.size())) {
    throw std::runtime_error("pwrite");
  }
  ::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW);
  return fd;
}

inline std::vector<std::byte> file_contents(int fd) {
  const off_t size = ::lseek(fd, 0, SEEK_END);
  std::vector<std::byte> contents(static_cast<std::size_t>(size));
  if (::pread(fd, contents.data(), contents.size(), 0) != size) throw std::runtime_error("pread");
  return contents;
}

inline ShmErrc attach_error(int fd, const ReaderOptions& options = {}) {
  try {
    ShmReader::attach(fd, options);
  } catch (const ShmError& error) {
    return error.code();
  }
  ADD_FAILURE() << "attach unexpectedly succeeded";
  return ShmErrc::system_error;
}

inline RingConfig config(std::uint32_t message_size, std::uint32_t history = 1, std::uint32_t borrow_slots = 2) {
  RingConfig result;
  result.message_size = message_size;
  result.history = history;
  result.borrow_slots = borrow_slots;
  return result;
}

// A reader's options with `buffers` buffers, the rest as by default.
inline ReaderOptions with_buffers(std::uint32_t buffers) {
  ReaderOptions options;
  options.buffers = buffers;
  return options;
}

// Writes packet(size, s) for s = first..last.
inline void write_packets(ShmWriter& writer, std::uint64_t first, std::uint64_t last, std::size_t size = 64) {
  for (std::uint64_t s = first; s <= last; ++s)
    ASSERT_EQ(writer.write(packet(size, s).data(), size), WriteStatus::ok) << "packet " << s;
}

// Reads packets first..last from `reader` (none waiting): each in order, none lost, each whole.
inline void expect_packets(ShmReader& reader, std::uint64_t first, std::uint64_t last, std::size_t size = 64) {
  std::vector<std::byte> buffer(size);
  SampleInfo info;
  for (std::uint64_t s = first; s <= last; ++s) {
    ASSERT_EQ(reader.read(buffer.data(), buffer.size(), info), ReadStatus::ok) << "packet " << s;
    EXPECT_EQ(info.sequence, s);
    EXPECT_EQ(info.lost, 0u);
    EXPECT_EQ(buffer, packet(size, s));
  }
}

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
inline std::pair<int, int> two_allowed_cpus() {
  cpu_set_t allowed;
  if (::sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return {-1, -1};
  std::vector<int> cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE && cpus.size() < 2; ++cpu) {
    if (CPU_ISSET(cpu, &allowed)) cpus.push_back(cpu);
  }
  return cpus.size() == 2 ? std::make_pair(cpus[0], cpus[1]) : std::make_pair(-1, -1);
}

// The first CPU this process may run on.
inline int first_allowed_cpu() {
  cpu_set_t allowed;
  if (::sched_getaffinity(0, sizeof(allowed), &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) return cpu;
    }
  }
  return 0;
}

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

}  // namespace ln::transport::ringtest

#endif  // LN_TRANSPORT_SHM_RING_TEST_SUPPORT_HPP
