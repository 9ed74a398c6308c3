// What a topic logger costs its publisher, LN 2.9 C++ API: a publisher at a
// fixed rate (1 kHz by default), 64 B packets, no subscriber, with or
// without a logger of its topic enabled (the manager records in ln_core,
// the daemon in LN 2.9).
//
//   ln_logger pub [--topic T] [--n N] [--warmup W] [--rate HZ] [--logger 0|1]
//
// Writes W + N packets on an absolute schedule (sleeping until each
// deadline) and times every one of the last N write() calls (steady clock
// around the call) and how late the loop woke for it. With --logger 1 the
// logger is enabled before the first write and downloaded at the end: the
// result says how many of the N packets it holds.
#include <time.h>

#include "common.hpp"
#include "ln_messages.h"

using namespace bench;

namespace {

void sleep_until(Clock::time_point deadline) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline.time_since_epoch()).count();
  timespec at{static_cast<time_t>(ns / 1000000000), static_cast<long>(ns % 1000000000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr) != 0) {
  }
}

int pub(ln::client& clnt, const Args& args) {
  const std::string topic = args.str("topic", "lnbench.logged");
  const long n = args.integer("n", 3000);
  const long warmup = args.integer("warmup", 200);
  const double rate = args.real("rate", 1000);
  const bool with_logger = args.integer("logger", 0) != 0;
  ln::outport* out = clnt.publish(topic, "lnbench/p64");
  ln::logger* logger = nullptr;
  if (with_logger) {
    logger = clnt.get_logger("lnbench_" + topic);
    logger->add_topic(topic, static_cast<uint64_t>(n + warmup), 1);
    logger->enable();
  }
  Packet64 packet{};
  std::vector<double> cost, late;
  cost.reserve(static_cast<size_t>(n));
  late.reserve(static_cast<size_t>(n));
  const auto period = std::chrono::nanoseconds(static_cast<long long>(1e9 / rate));
  const auto start = Clock::now() + std::chrono::milliseconds(10);
  for (long i = 0; i < warmup + n; ++i) {
    const auto deadline = start + period * i;
    sleep_until(deadline);
    stamp(&packet, sizeof packet, static_cast<uint32_t>(i + 1));
    const auto t0 = Clock::now();
    out->write(&packet);
    const auto t1 = Clock::now();
    if (i < warmup) continue;
    cost.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    late.push_back(std::chrono::duration<double, std::micro>(t0 - deadline).count());
  }
  long recorded = -1;
  if (logger != nullptr) {
    logger->disable();
    ln::logger_data* data = logger->download();
    if (data->topics.empty()) throw Failure("the logger's download has no topic");
    ln::logger_data::topic_cursor* cursor = data->topics.front();
    recorded = 0;
    for (uint32_t i = 0; i < cursor->topic->n_samples; ++i) {
      uint32_t seq;
      std::memcpy(&seq, &cursor->get_sample(i)->data, sizeof seq);
      if (seq > static_cast<uint32_t>(warmup)) ++recorded;
    }
  }
  const Stats c = stats_of(cost), l = stats_of(late);
  Json()
      .boolean("ok", true)
      .boolean("logger", with_logger)
      .integer("n", n)
      .num("rate_hz", rate)
      .num("write_median_us", c.median)
      .num("write_p99_us", c.p99)
      .num("write_max_us", c.max)
      .num("late_median_us", l.median)
      .num("late_p99_us", l.p99)
      .integer("recorded", recorded)
      .print();
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return role_main(argc, argv, "lnbench_logger_", {{"pub", pub}}); }
