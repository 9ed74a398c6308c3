#pragma once

// Operating-system plumbing for the shared-memory topic transport: owning file
// descriptors, anonymous sealed memory files (memfd), shared mappings, passing
// descriptors between processes, byte-range liveness locks and futexes.
//
// Why memfd and no named POSIX shm: a memfd has no name in any file system, so
// nothing is left behind in /dev/shm when a publisher crashes, and nobody can
// open it by guessing a name; subscribers get it through a Unix socket
// (SCM_RIGHTS), the same socket the higher layer already uses to arrange the
// subscription. Its size is sealed, so a peer can never shrink it under a
// mapping (which would turn later accesses into SIGBUS). Every process that
// attaches re-opens the memfd through /proc/self/fd to get its own open file
// description; that is what makes the per-process liveness locks below work.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace ln::transport {

/// What went wrong while creating or attaching a segment.
enum class ShmErrc {
  system_error,      ///< a system call failed; ShmError::sys_errno() says why
  invalid_config,    ///< sizes or counts out of range
  not_sealed,        ///< the descriptor is not a size-sealed memfd
  too_small,         ///< the file is smaller than its header says
  bad_magic,         ///< not one of our segments
  bad_version,       ///< one of our segments, but a layout version we do not speak
  bad_layout,        ///< header fields are inconsistent or fail the checksum
  invalid_argument,  ///< a reader option does not fit the segment
};

const char* to_string(ShmErrc code);

/// Thrown by the set-up functions (never by the data path, which returns status codes).
class ShmError : public std::runtime_error {
 public:
  ShmError(ShmErrc code, const std::string& what, int sys_errno = 0);
  ShmErrc code() const noexcept { return code_; }
  int sys_errno() const noexcept { return sys_errno_; }

 private:
  ShmErrc code_;
  int sys_errno_;
};

/// Sole owner of a file descriptor; closes it on destruction.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) noexcept : fd_(fd) {}
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept;
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  ~UniqueFd() { reset(); }

  int get() const noexcept { return fd_; }
  bool valid() const noexcept { return fd_ >= 0; }
  int release() noexcept;
  void reset(int fd = -1) noexcept;

 private:
  int fd_ = -1;
};

/// A MAP_SHARED mapping of a whole file; unmapped on destruction.
class Mapping {
 public:
  Mapping() = default;
  Mapping(Mapping&& other) noexcept;
  Mapping& operator=(Mapping&& other) noexcept;
  Mapping(const Mapping&) = delete;
  Mapping& operator=(const Mapping&) = delete;
  ~Mapping();

  /// Maps `size` bytes of `fd` read-write and pre-faults them, so the first
  /// packet does not pay for page faults. Throws ShmError.
  static Mapping map_shared(int fd, std::size_t size);
  /// The same for `size` bytes at `offset` (a multiple of the page size),
  /// read-only unless `writable`.
  static Mapping map_shared(int fd, std::size_t offset, std::size_t size, bool writable);

  std::byte* data() const noexcept { return data_; }
  std::size_t size() const noexcept { return size_; }

 private:
  std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

/// Creates an anonymous memory file of exactly `size` bytes (zero-filled),
/// close-on-exec, with its size sealed. `debug_name` only shows up in
/// /proc/<pid>/fd and /proc/<pid>/maps. Throws ShmError.
UniqueFd create_sealed_memfd(const std::string& debug_name, std::size_t size);

/// Size of the file behind `fd`, after checking that it is a memfd sealed
/// against shrinking. Throws ShmError (not_sealed, system_error).
std::size_t sealed_memfd_size(int fd);

/// Opens the file behind `fd` again as a new, independent open file
/// description (via /proc/self/fd). Returns an invalid UniqueFd if that is
/// impossible (no /proc); the caller then falls back to dup().
UniqueFd reopen_as_own_description(int fd);

/// Sends `fd_to_send` (plus one dummy byte) over a connected Unix socket.
/// Throws ShmError(system_error) on failure.
void send_fd(int unix_socket, int fd_to_send);

/// Receives one descriptor sent by send_fd. The received descriptor is
/// close-on-exec. Throws ShmError on failure, on EOF, and when the message
/// carried no descriptor.
UniqueFd receive_fd(int unix_socket);

/// Advisory write locks on single bytes of a file, owned by an *open file
/// description* (Linux OFD locks): released automatically when the last
/// descriptor of that description is closed, in particular when the owning
/// process dies. Used as kernel-maintained "I am alive" flags.
bool try_lock_byte(int fd, std::uint64_t offset) noexcept;
void unlock_byte(int fd, std::uint64_t offset) noexcept;
/// True if another open file description holds a lock on that byte.
/// Errors count as "locked" so a failing check never declares anyone dead.
bool byte_locked_by_other(int fd, std::uint64_t offset) noexcept;

/// Futex on a word in shared memory (non-private, so it works across processes).
/// Returns once woken, when `*word != expected`, on a signal, or after `timeout`
/// (negative = no timeout). Spurious returns are possible: callers re-check.
/// A waiter is only woken by wakes whose `wake_mask` shares a bit with its
/// `wait_mask` (FUTEX_WAIT_BITSET), so one word can serve waiters that care
/// about different events.
inline constexpr std::uint32_t kFutexAnyEvent = 0xffffffffu;
void futex_wait(const std::atomic<std::uint32_t>* word, std::uint32_t expected, std::chrono::nanoseconds timeout,
                std::uint32_t wait_mask = kFutexAnyEvent) noexcept;
void futex_wake_all(const std::atomic<std::uint32_t>* word, std::uint32_t wake_mask = kFutexAnyEvent) noexcept;

}  // namespace ln::transport
