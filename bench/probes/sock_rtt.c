/* Kernel socket round trip between two processes (fork), blocking I/O.
 *
 *   sock_rtt --kind unix|udp|tcp [--cpus 0,1] [--iters 20000] [--warmup 2000] [--size 64]
 *            [--deadline-s 20]
 *
 *   unix  AF_UNIX stream socketpair (what LN uses for local services)
 *   udp   two connected UDP sockets on 127.0.0.1
 *   tcp   TCP on 127.0.0.1 with TCP_NODELAY on both ends (LN's remote/reliable path)
 *
 * A sends --size bytes, B reads them all and sends them back, A reads them all: one round trip.
 * Sockets get 2 s receive/send timeouts so a lost datagram or a dead peer ends the run with an
 * error instead of a hang. Prints one JSON line with the RTT statistics in µs. */
#include "probe.h"  // first: it defines _GNU_SOURCE

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>

#define MAX_SIZE 65000 /* fits one UDP datagram */

enum kind { K_UNIX, K_UDP, K_TCP };

static void set_timeouts(int fd) {
  struct timeval tv = {2, 0};
  if (setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv) ||
      setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv))
    die("setsockopt timeouts failed");
}

static struct sockaddr_in loopback_any_port(void) {
  struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = 0};
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}

/* fd[0] for A, fd[1] for B; each is bidirectional. */
static void make_pair(enum kind k, int fd[2]) {
  if (k == K_UNIX) {
    if (socketpair(AF_UNIX, SOCK_STREAM, 0, fd)) die("socketpair failed");
  } else if (k == K_UDP) {
    struct sockaddr_in a[2] = {loopback_any_port(), loopback_any_port()};
    for (int i = 0; i < 2; i++) {
      socklen_t len = sizeof a[i];
      fd[i] = socket(AF_INET, SOCK_DGRAM, 0);
      if (fd[i] < 0 || bind(fd[i], (struct sockaddr*)&a[i], sizeof a[i]) ||
          getsockname(fd[i], (struct sockaddr*)&a[i], &len))
        die("udp socket/bind on 127.0.0.1 failed");
    }
    if (connect(fd[0], (struct sockaddr*)&a[1], sizeof a[1]) || connect(fd[1], (struct sockaddr*)&a[0], sizeof a[0]))
      die("udp connect failed");
  } else {
    struct sockaddr_in a = loopback_any_port();
    socklen_t len = sizeof a;
    int one = 1, listener = socket(AF_INET, SOCK_STREAM, 0);
    if (listener < 0 || bind(listener, (struct sockaddr*)&a, sizeof a) || listen(listener, 1) ||
        getsockname(listener, (struct sockaddr*)&a, &len))
      die("tcp listen on 127.0.0.1 failed");
    fd[0] = socket(AF_INET, SOCK_STREAM, 0);
    if (fd[0] < 0 || connect(fd[0], (struct sockaddr*)&a, sizeof a)) die("tcp connect failed");
    fd[1] = accept(listener, NULL, NULL);
    if (fd[1] < 0) die("tcp accept failed");
    close(listener);
    for (int i = 0; i < 2; i++)
      if (setsockopt(fd[i], IPPROTO_TCP, TCP_NODELAY, &one, sizeof one)) die("TCP_NODELAY failed");
  }
  set_timeouts(fd[0]);
  set_timeouts(fd[1]);
}

/* Stream sockets may split a message: loop until all of it moved. A datagram is one read. */
static int recv_all(int fd, char* buf, size_t n, int stream) {
  if (!stream) return read(fd, buf, n) == (ssize_t)n ? 0 : -1;
  for (size_t got = 0; got < n;) {
    ssize_t r = read(fd, buf + got, n - got);
    if (r <= 0) return -1;
    got += (size_t)r;
  }
  return 0;
}
static int send_all(int fd, const char* buf, size_t n) {
  for (size_t put = 0; put < n;) {
    ssize_t w = write(fd, buf + put, n - put);
    if (w <= 0) return -1;
    put += (size_t)w;
  }
  return 0;
}

int main(int argc, char** argv) {
  alarm(PROBE_HARD_ALARM_S);
  signal(SIGPIPE, SIG_IGN); /* an echo that ended early (say, it could not pin itself): EPIPE, then its reason */
  static const char* const kind_names[] = {"unix", "udp", "tcp"};  // as enum kind
  const struct rtt_args o = arg_rtt(argc, argv, "--kind", kind_names, 3);
  const enum kind k = (enum kind)o.choice;
  const char* kind_name = kind_names[k];
  long size = arg_long(argc, argv, "--size", 64);
  if (size < 1 || size > MAX_SIZE) die("--size must be 1..%d", MAX_SIZE);

  int fd[2];
  make_pair(k, fd);
  int stream = k != K_UDP;
  char* buf = malloc((size_t)size);
  if (!buf) die("out of memory");
  memset(buf, 7, (size_t)size);
  const long total = o.warmup + o.iters;
  const uint64_t deadline = now_ns() + (uint64_t)o.deadline_s * 1000000000ull;

  pid_t pid = fork();
  if (pid < 0) die("fork failed");
  if (pid == 0) { /* B: echo */
    alarm(PROBE_HARD_ALARM_S);
    if (pin_to_cpu(o.cpu_b)) _exit(4);
    close(fd[0]);
    for (long i = 0; i < total; i++)
      if (recv_all(fd[1], buf, (size_t)size, stream) || send_all(fd[1], buf, (size_t)size) || now_ns() > deadline)
        _exit(3);
    _exit(0);
  }

  close(fd[1]);
  uint64_t* samples = start_measuring(pid, o.cpu_a, o.iters);
  int failed = 0;
  for (long i = 0; i < total; i++) {
    uint64_t t0 = now_ns();
    if (send_all(fd[0], buf, (size_t)size) || recv_all(fd[0], buf, (size_t)size, stream)) {
      failed = 1;
      break;
    }
    uint64_t t1 = now_ns();
    if (i >= o.warmup) samples[i - o.warmup] = t1 - t0;
    if (t1 > deadline) {
      failed = 2;
      break;
    }
  }
  if (failed) kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFEXITED(status) && WEXITSTATUS(status) == 4) die("cannot pin the echo process to cpu %d", o.cpu_b);
  if (failed == 1) die("%s: send/receive failed or timed out (2 s)", kind_name);
  if (failed == 2) die("%s: deadline of %ld s passed", kind_name, o.deadline_s);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) die("echo process failed (status %d)", status);

  struct rtt_stats st = rtt_stats_of(samples, (size_t)o.iters);
  printf("{\"probe\": \"sock_rtt\", \"kind\": \"%s\", \"cpus\": [%d, %d], \"size\": %ld, \"warmup\": %ld, ", kind_name,
         o.cpu_a, o.cpu_b, size, o.warmup);
  print_rtt_stats_json(&st);
  printf("}\n");
  free(samples);
  free(buf);
  return 0;
}
