// Micro-benchmark of the shared-memory topic transport. Every case forks two
// pinned processes that exchange segment descriptors over a socketpair; the
// measuring process prints one JSON line per case on stdout.
//
//   shm_ring_bench                       the standard suite (see run_suite)
//   shm_ring_bench rtt SIZE MODE PLACEMENT [ITERATIONS]
//        MODE: copy (write + read, 4 payload copies per round trip)
//              zero_copy (loan/commit + borrow, only an 8-byte sequence is touched)
//              write_borrow (write + borrow: 2 payload copies per round trip)
//              copy_nospin (copy with spinning disabled: pure futex wake-ups)
//   shm_ring_bench rate SIZE BUFFERS PLACEMENT SECONDS [MSGS_PER_S]
//        one-way stream; without MSGS_PER_S the publisher writes as fast as it can;
//        a paced publisher that was descheduled resumes its rhythm (catching up
//        at most 10 µs worth of packets) instead of bursting
//   PLACEMENT: same (both on CPU 1) or split (CPU 0 and CPU 1)
//   Options (before the test name):
//     --repeat N        run every case N times
//     --max-spin-us N   SpinPolicy::max_spin of all readers (default 50; 0 = futex only)
//     --lag-policy newest|window   LagPolicy of the rate subscriber (default newest, like LN)
//     --wait-quiet S    wait at most S seconds for quiet CPUs before every case (default 60)
//   Before every case the driver waits (at most 60 s) until both CPUs are at
//   most 15 % busy, so that other load on the machine disturbs less; the JSON
//   line says whether it succeeded ("quiet").

#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "transport/shm_ring.hpp"

namespace {

using namespace ln::transport;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// Global knobs set from the command line.
long g_max_spin_us = 50;
long g_wait_quiet_s = 60;
bool g_quiet = true;
LagPolicy g_lag_policy = LagPolicy::skip_to_newest;

SpinPolicy spin_policy() {
  SpinPolicy spin;
  spin.max_spin = std::chrono::microseconds(g_max_spin_us);
  spin.min_spin = std::min(spin.min_spin, spin.max_spin);
  return spin;
}

// Busy share of each CPU over `window`, from /proc/stat.
std::vector<double> cpu_busy_shares(std::chrono::milliseconds window) {
  const auto sample = [] {
    std::vector<std::pair<unsigned long long, unsigned long long>> cpus;  // busy, total
    if (std::FILE* stat = std::fopen("/proc/stat", "r")) {
      char line[512];
      while (std::fgets(line, sizeof(line), stat) != nullptr) {
        if (std::strncmp(line, "cpu", 3) != 0 || line[3] < '0' || line[3] > '9') continue;
        unsigned long long v[8] = {};
        std::sscanf(line, "%*s %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5],
                    &v[6], &v[7]);
        const unsigned long long idle = v[3] + v[4];
        unsigned long long total = 0;
        for (unsigned long long x : v) total += x;
        cpus.emplace_back(total - idle, total);
      }
      std::fclose(stat);
    }
    return cpus;
  };
  const auto before = sample();
  std::this_thread::sleep_for(window);
  const auto after = sample();
  std::vector<double> shares;
  for (std::size_t i = 0; i < before.size() && i < after.size(); ++i) {
    const double total = static_cast<double>(after[i].second - before[i].second);
    shares.push_back(total > 0 ? static_cast<double>(after[i].first - before[i].first) / total : 0.0);
  }
  return shares;
}

bool wait_for_quiet_cpus() {
  const auto deadline = Clock::now() + std::chrono::seconds(g_wait_quiet_s);
  while (Clock::now() < deadline) {
    const std::vector<double> shares = cpu_busy_shares(250ms);
    if (std::all_of(shares.begin(), shares.end(), [](double share) { return share <= 0.15; })) return true;
  }
  return false;
}

struct Placement {
  std::string name;
  int measuring_cpu;
  int other_cpu;
};

Placement placement_named(const std::string& name) {
  if (name == "same") return {name, 1, 1};
  return {"split", 0, 1};
}

bool pin_to_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return ::sched_setaffinity(0, sizeof(set), &set) == 0;
}

void send_all(int socket, const void* data, std::size_t size) {
  if (::send(socket, data, size, MSG_NOSIGNAL) != static_cast<ssize_t>(size)) throw std::runtime_error("send");
}

void receive_all(int socket, void* data, std::size_t size) {
  auto* bytes = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t got = ::recv(socket, bytes, size, 0);
    if (got <= 0) throw std::runtime_error("recv");
    bytes += got;
    size -= static_cast<std::size_t>(got);
  }
}

// Each side creates the segment it publishes and hands its descriptor to the other.
struct Link {
  ShmWriter writer;
  ShmReader reader;
};

Link connect(int socket, const RingConfig& mine, const ReaderOptions& options) {
  ShmWriter writer = ShmWriter::create(mine);
  send_fd(socket, writer.fd());
  ShmReader reader = ShmReader::attach(receive_fd(socket), options);
  const char ready = 'r';
  send_all(socket, &ready, 1);  // attached: from now on every packet reaches us
  char other = 0;
  receive_all(socket, &other, 1);
  return {std::move(writer), std::move(reader)};
}

// Forks `body` and returns its pid.
template <typename Body>
pid_t spawn(Body body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    int code = 1;
    try {
      code = body();
    } catch (const std::exception& error) {
      std::fprintf(stderr, "bench child: %s\n", error.what());
    }
    std::fflush(stdout);
    ::_exit(code);
  }
  return pid;
}

bool has_exited(pid_t pid) {
  siginfo_t info{};
  return ::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid;
}

// Waits until `pid` exits or the deadline passes, without periodic wake-ups
// (they would land on the measured CPUs): poll() on a pidfd.
bool wait_for_exit(pid_t pid, Clock::time_point deadline) {
  const int pidfd = static_cast<int>(::syscall(SYS_pidfd_open, pid, 0));
  while (!has_exited(pid)) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) break;
    if (pidfd >= 0) {
      pollfd entry{pidfd, POLLIN, 0};
      ::poll(&entry, 1, static_cast<int>(std::min<long long>(left.count(), 60000)));
    } else {
      std::this_thread::sleep_for(std::min<std::chrono::milliseconds>(left, 50ms));
    }
  }
  if (pidfd >= 0) ::close(pidfd);
  return has_exited(pid);
}

// Waits for both children, killing them (by pid) if they overrun.
bool reap(pid_t first, pid_t second, std::chrono::seconds limit) {
  const auto deadline = Clock::now() + limit;
  bool ok = true;
  for (pid_t pid : {first, second}) {
    int status = 0;
    if (!wait_for_exit(pid, deadline)) {
      ::kill(pid, SIGKILL);
      ok = false;
    }
    ::waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) ok = false;
  }
  return ok;
}

// Hypervisor steal time of all CPUs so far, in milliseconds (USER_HZ = 100).
double steal_ms() {
  double steal = 0;
  if (std::FILE* stat = std::fopen("/proc/stat", "r")) {
    unsigned long long v[8] = {};
    if (std::fscanf(stat, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5],
                    &v[6], &v[7]) == 8) {
      steal = static_cast<double>(v[7]) * 10.0;
    }
    std::fclose(stat);
  }
  return steal;
}

double percentile(std::vector<double>& values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(p * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(index, values.size() - 1)];
}

// ------------------------------------------------------------------ round trip

ReaderOptions rtt_reader_options(const std::string& mode) {
  ReaderOptions options;
  options.spin = spin_policy();
  if (mode == "copy_nospin") {
    options.spin.min_spin = 0ns;
    options.spin.max_spin = 0ns;
  }
  return options;
}

int rtt_echo(int socket, std::uint32_t size, const std::string& mode, int cpu) {
  pin_to_cpu(cpu);
  Link link = connect(socket, RingConfig{size, 1, 2, 1, "bench_pong"}, rtt_reader_options(mode));
  std::vector<unsigned char> buffer(size);
  SampleInfo info;
  for (;;) {
    if (mode == "zero_copy") {
      BorrowedSample ping;
      if (link.reader.borrow(ping, 2s) != ReadStatus::ok) return 0;
      void* reply = link.writer.loan();
      std::memcpy(reply, ping.data(), sizeof(std::uint64_t));
      link.writer.commit(ping.size(), ping.info().timestamp);
    } else if (mode == "write_borrow") {
      BorrowedSample ping;
      if (link.reader.borrow(ping, 2s) != ReadStatus::ok) return 0;
      link.writer.write(ping.data(), ping.size(), ping.info().timestamp);
    } else {
      if (link.reader.read(buffer.data(), buffer.size(), info, 2s) != ReadStatus::ok) return 0;
      link.writer.write(buffer.data(), info.size, info.timestamp);
    }
  }
}

int rtt_measure(int socket, std::uint32_t size, const std::string& mode, const Placement& placement, int iterations) {
  const bool pinned = pin_to_cpu(placement.measuring_cpu);
  Link link = connect(socket, RingConfig{size, 1, 2, 1, "bench_ping"}, rtt_reader_options(mode));
  const int warmup = size > 65536 ? 50 : 2000;
  std::vector<unsigned char> outgoing(size, 0xab);
  std::vector<unsigned char> incoming(size);
  std::vector<double> microseconds;
  microseconds.reserve(static_cast<std::size_t>(iterations));
  int mismatches = 0;
  double steal_at_start = 0;
  for (int i = 0; i < warmup + iterations; ++i) {
    if (i == warmup) steal_at_start = steal_ms();
    const std::uint64_t sequence = static_cast<std::uint64_t>(i) + 1;
    std::uint64_t echoed = 0;
    const auto start = Clock::now();
    if (mode == "zero_copy") {
      void* slot = link.writer.loan();
      std::memcpy(slot, &sequence, sizeof(sequence));
      link.writer.commit(size, 0.0);
      BorrowedSample reply;
      if (link.reader.borrow(reply, 2s) != ReadStatus::ok) return 2;
      std::memcpy(&echoed, reply.data(), sizeof(echoed));
    } else if (mode == "write_borrow") {
      std::memcpy(outgoing.data(), &sequence, sizeof(sequence));
      link.writer.write(outgoing.data(), size, 0.0);
      BorrowedSample reply;
      if (link.reader.borrow(reply, 2s) != ReadStatus::ok) return 2;
      std::memcpy(&echoed, reply.data(), sizeof(echoed));
    } else {
      std::memcpy(outgoing.data(), &sequence, sizeof(sequence));
      link.writer.write(outgoing.data(), size, 0.0);
      SampleInfo info;
      if (link.reader.read(incoming.data(), incoming.size(), info, 2s) != ReadStatus::ok) return 2;
      std::memcpy(&echoed, incoming.data(), sizeof(echoed));
    }
    const auto stop = Clock::now();
    if (echoed != sequence) ++mismatches;
    if (i >= warmup) {
      microseconds.push_back(std::chrono::duration<double, std::micro>(stop - start).count());
    }
  }
  const double steal = steal_ms() - steal_at_start;
  link.writer.close();
  double sum = 0;
  for (double v : microseconds) sum += v;
  const double mean = sum / static_cast<double>(microseconds.size());
  const double p50 = percentile(microseconds, 0.50);
  const double p99 = percentile(microseconds, 0.99);
  const ReaderStats stats = link.reader.stats();
  std::printf(
      "{\"test\":\"rtt\",\"size\":%u,\"mode\":\"%s\",\"placement\":\"%s\",\"pinned\":%s,"
      "\"quiet\":%s,\"max_spin_us\":%ld,\"n\":%d,"
      "\"median_us\":%.3f,\"p99_us\":%.3f,\"mean_us\":%.3f,\"min_us\":%.3f,\"max_us\":%.1f,"
      "\"mismatches\":%d,\"steal_ms\":%.0f,\"spin_wakeups\":%llu,\"futex_sleeps\":%llu,\"yield_backoffs\":%llu}\n",
      size, mode.c_str(), placement.name.c_str(), pinned ? "true" : "false", g_quiet ? "true" : "false", g_max_spin_us,
      iterations, p50, p99, mean, microseconds.front(), microseconds.back(), mismatches, steal,
      static_cast<unsigned long long>(stats.spin_wakeups), static_cast<unsigned long long>(stats.futex_sleeps),
      static_cast<unsigned long long>(stats.yield_backoffs));
  return mismatches == 0 ? 0 : 3;
}

bool run_rtt(std::uint32_t size, const std::string& mode, const std::string& placement_name, int iterations) {
  const Placement placement = placement_named(placement_name);
  g_quiet = wait_for_quiet_cpus();
  int sockets[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets) != 0) return false;
  const pid_t echo = spawn([&] {
    ::close(sockets[0]);
    return rtt_echo(sockets[1], size, mode, placement.other_cpu);
  });
  const pid_t measure = spawn([&] {
    ::close(sockets[1]);
    return rtt_measure(sockets[0], size, mode, placement, iterations);
  });
  ::close(sockets[0]);
  ::close(sockets[1]);
  return reap(measure, echo, 120s);
}

// ------------------------------------------------------------------ one-way rate

struct PublisherReport {
  std::uint64_t written;
  double seconds;
  double longest_write_gap_us;  // publisher-side stalls (descheduled), not transport losses
};

int rate_publish(int socket, std::uint32_t size, std::uint32_t buffers, int cpu, double seconds,
                 double messages_per_second) {
  pin_to_cpu(cpu);
  Link link = connect(socket, RingConfig{size, buffers, 2, 1, "bench_rate"}, ReaderOptions{});
  std::vector<unsigned char> payload(size);
  std::uint64_t written = 0;
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(messages_per_second > 0 ? 1.0 / messages_per_second : 0.0));
  // After being descheduled the publisher resumes its rhythm instead of
  // bursting every overdue packet (a periodic source does not catch up).
  const auto max_lateness = std::chrono::duration_cast<Clock::duration>(10us);
  auto due = start;
  auto now = start;
  auto previous_write = start;
  Clock::duration longest_gap{};
  while (now < end) {
    // Check the clock only every 64 packets when flooding.
    for (int i = 0; i < 64; ++i) {
      if (messages_per_second > 0) {
        while ((now = Clock::now()) < due) {
        }
        due = std::max(due + period, now - max_lateness);
      }
      const std::uint64_t sequence = written + 1;
      std::memset(payload.data(), static_cast<int>(sequence & 0xff), size);
      std::memcpy(payload.data(), &sequence, sizeof(sequence));
      link.writer.write(payload.data(), size, 0.0);
      ++written;
    }
    now = Clock::now();
    longest_gap = std::max(longest_gap, now - previous_write);  // per 64 packets when flooding
    previous_write = now;
  }
  const PublisherReport report{written, std::chrono::duration<double>(Clock::now() - start).count(),
                               std::chrono::duration<double, std::micro>(longest_gap).count()};
  link.writer.close();
  send_all(socket, &report, sizeof(report));
  return 0;
}

int rate_receive(int socket, std::uint32_t size, std::uint32_t buffers, const Placement& placement, double seconds,
                 double messages_per_second) {
  const bool pinned = pin_to_cpu(placement.measuring_cpu);
  ReaderOptions options;
  options.buffers = buffers;
  options.spin = spin_policy();
  options.on_lag = g_lag_policy;
  Link link = connect(socket, RingConfig{8, 1, 0, 1, "bench_rate_unused"}, options);
  std::vector<unsigned char> buffer(size);
  std::uint64_t received = 0, lost = 0, torn = 0, out_of_order = 0, previous = 0;
  std::uint64_t loss_events = 0, largest_gap = 0, losses_after_sleep = 0;
  Clock::duration longest_stall{};
  Clock::time_point first{}, last{};
  const double steal_at_start = steal_ms();
  for (;;) {
    SampleInfo info;
    const std::uint64_t sleeps_before = link.reader.stats().futex_sleeps;
    const ReadStatus status = link.reader.read(buffer.data(), buffer.size(), info, 2s);
    if (status != ReadStatus::ok) break;
    const bool slept = link.reader.stats().futex_sleeps != sleeps_before;
    const auto now = Clock::now();
    if (received == 0) first = now;
    if (received != 0) longest_stall = std::max(longest_stall, now - last);
    last = now;
    ++received;
    lost += info.lost;
    if (info.lost != 0) {
      ++loss_events;
      if (slept) ++losses_after_sleep;
      largest_gap = std::max(largest_gap, info.lost);
    }
    std::uint64_t embedded = 0;
    std::memcpy(&embedded, buffer.data(), sizeof(embedded));
    bool intact = embedded == info.sequence;
    for (std::size_t i = sizeof(embedded); i < info.size; ++i) {
      intact = intact && buffer[i] == static_cast<unsigned char>(info.sequence & 0xff);
    }
    if (!intact) ++torn;
    if (info.sequence <= previous) ++out_of_order;
    previous = info.sequence;
  }
  const double steal = steal_ms() - steal_at_start;
  PublisherReport report{};
  receive_all(socket, &report, sizeof(report));
  const double receive_seconds = std::chrono::duration<double>(last - first).count();
  const ReaderStats stats = link.reader.stats();
  std::printf(
      "{\"test\":\"one_way\",\"size\":%u,\"buffers\":%u,\"placement\":\"%s\",\"pinned\":%s,"
      "\"quiet\":%s,\"max_spin_us\":%ld,\"lag_policy\":\"%s\","
      "\"pace\":\"%s\",\"target_per_s\":%.0f,\"seconds\":%.2f,\"written\":%llu,\"written_per_s\":%.0f,"
      "\"received\":%llu,\"received_per_s\":%.0f,\"lost\":%llu,\"delivered_share\":%.4f,"
      "\"loss_events\":%llu,\"losses_after_sleep\":%llu,\"largest_gap\":%llu,\"longest_stall_us\":%.0f,"
      "\"publisher_longest_gap_us\":%.0f,\"steal_ms\":%.0f,"
      "\"torn\":%llu,\"out_of_order\":%llu,\"spin_wakeups\":%llu,\"futex_sleeps\":%llu,"
      "\"yield_backoffs\":%llu,\"torn_copies_retried\":%llu}\n",
      size, buffers, placement.name.c_str(), pinned ? "true" : "false", g_quiet ? "true" : "false", g_max_spin_us,
      g_lag_policy == LagPolicy::skip_to_newest ? "newest" : "window", messages_per_second > 0 ? "paced" : "flood",
      messages_per_second, seconds, static_cast<unsigned long long>(report.written),
      static_cast<double>(report.written) / report.seconds, static_cast<unsigned long long>(received),
      receive_seconds > 0 ? static_cast<double>(received) / receive_seconds : 0.0,
      static_cast<unsigned long long>(lost),
      report.written ? static_cast<double>(received) / static_cast<double>(report.written) : 0.0,
      static_cast<unsigned long long>(loss_events), static_cast<unsigned long long>(losses_after_sleep),
      static_cast<unsigned long long>(largest_gap), std::chrono::duration<double, std::micro>(longest_stall).count(),
      report.longest_write_gap_us, steal, static_cast<unsigned long long>(torn),
      static_cast<unsigned long long>(out_of_order), static_cast<unsigned long long>(stats.spin_wakeups),
      static_cast<unsigned long long>(stats.futex_sleeps), static_cast<unsigned long long>(stats.yield_backoffs),
      static_cast<unsigned long long>(stats.torn_copies));
  return torn == 0 && out_of_order == 0 ? 0 : 3;
}

bool run_rate(std::uint32_t size, std::uint32_t buffers, const std::string& placement_name, double seconds,
              double messages_per_second) {
  const Placement placement = placement_named(placement_name);
  g_quiet = wait_for_quiet_cpus();
  int sockets[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sockets) != 0) return false;
  const pid_t publisher = spawn([&] {
    ::close(sockets[0]);
    return rate_publish(sockets[1], size, buffers, placement.other_cpu, seconds, messages_per_second);
  });
  const pid_t subscriber = spawn([&] {
    ::close(sockets[1]);
    return rate_receive(sockets[0], size, buffers, placement, seconds, messages_per_second);
  });
  ::close(sockets[0]);
  ::close(sockets[1]);
  return reap(subscriber, publisher, std::chrono::seconds(static_cast<int>(seconds) + 60));
}

void run_suite(int repeat) {
  for (int r = 0; r < repeat; ++r) {
    run_rtt(64, "copy", "same", 20000);
    run_rtt(64, "copy", "split", 20000);
    run_rtt(64, "copy_nospin", "same", 20000);
    run_rtt(64, "copy_nospin", "split", 20000);
    run_rtt(64, "zero_copy", "split", 20000);
    run_rtt(1 << 20, "copy", "split", 2000);
    run_rtt(1 << 20, "zero_copy", "split", 2000);
    run_rtt(1 << 20, "copy", "same", 2000);
    run_rtt(1 << 20, "zero_copy", "same", 2000);
    run_rtt(1 << 20, "write_borrow", "split", 2000);
    run_rate(64, 1, "split", 3.0, 0);
    run_rate(64, 256, "split", 3.0, 0);
    run_rate(64, 256, "split", 3.0, 2e6);
    run_rate(64, 16384, "split", 3.0, 2e6);
    run_rate(64, 1, "same", 3.0, 0);
    run_rate(64, 256, "same", 3.0, 0);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::vector<std::string> args(argv + 1, argv + argc);
  int repeat = 1;
  while (args.size() >= 2 && (args[0] == "--repeat" || args[0] == "--max-spin-us" || args[0] == "--lag-policy" ||
                              args[0] == "--wait-quiet")) {
    if (args[0] == "--repeat") repeat = std::max(1, std::atoi(args[1].c_str()));
    if (args[0] == "--max-spin-us") g_max_spin_us = std::max(0L, std::atol(args[1].c_str()));
    if (args[0] == "--wait-quiet") g_wait_quiet_s = std::max(0L, std::atol(args[1].c_str()));
    if (args[0] == "--lag-policy") {
      g_lag_policy = args[1] == "window" ? LagPolicy::keep_latest_window : LagPolicy::skip_to_newest;
    }
    args.erase(args.begin(), args.begin() + 2);
  }
  if (args.empty()) {
    run_suite(repeat);
    return 0;
  }
  bool ok = true;
  for (int r = 0; r < repeat; ++r) {
    if (args[0] == "rtt" && args.size() >= 4) {
      const int iterations = args.size() >= 5 ? std::atoi(args[4].c_str()) : 20000;
      ok = run_rtt(static_cast<std::uint32_t>(std::strtoul(args[1].c_str(), nullptr, 0)), args[2], args[3],
                   iterations) &&
           ok;
    } else if (args[0] == "rate" && args.size() >= 5) {
      const double pace = args.size() >= 6 ? std::atof(args[5].c_str()) : 0.0;
      ok = run_rate(static_cast<std::uint32_t>(std::strtoul(args[1].c_str(), nullptr, 0)),
                    static_cast<std::uint32_t>(std::strtoul(args[2].c_str(), nullptr, 0)), args[3],
                    std::atof(args[4].c_str()), pace) &&
           ok;
    } else {
      std::fprintf(stderr,
                   "usage: shm_ring_bench [--repeat N] [--max-spin-us N] [--lag-policy newest|window] [--wait-quiet S] "
                   "[rtt SIZE copy|zero_copy|write_borrow|copy_nospin "
                   "same|split [N] | rate SIZE BUFFERS same|split SECONDS [MSGS_PER_S]]\n");
      return 2;
    }
  }
  return ok ? 0 : 1;
}
