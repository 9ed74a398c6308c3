/* Shared helpers for the bench probes: clock, CPU pinning, argument parsing, statistics
 * and the one-JSON-line output the runner parses.
 *
 * Every probe is bounded three ways: an iteration count, a wall-clock deadline checked
 * inside every wait loop, and alarm() as the last resort if a loop is ever wrong. */
#ifndef BENCH_PROBE_H
#define BENCH_PROBE_H
#define _GNU_SOURCE
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define PROBE_HARD_ALARM_S 90 /* no probe process outlives this, whatever its arguments */

static inline uint64_t now_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static inline void cpu_relax(void) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  __asm__ __volatile__("yield");
#endif
}

/* Pin the calling process; cpu < 0 leaves placement to the scheduler. */
static inline int pin_to_cpu(int cpu) {
  if (cpu < 0) return 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return sched_setaffinity(0, sizeof set, &set);
}

/* Errors go to stderr as text and the exit code is non-zero: the runner shows both. */
static inline __attribute__((noreturn, format(printf, 1, 2))) void die(const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs("probe error: ", stderr);
  vfprintf(stderr, fmt, ap);
  fputc('\n', stderr);
  va_end(ap);
  exit(1);
}

/* --- "--key value" arguments: tiny on purpose, every probe takes only a few options --- */
static inline const char* arg_str(int argc, char** argv, const char* key, const char* dflt) {
  for (int i = 1; i + 1 < argc; i++)
    if (strcmp(argv[i], key) == 0) return argv[i + 1];
  return dflt;
}
static inline long arg_long(int argc, char** argv, const char* key, long dflt) {
  const char* s = arg_str(argc, argv, key, NULL);
  if (!s) return dflt;
  char* end;
  long v = strtol(s, &end, 10);
  if (*s == '\0' || *end != '\0') die("option %s wants an integer, got '%s'", key, s);
  return v;
}
/* "--cpus A,B": placement of the two processes (A = initiator, B = responder). */
static inline void arg_cpus(int argc, char** argv, int* a, int* b) {
  const char* s = arg_str(argc, argv, "--cpus", "0,1");
  if (sscanf(s, "%d,%d", a, b) != 2) die("--cpus wants A,B (e.g. 0,1 or 0,0), got '%s'", s);
}

/* "KEY NAME", NAME one of the n names: its index (0 when the option is absent). */
static inline int arg_choice(int argc, char** argv, const char* key, const char* const* names, int n) {
  const char* s = arg_str(argc, argv, key, names[0]);
  char list[256] = "";
  for (int i = 0; i < n; i++) {
    if (!strcmp(s, names[i])) return i;
    size_t used = strlen(list);
    snprintf(list + used, sizeof list - used, "%s%s", i ? ", " : "", names[i]);
  }
  die("unknown %s '%s' (%s)", key, s, list);
}
/* "--deadline-s S": the wall-clock limit of the measurement, well below the hard alarm. */
static inline long arg_deadline_s(int argc, char** argv) {
  long s = arg_long(argc, argv, "--deadline-s", 20);
  if (s < 1 || s > PROBE_HARD_ALARM_S - 10) die("--deadline-s out of range");
  return s;
}
/* The options of a round-trip probe: `choice_key` NAME (one of the n choice_names, the first when
 * absent: its index), --cpus A,B, --iters N timed round trips after --warmup W untimed ones, and
 * --deadline-s S (arg_deadline_s). */
struct rtt_args {
  int choice, cpu_a, cpu_b;
  long iters, warmup, deadline_s;
};
static inline struct rtt_args arg_rtt(int argc, char** argv, const char* choice_key, const char* const* choice_names,
                                      int n) {
  struct rtt_args o;
  o.choice = arg_choice(argc, argv, choice_key, choice_names, n);
  arg_cpus(argc, argv, &o.cpu_a, &o.cpu_b);
  o.iters = arg_long(argc, argv, "--iters", 20000);
  o.warmup = arg_long(argc, argv, "--warmup", 2000);
  if (o.iters < 1 || o.iters > 10000000 || o.warmup < 0 || o.warmup > 1000000) die("bad --iters/--warmup");
  o.deadline_s = arg_deadline_s(argc, argv);
  return o;
}

/* --- the two processes of a probe: the measuring one (A) and the forked peer (B) --- */
/* A after fork(): pins itself to `cpu`, or kills the peer `pid` and dies. */
static inline void pin_or_end_peer(pid_t pid, int cpu) {
  if (pin_to_cpu(cpu)) {
    kill(pid, SIGKILL);
    die("cannot pin to cpu %d", cpu);
  }
}
/* A after fork(): pin_or_end_peer() and zeroed room for `iters` round-trip samples. */
static inline uint64_t* start_measuring(pid_t pid, int cpu, long iters) {
  pin_or_end_peer(pid, cpu);
  uint64_t* samples = calloc((size_t)iters, sizeof *samples);
  if (!samples) die("out of memory");
  return samples;
}
/* A after its loop: when A `failed`, raises *abort_flag (B stops waiting) and kills B; reaps B
 * and dies when B failed (its exit code 4: it could not pin itself). `peer` names B. */
static inline void reap_peer(pid_t pid, int failed, _Atomic int* abort_flag, const char* peer) {
  if (failed) {
    atomic_store(abort_flag, 1);
    kill(pid, SIGKILL);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    die("%s failed (%s)", peer,
        WIFEXITED(status) && WEXITSTATUS(status) == 4 ? "cannot pin it to its cpu" : "deadline or signal");
}

/* --- statistics over round-trip samples (ns); sorts in place --- */
struct rtt_stats {
  size_t n;
  double min_us, median_us, mean_us, p99_us, p999_us, max_us;
};

static int cmp_u64(const void* x, const void* y) {
  uint64_t a = *(const uint64_t*)x, b = *(const uint64_t*)y;
  return (a > b) - (a < b);
}

static inline struct rtt_stats rtt_stats_of(uint64_t* s, size_t n) {
  struct rtt_stats r = {0};
  if (n == 0) return r;
  qsort(s, n, sizeof *s, cmp_u64);
  long double sum = 0;
  for (size_t i = 0; i < n; i++) sum += s[i];
  r.n = n;
  r.min_us = s[0] / 1e3;
  r.median_us = s[n / 2] / 1e3;
  r.mean_us = (double)(sum / n) / 1e3;
  r.p99_us = s[(size_t)((n - 1) * 0.99)] / 1e3;
  r.p999_us = s[(size_t)((n - 1) * 0.999)] / 1e3;
  r.max_us = s[n - 1] / 1e3;
  return r;
}

/* Prints the statistics as JSON members (no braces) so each probe can add its own. */
static inline void print_rtt_stats_json(const struct rtt_stats* r) {
  printf(
      "\"n\": %zu, \"min_us\": %.4f, \"median_us\": %.4f, \"mean_us\": %.4f, "
      "\"p99_us\": %.4f, \"p999_us\": %.4f, \"max_us\": %.4f",
      r->n, r->min_us, r->median_us, r->mean_us, r->p99_us, r->p999_us, r->max_us);
}

#endif
