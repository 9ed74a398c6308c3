/* One-way message rate through a single-producer single-consumer ring in shared memory
 * between two processes (fork): the ceiling for small-message pub/sub with one copy in and
 * one copy out.
 *
 *   shm_ring [--cpus 0,1] [--msgs 5000000] [--size 64] [--slots 1024] [--deadline-s 20]
 *
 * The producer copies each message into the next slot and publishes it at once (one release
 * store of head per message, as a pub/sub write call would); the consumer copies out all
 * published messages, checks the sequence number stamped in each, and then releases the slots
 * (one store of tail per batch). Both sides busy-poll; after a bounded spin they yield so the
 * probe also progresses with both processes on one CPU. Prints one JSON line. */
#include "probe.h"  // first: it defines _GNU_SOURCE

#include <signal.h>
#include <stdatomic.h>
#include <sys/mman.h>
#include <sys/wait.h>

#define MAX_SIZE 4096
#define MAX_SLOTS 65536

struct shared {
  _Alignas(64) _Atomic uint64_t head; /* next slot the producer writes */
  _Alignas(64) _Atomic uint64_t tail; /* next slot the consumer reads */
  _Alignas(64) _Atomic int consumer_ready;
  _Atomic int abort_flag;
  uint64_t consumer_done_ns, bad_messages;
  _Alignas(64) char slots[];
};

/* Spin briefly, then yield: on split cores the yield is never reached when the peer keeps up. */
static int backoff(uint32_t* spins, uint64_t deadline, struct shared* sh) {
  if (++*spins < 1024) {
    cpu_relax();
    return 0;
  }
  *spins = 0;
  sched_yield();
  return now_ns() > deadline || atomic_load_explicit(&sh->abort_flag, memory_order_relaxed) ? -1 : 0;
}

int main(int argc, char** argv) {
  alarm(PROBE_HARD_ALARM_S);
  int cpu_a, cpu_b;
  arg_cpus(argc, argv, &cpu_a, &cpu_b);
  long msgs = arg_long(argc, argv, "--msgs", 5000000);
  long size = arg_long(argc, argv, "--size", 64);
  long slots = arg_long(argc, argv, "--slots", 1024);
  long deadline_s = arg_deadline_s(argc, argv);
  if (msgs < 1 || msgs > 1000000000) die("--msgs out of range");
  if (size < 8 || size > MAX_SIZE) die("--size must be 8..%d (a message carries its 8-byte sequence number)", MAX_SIZE);
  if (slots < 2 || slots > MAX_SLOTS || (slots & (slots - 1))) die("--slots must be a power of two, 2..%d", MAX_SLOTS);

  const size_t stride = ((size_t)size + 63) & ~(size_t)63; /* no two slots share a cache line */
  const uint64_t mask = (uint64_t)slots - 1;
  size_t bytes = sizeof(struct shared) + stride * (size_t)slots;
  struct shared* sh = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (sh == MAP_FAILED) die("mmap failed");
  memset(sh, 0, bytes);
  const uint64_t deadline = now_ns() + (uint64_t)deadline_s * 1000000000ull;
  char msg[MAX_SIZE];
  memset(msg, 3, sizeof msg);

  pid_t pid = fork();
  if (pid < 0) die("fork failed");
  if (pid == 0) { /* consumer */
    alarm(PROBE_HARD_ALARM_S);
    if (pin_to_cpu(cpu_b)) {
      atomic_store(&sh->abort_flag, 1);
      _exit(4);
    } /* stop the producer now */
    atomic_store(&sh->consumer_ready, 1);
    uint64_t tail = 0, bad = 0;
    uint32_t spins = 0;
    while (tail < (uint64_t)msgs) {
      uint64_t head = atomic_load_explicit(&sh->head, memory_order_acquire);
      if (head == tail) {
        if (backoff(&spins, deadline, sh)) _exit(3);
        continue;
      }
      for (; tail < head; tail++) {
        memcpy(msg, sh->slots + (tail & mask) * stride, (size_t)size);
        uint64_t seq;
        memcpy(&seq, msg, sizeof seq);
        bad += seq != tail;
      }
      atomic_store_explicit(&sh->tail, tail, memory_order_release);
    }
    sh->consumer_done_ns = now_ns();
    sh->bad_messages = bad;
    _exit(0);
  }

  pin_or_end_peer(pid, cpu_a);
  int failed = 0;
  uint32_t spins = 0;
  /* start the clock only once the consumer runs, so fork and pinning are not timed */
  while (!atomic_load(&sh->consumer_ready) && !failed) failed = backoff(&spins, deadline, sh);
  const uint64_t t0 = now_ns();
  uint64_t tail_seen = 0;
  for (uint64_t head = 0; head < (uint64_t)msgs && !failed; head++) {
    while (head - tail_seen >= (uint64_t)slots && !failed) { /* full: refresh the cached tail */
      tail_seen = atomic_load_explicit(&sh->tail, memory_order_acquire);
      if (head - tail_seen >= (uint64_t)slots) failed = backoff(&spins, deadline, sh);
    }
    memcpy(msg, &head, sizeof head);
    memcpy(sh->slots + (head & mask) * stride, msg, (size_t)size);
    atomic_store_explicit(&sh->head, head + 1, memory_order_release);
  }
  reap_peer(pid, failed, &sh->abort_flag, "consumer");
  if (failed) die("producer: deadline of %ld s passed", deadline_s);
  double secs = (double)(sh->consumer_done_ns - t0) / 1e9;
  printf(
      "{\"probe\": \"shm_ring\", \"cpus\": [%d, %d], \"size\": %ld, \"slots\": %ld, \"msgs\": %ld, "
      "\"seconds\": %.6f, \"msgs_per_s\": %.1f, \"gbps\": %.4f, \"bad_messages\": %llu}\n",
      cpu_a, cpu_b, size, slots, msgs, secs, msgs / secs, msgs * (double)size / secs / 1e9,
      (unsigned long long)sh->bad_messages);
  return 0;
}
