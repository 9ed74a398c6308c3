// ln.h: the low-level named shared-memory API (create_shm_target,
// read_from_shm_source, ...) over transport/ln29_shm.hpp, and
// ln_get_v16_features(). Return values follow LN 2.9: 0 success, reads 1 (a
// packet) / 0 (none; errno ETIMEDOUT when a wait timed out) / -2 (unblocked);
// failures are negative with errno set.
#include <features.h>
#include <sys/syscall.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <new>
#include <string>

#include "client/c_api.hpp"
#include "transport/ln29_shm.hpp"

namespace {

using ln::transport::ShmErrc;
using ln::transport::ShmError;
using ln::transport::ln29::ReadResult;
using ln::transport::ln29::Segment;

// What LN 2.9 returns when unblock_shm_source() ended a wait.
constexpr int kUnblocked = -2;

enum class Side : std::uint64_t { target = 0x4c4e3239544152ull, source = 0x4c4e3239535243ull };

// shm_target_t / shm_source_t point to this. `side` comes first and is
// cleared on destruction, so stale and foreign handles are refused.
struct Handle {
  Side side;
  Segment segment;
  ~Handle() { side = Side{0}; }
};

// errno tells the caller why a call failed; calls that succeed leave it as
// it was (system calls on the way, e.g. a futex timeout, do not leak out).
thread_local int g_failure_errno = 0;

int failure(int code, int error) {
  g_failure_errno = error;
  return code;
}

template <typename Body>
int keeping_errno(Body&& body) noexcept {
  const int saved = errno;
  g_failure_errno = 0;
  const int ret = body();
  errno = g_failure_errno != 0 ? g_failure_errno : saved;
  return ret;
}

Handle* from(void* handle, Side side) noexcept {
  auto* candidate = static_cast<Handle*>(handle);
  return candidate != nullptr && candidate->side == side ? candidate : nullptr;
}

int from_shm_error(const ShmError& error) {
  switch (error.code()) {
    case ShmErrc::system_error:
      return error.sys_errno() == ENAMETOOLONG ? failure(-LNE_SHM_NAME_TOO_LONG, ENAMETOOLONG)
                                               : failure(-LNE_CHECK_ERRNO, error.sys_errno());
    case ShmErrc::bad_magic:
      return failure(-LNE_INVALID_SHM_MAGIC, EINVAL);
    case ShmErrc::bad_version:
      return failure(-LNE_SHM_VERSION_TOO_NEW, EINVAL);
    case ShmErrc::too_small:
    case ShmErrc::bad_layout:
      return failure(-LNE_WRONG_SHM_SIZE, EINVAL);
    default:
      return failure(-LNE_INVALID_PARAMETER, EINVAL);
  }
}

template <typename Make>
int new_handle(void** out, const char* name, Side side, Make&& make) noexcept {
  if (out == nullptr || name == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
  try {
    *out = new Handle{side, make(std::string(name))};
    return 0;
  } catch (const ShmError& error) {
    return from_shm_error(error);
  } catch (const std::bad_alloc&) {
    return failure(-LNE_NO_MEM, ENOMEM);
  } catch (...) {
    return failure(-LNE_INTERNAL_ERROR, EINVAL);
  }
}

int create_handle(void** out, const char* name, Side side, unsigned element_size, unsigned n_elements,
                  unsigned version) noexcept {
  return new_handle(out, name, side,
                    [&](const std::string& n) { return Segment::create(n, element_size, n_elements, version); });
}

int open_handle(void** out, const char* name, Side side) noexcept {
  return new_handle(out, name, side, [](const std::string& n) { return Segment::open(n); });
}

int release_handle(void** handle, Side side, bool remove_name) noexcept {
  Handle* owned = handle != nullptr ? from(*handle, side) : nullptr;
  if (owned == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
  const int error = remove_name ? owned->segment.unlink() : 0;
  delete owned;
  *handle = nullptr;
  return error == 0 || error == ENOENT ? 0 : failure(-LNE_CHECK_ERRNO, error);
}

std::chrono::nanoseconds wait_time(double seconds) {
  if (std::isnan(seconds) || seconds < 0) return std::chrono::nanoseconds(-1);
  if (seconds > 1e9) seconds = 1e9;  // "forever enough", and no overflow
  return std::chrono::nanoseconds(static_cast<std::int64_t>(seconds * 1e9));
}

int read_result(ReadResult result) {
  switch (result) {
    case ReadResult::packet:
      return 1;
    case ReadResult::nothing_new:
      return 0;
    case ReadResult::timeout:
      return failure(0, ETIMEDOUT);
    case ReadResult::unblocked:
      return kUnblocked;
    case ReadResult::torn:
      return failure(-LNE_SHM_READ_ERROR, EAGAIN);
  }
  return failure(-LNE_INTERNAL_ERROR, EINVAL);
}

int read_next(shm_source_t source, double* ts, uint32_t* packet_counter, void* data, unsigned int len,
              std::chrono::nanoseconds timeout, bool is_timed) {
  Handle* handle = from(source, Side::source);
  if (handle == nullptr || (data == nullptr && len > 0)) return failure(-LNE_INVALID_PARAMETER, EINVAL);
  double timestamp = 0;
  std::uint32_t counter = 0;
  ReadResult result = handle->segment.read_next(data, len, timestamp, counter, timeout);
  if (result == ReadResult::nothing_new && is_timed) result = ReadResult::timeout;
  if (result == ReadResult::packet) {
    if (ts != nullptr) *ts = timestamp;
    if (packet_counter != nullptr) *packet_counter = counter;
  }
  return read_result(result);
}

}  // namespace

extern "C" {

int create_shm_target(shm_target_t* target, const char* name, unsigned int element_size, unsigned int n_elements,
                      unsigned int version) {
  return keeping_errno([&] { return create_handle(target, name, Side::target, element_size, n_elements, version); });
}

int open_shm_target(shm_target_t* target, const char* name) {
  return keeping_errno([&] { return open_handle(target, name, Side::target); });
}

int destroy_shm_target(shm_target_t* target) {
  return keeping_errno([&] { return release_handle(target, Side::target, true); });
}

int close_shm_target(shm_target_t* target) {
  return keeping_errno([&] { return release_handle(target, Side::target, false); });
}

int write_to_shm_target(shm_target_t target, double ts, void* data, unsigned int len) {
  return keeping_errno([&] {
    Handle* handle = from(target, Side::target);
    if (handle == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    return handle->segment.write(ts, data, len) ? 0 : failure(-LNE_PACKET_TOO_LARGE, EMSGSIZE);
  });
}

int get_next_buffer_from_shm_target(shm_target_t target, void** buffer) {
  return keeping_errno([&] {
    Handle* handle = from(target, Side::target);
    if (handle == nullptr || buffer == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    *buffer = handle->segment.next_buffer();
    return 0;
  });
}

int create_shm_source(shm_source_t* source, const char* name, unsigned int element_size, unsigned int n_elements,
                      unsigned int version) {
  return keeping_errno([&] { return create_handle(source, name, Side::source, element_size, n_elements, version); });
}

int open_shm_source(shm_source_t* source, const char* name) {
  return keeping_errno([&] { return open_handle(source, name, Side::source); });
}

int destroy_shm_source(shm_source_t* source) {
  return keeping_errno([&] { return release_handle(source, Side::source, true); });
}

int close_shm_source(shm_source_t* source) {
  return keeping_errno([&] { return release_handle(source, Side::source, false); });
}

// ln.h declares a pointer to the handle, LN 2.9's library takes the handle
// itself (and crashes on the pointer): both are accepted.
int shm_source_get_last_counter(shm_source_t* source, uint32_t* counter) {
  return keeping_errno([&] {
    Handle* handle = from(source, Side::source);
    if (handle == nullptr && source != nullptr) handle = from(*source, Side::source);
    if (handle == nullptr || counter == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    *counter = handle->segment.newest_counter();
    return 0;
  });
}

int read_from_shm_source(shm_source_t source, double* ts, uint32_t* packet_counter, void* data, unsigned int len,
                         int blocking) {
  return keeping_errno([&] {
    return read_next(source, ts, packet_counter, data, len,
                     blocking ? std::chrono::nanoseconds(-1) : std::chrono::nanoseconds(0), false);
  });
}

int read_from_shm_source_timeout(shm_source_t source, double* ts, uint32_t* packet_counter, void* data,
                                 unsigned int len, double timeout) {
  return keeping_errno([&] { return read_next(source, ts, packet_counter, data, len, wait_time(timeout), true); });
}

int read_last_from_shm_source(shm_source_t source, double* ts, uint32_t* packet_counter, void* data, unsigned int len) {
  return keeping_errno([&] {
    Handle* handle = from(source, Side::source);
    if (handle == nullptr || (data == nullptr && len > 0)) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    double timestamp = 0;
    std::uint32_t counter = 0;
    const ReadResult result = handle->segment.read_last(data, len, timestamp, counter);
    if (result == ReadResult::packet) {
      if (ts != nullptr) *ts = timestamp;
      if (packet_counter != nullptr) *packet_counter = counter;
    }
    return read_result(result);
  });
}

int block_only_on_shm_source(shm_source_t source, uint32_t* packet_counter, double timeout) {
  return keeping_errno([&] {
    Handle* handle = from(source, Side::source);
    if (handle == nullptr || packet_counter == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    return read_result(handle->segment.wait_for_packet(*packet_counter, wait_time(timeout)));
  });
}

int unblock_shm_source(shm_source_t source) {
  return keeping_errno([&] {
    Handle* handle = from(source, Side::source);
    if (handle == nullptr) return failure(-LNE_INVALID_PARAMETER, EINVAL);
    handle->segment.unblock();
    return 0;
  });
}

void ln_get_v16_features(unsigned int* is_with_sys_futex, unsigned int* is_glibc_atleast_2_25) {
  // Blocking reads of topics and of these segments sleep in futex(2); glibc
  // 2.25 brought the condition variables LN 2.9's version-16 segments need.
#ifdef SYS_futex
  if (is_with_sys_futex != nullptr) *is_with_sys_futex = 1;
#else
  if (is_with_sys_futex != nullptr) *is_with_sys_futex = 0;
#endif
#if defined(__GLIBC_PREREQ) && __GLIBC_PREREQ(2, 25)
  if (is_glibc_atleast_2_25 != nullptr) *is_glibc_atleast_2_25 = 1;
#else
  if (is_glibc_atleast_2_25 != nullptr) *is_glibc_atleast_2_25 = 0;
#endif
}

}  // extern "C"
