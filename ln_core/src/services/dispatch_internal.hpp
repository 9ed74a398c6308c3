// The dispatcher's internal state, shared by dispatch.cpp (providers,
// connections, requests) and thread_pools.cpp (service groups and thread
// pools). Not installed; nothing outside services/ includes it.
#ifndef LN_SERVICES_DISPATCH_INTERNAL_HPP
#define LN_SERVICES_DISPATCH_INTERNAL_HPP

#include <sched.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <list>
#include <thread>

#define NO_CPP_WRAPPER
#include "ln/ln.h"
#include "services/dispatch.hpp"
#include "services/socket_io.hpp"

namespace ln::services {

// ------------------------------------------------------------- internals

struct Provider {
  std::uint32_t service_id = 0;
  std::string name;
  std::shared_ptr<const ServiceSignature> signature;
  Handler handler = nullptr;
  void* user_data = nullptr;
  ServiceGroup* group = nullptr;
  std::atomic<bool> removed{false};
  // Guarded by the dispatcher's mutex:
  ConnectionObserver observer = nullptr;
  void* observer_data = nullptr;
  int running = 0;  // handlers in progress
};

// How long a response write waits for a caller to make room before the rest
// is queued: a caller that reads takes it within this (large responses go
// out in one go), one that does not holds up its serving thread no longer.
inline constexpr auto response_wait = std::chrono::milliseconds(1);

inline std::int64_t now_ns() { return io::Clock::now().time_since_epoch().count(); }

// Responses go out in order. What a caller does not take at once is queued
// (its requests then wait in its socket, see serve_claimed), flushed when
// the socket is writable again, and the connection is closed when the queue
// makes no progress for Limits::response_timeout_ms or would grow beyond
// Limits::max_unread_responses: a caller that does not read holds up
// nobody but itself.
struct ProviderConnection {
  ProviderConnection(int socket, std::shared_ptr<Provider> served, std::size_t max_payload)
      : fd(socket), provider(std::move(served)), assembler(max_payload) {}
  // Closed only when nothing refers to it any more, so a deferred response
  // can never write into a descriptor number that was reused meanwhile.
  ~ProviderConnection() { ::close(fd); }

  enum class Sent { out, queued, too_much, failed };

  // `owned`: the frame's memory, kept instead of copied if the rest is queued.
  Sent send(const char* data, std::size_t size, std::unique_ptr<char[]> owned, const Limits& limits, int& sys_errno) {
    std::lock_guard<std::mutex> lock(write_mutex);
    std::size_t sent = 0;
    if (queue.empty()) {
      const io::Result r = io::send_within(fd, data, size, io::Deadline::at(io::Clock::now() + response_wait), sent);
      sys_errno = r.sys_errno;
      // A caller that has gone (aborted, timed out) simply does not get it.
      if (r.outcome == io::Outcome::Done || r.outcome == io::Outcome::Closed) return Sent::out;
      if (r.outcome != io::Outcome::Timeout) return Sent::failed;
      last_progress_ns.store(now_ns());
    } else if (queued_bytes + size > limits.max_unread_responses) {
      return Sent::too_much;
    }
    Chunk chunk;
    if (owned) {
      chunk.owned = std::move(owned);
      chunk.data = data + sent;
    } else {
      chunk.copy.assign(data + sent, size - sent);
      chunk.data = chunk.copy.data();
    }
    chunk.size = size - sent;
    queued_bytes += chunk.size;
    queue.push_back(std::move(chunk));
    has_queued.store(true);
    return Sent::queued;
  }

  // Writes what the socket takes now; `empty` tells whether the queue is.
  io::Result flush(bool& empty) {
    std::lock_guard<std::mutex> lock(write_mutex);
    io::Result r;
    while (!queue.empty()) {
      Chunk& front = queue.front();
      const std::size_t before = front_sent;
      r = io::send_some(fd, front.data, front.size, front_sent);
      if (front_sent != before) last_progress_ns.store(now_ns());
      queued_bytes -= front_sent - before;
      if (r.outcome != io::Outcome::Done || front_sent < front.size) break;
      queue.pop_front();
      front_sent = 0;
    }
    empty = queue.empty();
    has_queued.store(!empty);
    return r;
  }

  const int fd;
  const std::shared_ptr<Provider> provider;
  frames::FrameAssembler assembler;  // used only by the thread that claimed the connection
  std::mutex write_mutex;
  std::atomic<bool> closed{false};
  std::atomic<bool> has_queued{false};
  std::atomic<std::int64_t> last_progress_ns{0};  // of the queue: when it last shrank or began
  // Guarded by write_mutex:
  struct Chunk {
    std::unique_ptr<char[]> owned;
    std::string copy;
    const char* data = nullptr;
    std::size_t size = 0;
  };
  std::deque<Chunk> queue;
  std::size_t front_sent = 0;
  std::size_t queued_bytes = 0;
  // Guarded by the dispatcher's mutex:
  std::uint64_t key = 0;
  int registered_in = -1;  // the epoll set it is registered with
  std::uint32_t armed_events = 0;
  bool claimed = false;  // a thread is reading it
};

// In a pool's set, where several threads wait, a connection fires once and
// waits to be re-armed by the thread that served it: never two threads on
// one connection. A group's own set has one waiter at a time, so there a
// connection stays armed (level-triggered) and costs no re-arm per request.
// A connection whose caller has not taken all responses yet waits for room
// (EPOLLOUT) instead of requests (EPOLLIN): its requests wait in its socket.
inline std::uint32_t set_events(bool shared, bool output_queued) {
  return (output_queued ? EPOLLOUT : EPOLLIN) | EPOLLRDHUP | (shared ? EPOLLONESHOT : 0u);
}
// The key of an event set's timer (connection keys count up from 1, 0 is
// the wake-up descriptor).
inline constexpr std::uint64_t timer_key = ~std::uint64_t{0};
// Requests of one connection handled in a row; the rest wait for the
// connection's next turn, after the other connections': a caller that
// floods the provider delays the others by this many requests only. One
// (plain round robin) halved the median round trip of a normal caller next
// to a flooding one against four, with no measurable loss in throughput
// (bench/run ln_isolation, ln_services).
inline constexpr int requests_per_turn = 1;

inline Status errno_failure(const std::string& what, int err) {
  return Status::failure(LNE_CHECK_ERRNO, what + ": " + std::strerror(err), err);
}

// epoll_wait() that first polls, yielding, for up to `spin_us` (WaitPolicy);
// `yield_first` when nothing can have come yet.
inline int wait_for_events(int epoll_fd, epoll_event* events, int max_events, const io::Deadline& deadline,
                           unsigned spin_us, bool yield_first = false) {
  if (spin_us > 0) {
    if (yield_first) ::sched_yield();
    const io::Clock::time_point until = io::Clock::now() + std::chrono::microseconds(spin_us);
    do {
      const int n = ::epoll_wait(epoll_fd, events, max_events, 0);
      if (n != 0) return n;
      ::sched_yield();
    } while (io::Clock::now() < until && !deadline.expired());
  }
  return ::epoll_wait(epoll_fd, events, max_events, deadline.remaining_ms());
}

// An epoll set plus the eventfd that wakes its waiters (key 0) and a timer
// (timer_key) for the deadlines of its connections' queued responses.
struct EventSet {
  EventSet() = default;
  EventSet(const EventSet&) = delete;
  EventSet& operator=(const EventSet&) = delete;
  ~EventSet() {
    if (epoll_fd >= 0) ::close(epoll_fd);
    if (wake_fd >= 0) ::close(wake_fd);
    if (timer_fd >= 0) ::close(timer_fd);
  }

  Status open() {
    epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
    if (epoll_fd < 0) return errno_failure("epoll_create1", errno);
    wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (wake_fd < 0) return errno_failure("eventfd", errno);
    timer_fd = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
    if (timer_fd < 0) return errno_failure("timerfd_create", errno);
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u64 = 0;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, wake_fd, &ev) != 0) return errno_failure("epoll_ctl", errno);
    ev.data.u64 = timer_key;
    if (::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, timer_fd, &ev) != 0) return errno_failure("epoll_ctl", errno);
    return {};
  }
  // Fires at `when_ns` (steady clock) unless it fires earlier already (dispatcher's mutex held).
  void arm_timer(std::int64_t when_ns) {
    if (timer_armed && timer_at_ns <= when_ns) return;
    itimerspec spec{};
    spec.it_value.tv_sec = static_cast<time_t>(when_ns / 1000000000);
    spec.it_value.tv_nsec = static_cast<long>(when_ns % 1000000000);
    if (spec.it_value.tv_sec == 0 && spec.it_value.tv_nsec == 0) spec.it_value.tv_nsec = 1;  // 0 would disarm
    ::timerfd_settime(timer_fd, TFD_TIMER_ABSTIME, &spec, nullptr);
    timer_armed = true;
    timer_at_ns = when_ns;
  }
  void consume_timer() {
    std::uint64_t expirations = 0;
    [[maybe_unused]] const ssize_t n = ::read(timer_fd, &expirations, sizeof expirations);
  }
  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(wake_fd, &one, sizeof one);
  }
  void consume() const {
    std::uint64_t value = 0;
    [[maybe_unused]] const ssize_t n = ::read(wake_fd, &value, sizeof value);
  }

  int epoll_fd = -1;
  int wake_fd = -1;
  int timer_fd = -1;
  bool timer_armed = false;  // guarded by the dispatcher's mutex
  std::int64_t timer_at_ns = 0;
  // Connections whose turn ended with requests left (received already, so
  // epoll will not report them), in turn order; guarded by the mutex.
  std::deque<std::uint64_t> backlog;
};

struct PendingEvent {
  std::shared_ptr<Provider> provider;
  int event = 0;
  int fd = -1;
};

struct ServiceGroup {
  std::string name;
  EventSet events;                  // its connections while it is handled directly
  ThreadPool* pool = nullptr;       // set while a pool serves it
  bool busy = false;                // a thread is in wait_and_handle(); others take turns
  bool answered_last_turn = false;  // the last wait_and_handle() served requests
  std::condition_variable turn;
  bool unblock_pending = false;
  std::vector<PendingEvent> observer_events;
};

struct PoolThread {
  std::thread thread;
  bool finished = false;
};

struct ThreadPool {
  std::string name;
  EventSet events;
  std::list<PoolThread> threads;  // a list: threads keep the address of their entry
  unsigned active = 0;            // threads not asked to retire
  unsigned retire_requests = 0;
  bool stopping = false;
  int policy = -1;
  int priority = -1;
  unsigned affinity_mask = 0;
};

}  // namespace ln::services

#endif  // LN_SERVICES_DISPATCH_INTERNAL_HPP
