/* memcpy bandwidth on one pinned core with warm buffers (src and dst reused every copy):
 * the ceiling for any path that copies a payload once.
 *
 *   memcpy_bw [--cpu 0] [--sizes 64,4096,65536,1048576,16777216] [--trials 5] [--trial-ms 200]
 *
 * One JSON line per size. GB/s = bytes copied / s (1 GB = 1e9 B), read+write traffic is twice
 * that. A trial copies until 1 GiB moved or --trial-ms passed; best and median over trials. */
#include "probe.h"  // first: it defines _GNU_SOURCE

/* Through a volatile pointer so the compiler can neither inline nor drop a copy whose
 * destination is never read. */
typedef void* (*memcpy_fn)(void*, const void*, size_t);
static volatile memcpy_fn do_copy = memcpy;

static int cmp_double_desc(const void* x, const void* y) {
  double a = *(const double*)x, b = *(const double*)y;
  return (a < b) - (a > b);
}

static void measure(size_t size, int trials, long trial_ms) {
  size_t alloc = size < 4096 ? 4096 : size;
  char *src = aligned_alloc(4096, alloc), *dst = aligned_alloc(4096, alloc);
  if (!src || !dst) die("cannot allocate 2 x %zu bytes", alloc);
  memset(src, 0x5a, size);
  memset(dst, 0xa5, size); /* touch every page before timing */

  double gbps[64];
  uint64_t total_copies = 0;
  /* read the clock after a batch: ~64 copies, fewer for big sizes so a batch stays ~64 MiB */
  size_t batch = (64u << 20) / size;
  if (batch > 64) batch = 64;
  if (batch < 1) batch = 1;
  for (int t = 0; t < trials; t++) {
    uint64_t copies = 0, t0 = now_ns(), t1, deadline = t0 + (uint64_t)trial_ms * 1000000u;
    do {
      for (size_t j = 0; j < batch; j++) do_copy(dst, src, size);
      copies += batch;
      t1 = now_ns();
    } while (copies * size < (1ull << 30) && t1 < deadline);
    gbps[t] = (double)(copies * size) / (double)(t1 - t0);
    total_copies += copies;
  }
  qsort(gbps, (size_t)trials, sizeof gbps[0], cmp_double_desc);
  double median = gbps[trials / 2];
  printf(
      "{\"probe\": \"memcpy_bw\", \"size\": %zu, \"best_gbps\": %.4f, \"median_gbps\": %.4f, "
      "\"trials\": %d, \"copies\": %llu, \"ns_per_copy_median\": %.3f, \"check\": %d}\n",
      size, gbps[0], median, trials, (unsigned long long)total_copies, size / median, dst[size - 1] == src[size - 1]);
  fflush(stdout);
  free(src);
  free(dst);
}

int main(int argc, char** argv) {
  alarm(PROBE_HARD_ALARM_S);
  int cpu = (int)arg_long(argc, argv, "--cpu", 0);
  int trials = (int)arg_long(argc, argv, "--trials", 5);
  long trial_ms = arg_long(argc, argv, "--trial-ms", 200);
  const char* sizes = arg_str(argc, argv, "--sizes", "64,4096,65536,1048576,16777216");
  if (trials < 1 || trials > 64) die("--trials must be 1..64");
  if (trial_ms < 1 || trial_ms > 2000) die("--trial-ms must be 1..2000");
  if (pin_to_cpu(cpu)) die("cannot pin to cpu %d", cpu);

  char* list = strdup(sizes);
  for (char *save = NULL, *tok = strtok_r(list, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
    long size = atol(tok);
    if (size < 1 || size > (1l << 30)) die("size %s out of range 1..1 GiB", tok);
    measure((size_t)size, trials, trial_ms);
  }
  free(list);
  return 0;
}
