/* Round trip between two processes (fork) through a shared anonymous mapping.
 *
 *   shm_rtt --mode spin|futex|adaptive|yield [--cpus 0,1] [--iters 20000] [--warmup 2000]
 *           [--payload 64] [--spin-iters 200] [--deadline-s 20]
 *
 * A round trip: A copies the payload in and bumps its sequence word, B sees it, copies the
 * payload out and back in, bumps its own word, A sees that and copies the payload out.
 * How a side waits for the other's word is the mode:
 *   spin     busy-poll (the latency floor; burns the waiting core)
 *   futex    sleep in FUTEX_WAIT; the sender always calls FUTEX_WAKE (the plain blocking way)
 *   adaptive spin up to --spin-iters pause iterations, then announce "sleeping" and FUTEX_WAIT;
 *            the sender calls FUTEX_WAKE only if the peer announced it sleeps, so a fast peer
 *            costs no system call on either side
 *   yield    call sched_yield() until the word changes: with both processes on one CPU, the
 *            cheapest hand-over the kernel offers (one system call and one context switch per
 *            hop, no futex); the floor for any blocking read between two processes on one core
 * Prints one JSON line with the RTT statistics (µs) and, for the futex modes, how often the
 * waits slept, how many wake calls were made and how many 1 s futex timeouts happened
 * (a timeout in adaptive mode would be a lost wake-up, i.e. a protocol bug). */
#include "probe.h"  // first: it defines _GNU_SOURCE

#include <errno.h>
#include <linux/futex.h>
#include <sched.h>
#include <signal.h>
#include <stdatomic.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/wait.h>

#define MAX_PAYLOAD (1 << 20)

enum mode { M_SPIN, M_FUTEX, M_ADAPTIVE, M_YIELD };

/* One direction of the ping-pong. seq and sleeping share a line on purpose: the sender
 * writes seq then reads sleeping, so one cache-line transfer serves both. */
struct channel {
  _Alignas(64) _Atomic uint32_t seq;
  _Atomic uint32_t sleeping;
};

struct wait_counters {
  uint64_t waits, sleeps, wakes, timeouts;
};

struct shared {
  struct channel a2b, b2a;
  _Alignas(64) _Atomic int abort_flag;
  struct wait_counters b_counters; /* B's, read by A after B exited */
  _Alignas(64) char a2b_data[MAX_PAYLOAD];
  _Alignas(64) char b2a_data[MAX_PAYLOAD];
};

struct side {
  struct shared* sh;
  enum mode mode;
  long spin_iters;
  uint64_t deadline;
  struct wait_counters c;
};

static long futex(_Atomic uint32_t* addr, int op, uint32_t val, const struct timespec* timeout) {
  /* shared (not PRIVATE) futex: the two processes map the word at different mm's */
  return syscall(SYS_futex, (uint32_t*)addr, op, val, timeout, NULL, 0);
}

static int expired(struct side* s) {
  return now_ns() > s->deadline || atomic_load_explicit(&s->sh->abort_flag, memory_order_relaxed);
}

static void signal_peer(struct side* s, struct channel* ch, uint32_t value) {
  if (s->mode == M_SPIN || s->mode == M_YIELD) {
    atomic_store_explicit(&ch->seq, value, memory_order_release);
  } else if (s->mode == M_FUTEX) {
    atomic_store_explicit(&ch->seq, value, memory_order_release);
    futex(&ch->seq, FUTEX_WAKE, 1, NULL);
    s->c.wakes++;
  } else {
    /* seq_cst store then load pairs with the waiter's seq_cst store of `sleeping` then load of
     * `seq` (Dekker): at least one side sees the other's write, so no wake-up is lost. */
    atomic_store(&ch->seq, value);
    if (atomic_load(&ch->sleeping)) {
      futex(&ch->seq, FUTEX_WAKE, 1, NULL);
      s->c.wakes++;
    }
  }
}

/* Wait until ch->seq == want. Returns 0, or -1 when the deadline passed or the peer gave up. */
static int wait_peer(struct side* s, struct channel* ch, uint32_t want) {
  s->c.waits++;
  if (s->mode == M_YIELD) {
    for (long n = 1; atomic_load_explicit(&ch->seq, memory_order_acquire) != want; n++) {
      sched_yield();
      if ((n & 0xff) == 0 && expired(s)) return -1;
    }
    return 0;
  }
  if (s->mode != M_FUTEX) {
    long limit = s->mode == M_SPIN ? -1 : s->spin_iters;
    for (long n = 1; atomic_load_explicit(&ch->seq, memory_order_acquire) != want; n++) {
      if (n == limit) goto sleep;
      cpu_relax();
      if ((n & 0x3fff) == 0 && expired(s)) return -1;
    }
    return 0;
  }
sleep:;
  const struct timespec timeout = {1, 0}; /* only a safety net: counted, never expected */
  uint32_t cur;
  int slept = 0;
  for (;;) {
    if (s->mode == M_ADAPTIVE) atomic_store(&ch->sleeping, 1);
    if ((cur = atomic_load(&ch->seq)) == want) break;
    if (!slept++) s->c.sleeps++; /* counts waits that slept, not futex calls */
    /* returns at once (EAGAIN) if seq already moved past cur */
    if (futex(&ch->seq, FUTEX_WAIT, cur, &timeout) != 0 && errno == ETIMEDOUT) s->c.timeouts++;
    if (expired(s)) return -1;
  }
  if (s->mode == M_ADAPTIVE) atomic_store_explicit(&ch->sleeping, 0, memory_order_relaxed);
  return 0;
}

/* What one spin iteration costs here (pause latency differs ~10x between CPU models), so a
 * reader can turn --spin-iters into time. */
static double ns_per_spin_iteration(void) {
  const int n = 20000;
  uint64_t t0 = now_ns();
  for (int i = 0; i < n; i++) cpu_relax();
  return (double)(now_ns() - t0) / n;
}

static char scratch[MAX_PAYLOAD];

static void responder(struct side* s, int cpu, long total, size_t payload) {
  alarm(PROBE_HARD_ALARM_S);
  struct shared* sh = s->sh;
  /* on any failure raise abort_flag, so A stops waiting now rather than at its deadline */
  if (pin_to_cpu(cpu)) {
    atomic_store(&sh->abort_flag, 1);
    _exit(4);
  }
  for (long i = 1; i <= total; i++) {
    if (wait_peer(s, &sh->a2b, (uint32_t)i)) {
      atomic_store(&sh->abort_flag, 1);
      _exit(3);
    }
    if (payload) {
      memcpy(scratch, sh->a2b_data, payload);
      memcpy(sh->b2a_data, scratch, payload);
    }
    signal_peer(s, &sh->b2a, (uint32_t)i);
  }
  sh->b_counters = s->c;
  _exit(0);
}

int main(int argc, char** argv) {
  alarm(PROBE_HARD_ALARM_S);
  static const char* const mode_names[] = {"spin", "futex", "adaptive", "yield"};  // as enum mode
  const struct rtt_args o = arg_rtt(argc, argv, "--mode", mode_names, 4);
  const enum mode mode = (enum mode)o.choice;
  const char* mode_name = mode_names[mode];
  long payload = arg_long(argc, argv, "--payload", 64);
  long spin_iters = arg_long(argc, argv, "--spin-iters", 200);
  if (payload < 0 || payload > MAX_PAYLOAD) die("--payload must be 0..%d", MAX_PAYLOAD);
  if (spin_iters < 1) die("--spin-iters must be >= 1");
  /* Both spinners on one CPU only progress when the scheduler preempts one: milliseconds per hop. */
  if (mode == M_SPIN && o.cpu_a == o.cpu_b && o.cpu_a >= 0)
    die("spin with both processes on cpu %d cannot make progress", o.cpu_a);

  struct shared* sh = mmap(NULL, sizeof *sh, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (sh == MAP_FAILED) die("mmap failed");
  memset(sh, 0, sizeof *sh);
  memset(scratch, 1, sizeof scratch);
  struct side me = {
      .sh = sh, .mode = mode, .spin_iters = spin_iters, .deadline = now_ns() + (uint64_t)o.deadline_s * 1000000000ull};
  const long total = o.warmup + o.iters;

  pid_t pid = fork();
  if (pid < 0) die("fork failed");
  if (pid == 0) responder(&me, o.cpu_b, total, (size_t)payload);

  uint64_t* samples = start_measuring(pid, o.cpu_a, o.iters);
  int failed = 0;
  for (long i = 1; i <= total && !failed; i++) {
    uint64_t t0 = now_ns();
    if (payload) memcpy(sh->a2b_data, scratch, (size_t)payload);
    signal_peer(&me, &sh->a2b, (uint32_t)i);
    failed = wait_peer(&me, &sh->b2a, (uint32_t)i);
    if (payload) memcpy(scratch, sh->b2a_data, (size_t)payload);
    uint64_t t1 = now_ns();
    if (i > o.warmup) samples[i - o.warmup - 1] = t1 - t0;
  }
  reap_peer(pid, failed, &sh->abort_flag, "responder");
  if (failed) die("%s: deadline of %ld s passed", mode_name, o.deadline_s);

  struct rtt_stats st = rtt_stats_of(samples, (size_t)o.iters);
  struct wait_counters b = sh->b_counters;
  uint64_t waits = me.c.waits + b.waits, sleeps = me.c.sleeps + b.sleeps;
  printf(
      "{\"probe\": \"shm_rtt\", \"mode\": \"%s\", \"cpus\": [%d, %d], \"payload\": %ld, "
      "\"warmup\": %ld, \"spin_iters\": %ld, \"ns_per_spin_iter\": %.2f, ",
      mode_name, o.cpu_a, o.cpu_b, payload, o.warmup, mode == M_ADAPTIVE ? spin_iters : 0, ns_per_spin_iteration());
  print_rtt_stats_json(&st);
  printf(
      ", \"waits\": %llu, \"sleeps\": %llu, \"sleep_share\": %.4f, \"wakes\": %llu, "
      "\"futex_timeouts\": %llu}\n",
      (unsigned long long)waits, (unsigned long long)sleeps, waits ? (double)sleeps / waits : 0.0,
      (unsigned long long)(me.c.wakes + b.wakes), (unsigned long long)(me.c.timeouts + b.timeouts));
  free(samples);
  return 0;
}
