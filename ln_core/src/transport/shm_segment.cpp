#include "transport/shm_segment.hpp"

#include <fcntl.h>
#include <linux/futex.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <ctime>

namespace ln::transport {

namespace {

[[noreturn]] void throw_errno(const std::string& what, int err = errno) {
  throw ShmError(ShmErrc::system_error, what + ": " + std::strerror(err), err);
}

struct flock byte_lock(short type, std::uint64_t offset) {
  struct flock lock {};
  lock.l_type = type;
  lock.l_whence = SEEK_SET;
  lock.l_start = static_cast<off_t>(offset);
  lock.l_len = 1;
  lock.l_pid = 0;  // required to be 0 for OFD locks
  return lock;
}

}  // namespace

const char* to_string(ShmErrc code) {
  switch (code) {
    case ShmErrc::system_error:
      return "system error";
    case ShmErrc::invalid_config:
      return "invalid segment configuration";
    case ShmErrc::not_sealed:
      return "descriptor is not a size-sealed memfd";
    case ShmErrc::too_small:
      return "segment file too small";
    case ShmErrc::bad_magic:
      return "not an ln shared-memory ring segment";
    case ShmErrc::bad_version:
      return "unsupported segment layout version";
    case ShmErrc::bad_layout:
      return "inconsistent segment header";
    case ShmErrc::invalid_argument:
      return "invalid argument";
  }
  return "unknown error";
}

ShmError::ShmError(ShmErrc code, const std::string& what, int sys_errno)
    : std::runtime_error(what), code_(code), sys_errno_(sys_errno) {}

UniqueFd& UniqueFd::operator=(UniqueFd&& other) noexcept {
  if (this != &other) reset(other.release());
  return *this;
}

int UniqueFd::release() noexcept {
  const int fd = fd_;
  fd_ = -1;
  return fd;
}

void UniqueFd::reset(int fd) noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
}

Mapping::Mapping(Mapping&& other) noexcept : data_(other.data_), size_(other.size_) {
  other.data_ = nullptr;
  other.size_ = 0;
}

Mapping& Mapping::operator=(Mapping&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) ::munmap(data_, size_);
    data_ = other.data_;
    size_ = other.size_;
    other.data_ = nullptr;
    other.size_ = 0;
  }
  return *this;
}

Mapping::~Mapping() {
  if (data_ != nullptr) ::munmap(data_, size_);
}

Mapping Mapping::map_shared(int fd, std::size_t size) { return map_shared(fd, 0, size, true); }

Mapping Mapping::map_shared(int fd, std::size_t offset, std::size_t size, bool writable) {
  if (size == 0) throw ShmError(ShmErrc::invalid_config, "cannot map an empty segment");
  void* address = ::mmap(nullptr, size, PROT_READ | (writable ? PROT_WRITE : 0), MAP_SHARED | MAP_POPULATE, fd,
                         static_cast<off_t>(offset));
  if (address == MAP_FAILED) throw_errno("mmap of shared-memory segment");
  Mapping mapping;
  mapping.data_ = static_cast<std::byte*>(address);
  mapping.size_ = size;
  return mapping;
}

UniqueFd create_sealed_memfd(const std::string& debug_name, std::size_t size) {
  UniqueFd fd(::memfd_create(debug_name.c_str(), MFD_CLOEXEC | MFD_ALLOW_SEALING));
  if (!fd.valid()) throw_errno("memfd_create");
  if (::ftruncate(fd.get(), static_cast<off_t>(size)) != 0) throw_errno("ftruncate of memfd");
  // Growing would be harmless but there is no reason to allow it; sealing the
  // seals keeps anyone from undoing this later.
  if (::fcntl(fd.get(), F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_SEAL) != 0) {
    throw_errno("sealing memfd");
  }
  return fd;
}

std::size_t sealed_memfd_size(int fd) {
  const int seals = ::fcntl(fd, F_GET_SEALS);
  if (seals < 0) {
    if (errno == EINVAL) {
      throw ShmError(ShmErrc::not_sealed, "segment descriptor is not a memfd", errno);
    }
    throw_errno("reading memfd seals");
  }
  if ((seals & F_SEAL_SHRINK) == 0) {
    throw ShmError(ShmErrc::not_sealed, "segment memfd is not sealed against shrinking");
  }
  struct stat info {};
  if (::fstat(fd, &info) != 0) throw_errno("fstat of segment");
  if (info.st_size < 0) throw ShmError(ShmErrc::too_small, "segment has a negative size");
  return static_cast<std::size_t>(info.st_size);
}

UniqueFd reopen_as_own_description(int fd) {
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  return UniqueFd(::open(path.c_str(), O_RDWR | O_CLOEXEC));
}

void send_fd(int unix_socket, int fd_to_send) {
  char dummy = 'F';  // some socket types refuse to carry ancillary data without payload
  iovec payload{&dummy, 1};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
  msghdr message{};
  message.msg_iov = &payload;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof(control);
  cmsghdr* header = CMSG_FIRSTHDR(&message);
  header->cmsg_level = SOL_SOCKET;
  header->cmsg_type = SCM_RIGHTS;
  header->cmsg_len = CMSG_LEN(sizeof(int));
  std::memcpy(CMSG_DATA(header), &fd_to_send, sizeof(int));

  ssize_t sent;
  do {
    sent = ::sendmsg(unix_socket, &message, MSG_NOSIGNAL);
  } while (sent < 0 && errno == EINTR);
  if (sent < 0) throw_errno("sendmsg with descriptor");
  if (sent != 1) throw ShmError(ShmErrc::system_error, "sendmsg with descriptor: short write");
}

UniqueFd receive_fd(int unix_socket) {
  char dummy = 0;
  iovec payload{&dummy, 1};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 4)] = {};
  msghdr message{};
  message.msg_iov = &payload;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof(control);

  ssize_t received;
  do {
    received = ::recvmsg(unix_socket, &message, MSG_CMSG_CLOEXEC);
  } while (received < 0 && errno == EINTR);
  if (received < 0) throw_errno("recvmsg for descriptor");

  // Take ownership of everything that arrived before judging the message, so
  // that nothing leaks on the error paths.
  UniqueFd result;
  std::size_t extra_descriptors = 0;
  for (cmsghdr* header = CMSG_FIRSTHDR(&message); header != nullptr; header = CMSG_NXTHDR(&message, header)) {
    if (header->cmsg_level != SOL_SOCKET || header->cmsg_type != SCM_RIGHTS) continue;
    const std::size_t count = (header->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (std::size_t i = 0; i < count; ++i) {
      int fd;
      std::memcpy(&fd, CMSG_DATA(header) + i * sizeof(int), sizeof(int));
      if (!result.valid()) {
        result.reset(fd);
      } else {
        ::close(fd);
        ++extra_descriptors;
      }
    }
  }
  if (received == 0 && !result.valid()) {
    throw ShmError(ShmErrc::system_error, "recvmsg for descriptor: peer closed the socket");
  }
  if ((message.msg_flags & MSG_CTRUNC) != 0) {
    throw ShmError(ShmErrc::system_error, "recvmsg for descriptor: control data truncated");
  }
  if (!result.valid()) {
    throw ShmError(ShmErrc::system_error, "recvmsg for descriptor: message carried no descriptor");
  }
  if (extra_descriptors != 0) {
    throw ShmError(ShmErrc::system_error, "recvmsg for descriptor: more than one descriptor");
  }
  return result;
}

bool try_lock_byte(int fd, std::uint64_t offset) noexcept {
  struct flock lock = byte_lock(F_WRLCK, offset);
  return ::fcntl(fd, F_OFD_SETLK, &lock) == 0;
}

void unlock_byte(int fd, std::uint64_t offset) noexcept {
  struct flock lock = byte_lock(F_UNLCK, offset);
  ::fcntl(fd, F_OFD_SETLK, &lock);
}

bool byte_locked_by_other(int fd, std::uint64_t offset) noexcept {
  struct flock lock = byte_lock(F_WRLCK, offset);
  if (::fcntl(fd, F_OFD_GETLK, &lock) != 0) return true;
  return lock.l_type != F_UNLCK;
}

void futex_wait(const std::atomic<std::uint32_t>* word, std::uint32_t expected, std::chrono::nanoseconds timeout,
                std::uint32_t wait_mask) noexcept {
  static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t),
                "the futex word must be a plain 32-bit integer in memory");
  // FUTEX_WAIT_BITSET takes an absolute CLOCK_MONOTONIC deadline.
  timespec deadline{};
  timespec* deadline_ptr = nullptr;
  if (timeout.count() >= 0) {
    ::clock_gettime(CLOCK_MONOTONIC, &deadline);
    const long long total_ns = deadline.tv_nsec + timeout.count() % 1'000'000'000;
    deadline.tv_sec += static_cast<time_t>(timeout.count() / 1'000'000'000 + total_ns / 1'000'000'000);
    deadline.tv_nsec = static_cast<long>(total_ns % 1'000'000'000);
    deadline_ptr = &deadline;
  }
  ::syscall(SYS_futex, word, FUTEX_WAIT_BITSET, expected, deadline_ptr, nullptr, wait_mask);
}

void futex_wake_all(const std::atomic<std::uint32_t>* word, std::uint32_t wake_mask) noexcept {
  ::syscall(SYS_futex, word, FUTEX_WAKE_BITSET, INT_MAX, nullptr, nullptr, wake_mask);
}

}  // namespace ln::transport
