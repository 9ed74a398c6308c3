// Service groups and thread pools: who waits for a group's requests (the
// program's own thread in wait_and_handle(), or the threads of a pool), and
// the pools' threads and their scheduling.
#include <pthread.h>

#include "services/dispatch_internal.hpp"

namespace ln::services {

namespace {

Status apply_schedparam(const ThreadPool& pool, pthread_t thread) {
  if (pool.policy != -1 || pool.priority != -1) {
    int policy = 0;
    sched_param param{};
    int err = ::pthread_getschedparam(thread, &policy, &param);
    if (err != 0) return errno_failure("pthread_getschedparam", err);
    const int new_policy = pool.policy != -1 ? pool.policy : policy;
    if (pool.priority != -1)
      param.sched_priority = pool.priority;
    else if (new_policy != policy)
      param.sched_priority = ::sched_get_priority_min(new_policy);
    err = ::pthread_setschedparam(thread, new_policy, &param);
    if (err != 0) return errno_failure("thread pool '" + pool.name + "': pthread_setschedparam", err);
  }
  if (pool.affinity_mask != 0) {
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    for (unsigned cpu = 0; cpu < 8 * sizeof pool.affinity_mask; ++cpu)
      if (pool.affinity_mask & (1u << cpu)) CPU_SET(cpu, &cpus);
    const int err = ::pthread_setaffinity_np(thread, sizeof cpus, &cpus);
    if (err != 0) return errno_failure("thread pool '" + pool.name + "': pthread_setaffinity_np", err);
  }
  return {};
}

// A thread's scheduling as it was, to undo a change that failed half-way.
struct ThreadScheduling {
  int policy = SCHED_OTHER;
  sched_param param{};
  bool has_policy = false;
  cpu_set_t cpus;
  bool has_cpus = false;
};

ThreadScheduling scheduling_of(pthread_t thread) {
  ThreadScheduling s;
  s.has_policy = ::pthread_getschedparam(thread, &s.policy, &s.param) == 0;
  CPU_ZERO(&s.cpus);
  s.has_cpus = ::pthread_getaffinity_np(thread, sizeof s.cpus, &s.cpus) == 0;
  return s;
}

void restore_scheduling(pthread_t thread, const ThreadScheduling& s) {
  if (s.has_policy) ::pthread_setschedparam(thread, s.policy, &s.param);
  if (s.has_cpus) ::pthread_setaffinity_np(thread, sizeof s.cpus, &s.cpus);
}

}  // namespace

Status Dispatcher::group_locked(const char* name, ServiceGroup*& out) {
  if (ServiceGroup* found = find_group_locked(name)) {
    out = found;
    return {};
  }
  auto group = std::make_unique<ServiceGroup>();
  group->name = name ? name : "";
  Status s = group->events.open();
  if (!s.ok()) return s;
  out = group.get();
  if (name == nullptr)
    default_group_ = std::move(group);
  else
    groups_.emplace(name, std::move(group));
  return {};
}

ServiceGroup* Dispatcher::find_group_locked(const char* name) {
  if (name == nullptr) return default_group_.get();
  const auto it = groups_.find(std::string_view(name));
  return it == groups_.end() ? nullptr : it->second.get();
}

Status Dispatcher::pool_locked(const char* name, ThreadPool*& out) {
  if (name == nullptr) return Status::failure(LNE_INVALID_PARAMETER, "thread pool without a name");
  const auto it = pools_.find(std::string_view(name));
  if (it != pools_.end()) {
    out = it->second.get();
    return {};
  }
  auto pool = std::make_unique<ThreadPool>();
  pool->name = name;
  Status s = pool->events.open();
  if (s.ok()) s = start_threads_locked(*pool, 1);
  if (!s.ok()) return s;
  out = pool.get();
  pools_.emplace(name, std::move(pool));
  return {};
}

// ------------------------------------------------------ groups and pools

Status Dispatcher::wait_and_handle(const char* group_name, double timeout, int* handled) {
  if (handled) *handled = 0;
  const io::Deadline deadline =
      timeout < 0
          ? io::Deadline()
          : io::Deadline::at(io::Clock::now() +
                             std::chrono::duration_cast<io::Clock::duration>(std::chrono::duration<double>(timeout)));
  ServiceGroup* group = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Status s = group_locked(group_name, group);
    if (!s.ok()) return s;
  }
  bool yield_first = false;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto free = [&] { return !group->busy; };
    if (!deadline.finite())
      group->turn.wait(lock, free);
    else if (!group->turn.wait_until(lock, deadline.when(), free))
      return {};  // another thread kept the group for the whole timeout
    group->busy = true;
    // Right after answering, the next request needs the caller's turn first:
    // if the caller shares our CPU, let it have it before looking.
    yield_first = group->answered_last_turn;
  }
  int count = 0;
  struct EndOfTurn {
    Dispatcher& dispatcher;
    ServiceGroup& group;
    const int& count;
    ~EndOfTurn() {
      std::lock_guard<std::mutex> lock(dispatcher.mutex_);
      group.busy = false;
      group.answered_last_turn = count > 0;
      group.turn.notify_one();
    }
  } end_of_turn{*this, *group, count};

  epoll_event events[8];
  for (;;) {
    deliver_events(group, nullptr);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (group->pool && count == 0)
        return Status::failure(
            LNE_SVC_GRP_HANDLED_IN_POOL,
            "service group '" + group->name + "' is handled by thread pool '" + group->pool->name + "'");
      if (group->unblock_pending) {
        group->unblock_pending = false;
        break;
      }
    }
    if (count > 0) break;
    // Connections with requests left from their last turn do not wait for
    // epoll; the others' new requests are looked at first, without waiting.
    bool backlogged;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      backlogged = !group->events.backlog.empty();
    }
    const int n =
        wait_for_events(group->events.epoll_fd, events, 8, backlogged ? io::Deadline::at(io::Clock::now()) : deadline,
                        backlogged ? 0 : wait_.spin_us, yield_first);
    yield_first = false;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno_failure("epoll_wait", errno);
    for (int i = 0; i < n; ++i) {
      if (events[i].data.u64 == 0)
        group->events.consume();
      else if (events[i].data.u64 == timer_key)
        expire_queued_responses(group->events);
      else
        count += serve(events[i].data.u64);
    }
    if (backlogged) count += serve_backlog(group->events);
    if (n == 0 && !backlogged) break;
  }
  if (handled) *handled = count;
  return {};
}

Status Dispatcher::handle_in_pool(const char* group_name, const char* pool_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = nullptr;
  Status s = group_locked(group_name, group);
  ThreadPool* pool = nullptr;
  if (s.ok()) s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  if (group->pool == pool) return {};
  group->pool = pool;
  move_group_connections_locked(*group, pool->events.epoll_fd);
  group->events.wake();  // a thread in wait_and_handle() returns
  if (!group->observer_events.empty()) pool->events.wake();
  return {};
}

Status Dispatcher::remove_from_pool(const char* group_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = find_group_locked(group_name);
  if (group == nullptr)
    return Status::failure(LNE_SVC_GRP_UNKNOWN,
                           std::string("unknown service group '") + (group_name ? group_name : "") + "'");
  if (group->pool == nullptr) return {};
  group->pool = nullptr;
  move_group_connections_locked(*group, group->events.epoll_fd);
  group->events.wake();
  return {};
}

Status Dispatcher::unblock(const char* group_name) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServiceGroup* group = nullptr;
  Status s = group_locked(group_name, group);
  if (!s.ok()) return s;
  group->unblock_pending = true;
  group->events.wake();
  return {};
}

Status Dispatcher::set_max_threads(const char* pool_name, unsigned n_threads) {
  std::lock_guard<std::mutex> lock(mutex_);
  ThreadPool* pool = nullptr;
  Status s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  reap_finished_locked(*pool);
  const unsigned wanted = n_threads < 1 ? 1 : n_threads;
  if (wanted > pool->active) return start_threads_locked(*pool, wanted - pool->active);
  if (wanted < pool->active) {
    pool->retire_requests += pool->active - wanted;
    pool->active = wanted;
    pool->events.wake();
  }
  return {};
}

Status Dispatcher::set_pool_schedparam(const char* pool_name, int policy, int priority, unsigned affinity_mask) {
  std::lock_guard<std::mutex> lock(mutex_);
  ThreadPool* pool = nullptr;
  Status s = pool_locked(pool_name, pool);
  if (!s.ok()) return s;
  const int old_policy = pool->policy, old_priority = pool->priority;
  const unsigned old_mask = pool->affinity_mask;
  pool->policy = policy;
  pool->priority = priority;
  pool->affinity_mask = affinity_mask;
  // All or nothing: after a failure (EPERM, EINVAL, ...) every thread and the
  // pool's settings for later threads are as they were.
  std::vector<std::pair<pthread_t, ThreadScheduling>> changed;
  for (PoolThread& t : pool->threads) {
    if (t.finished) continue;
    const pthread_t thread = t.thread.native_handle();
    changed.emplace_back(thread, scheduling_of(thread));
    s = apply_schedparam(*pool, thread);
    if (!s.ok()) {
      for (const auto& [changed_thread, before] : changed) restore_scheduling(changed_thread, before);
      pool->policy = old_policy;
      pool->priority = old_priority;
      pool->affinity_mask = old_mask;
      return s;
    }
  }
  return {};
}

Status Dispatcher::start_threads_locked(ThreadPool& pool, unsigned count) {
  for (unsigned i = 0; i < count; ++i) {
    pool.threads.emplace_back();
    PoolThread& entry = pool.threads.back();
    try {
      entry.thread = std::thread(&Dispatcher::pool_thread_main, this, &pool, &entry);
    } catch (const std::system_error& e) {
      pool.threads.pop_back();
      return errno_failure("thread pool '" + pool.name + "': starting a thread", e.code().value());
    }
    ++pool.active;
    // Best effort for threads started later; set_pool_schedparam() reports.
    apply_schedparam(pool, entry.thread.native_handle());
  }
  return {};
}

void Dispatcher::reap_finished_locked(ThreadPool& pool) {
  for (auto it = pool.threads.begin(); it != pool.threads.end();) {
    if (it->finished) {
      it->thread.join();  // it has left its loop; joining is immediate
      it = pool.threads.erase(it);
    } else {
      ++it;
    }
  }
}

void Dispatcher::pool_thread_main(ThreadPool* pool, PoolThread* self) {
  epoll_event event{};
  for (;;) {
    // One event at a time, so idle threads can take the other connections.
    const int n = wait_for_events(pool->events.epoll_fd, &event, 1, io::Deadline(), wait_.spin_us);
    if (n < 0 && errno != EINTR) break;
    if (n <= 0) continue;
    const std::uint64_t key = event.data.u64;
    bool leave = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      // The wake-up stays readable until every thread that must leave saw
      // it. A thread that must leave serves nothing more, so a shrunk pool
      // keeps its new limit at once.
      if (pool->stopping) {
        leave = true;
      } else if (pool->retire_requests > 0) {
        leave = true;
        if (--pool->retire_requests == 0) pool->events.consume();
      } else if (key == 0) {
        pool->events.consume();
      }
    }
    if (leave) {
      if (key != 0) rearm(key);  // its event goes to a thread that stays
      break;
    }
    if (key == 0) {
      deliver_events(nullptr, pool);
      serve_backlog(pool->events);
    } else if (key == timer_key) {
      expire_queued_responses(pool->events);
    } else {
      serve(key);
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  self->finished = true;
}

void Dispatcher::rearm(std::uint64_t key) {
  std::shared_ptr<ProviderConnection> connection;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = connections_.find(key);
    // A claimed connection is re-armed by the thread that claimed it.
    if (it == connections_.end() || it->second->claimed) return;
    if (arm_locked(*it->second).ok()) return;
    connection = it->second;
  }
  close_connection(connection);
}

}  // namespace ln::services
