// Sustained one-way rate of 64 B packets, LN 2.9 C++ API.
//
//   ln_rate sub --buffers B [--topic T] [--max-seconds 60]
//   ln_rate pub --buffers B [--topic T] --seconds S [--rate R]
//
// --rate R paces the publisher to R packets/s (it busy-waits between batches
// of 64 writes, no sleeping), to see whether a subscriber that can keep up
// loses anything; without it the publisher writes as fast as it can.
//
// The subscriber (started first; prints "ready" once subscribed) does reads
// with a 1 s timeout and classifies every packet by its sequence number: new
// (higher than any seen), repeated (same as the previous one), older; it
// counts the numbers skipped (lost) after the first packet it got (first_seq;
// packets before that one are missing from `delivered` but not counted as
// lost: typically written before the subscription was in place) and checks
// every payload byte (torn).
// The publisher waits for has_subscriber(), writes as fast as it can for S
// seconds (payload bytes = seq & 0xff), then writes a stop packet carrying the
// number written and waits (bounded) for the subscriber to go away.
#include "common.hpp"
#include "ln_messages.h"

#include <thread>

using namespace bench;

namespace {

int sub(ln::client& clnt, const Args& args) {
  const unsigned buffers = static_cast<unsigned>(args.integer("buffers", 1));
  const std::string topic = args.str("topic", "lnbench.rate");
  const double max_seconds = args.real("max-seconds", 60);
  ln::inport* in = clnt.subscribe(topic, "lnbench/p64", -1, buffers);
  Packet64 pkt{};
  print_ready();
  const auto t_start = Clock::now();
  long long reads = 0, fresh = 0, repeats = 0, older = 0, lost = 0, torn = 0;
  long long written = -1;
  long long last = -1;
  long long first = -1;
  Clock::time_point t_first{}, t_last{};
  for (long long i = 0; i < 2000000000LL; ++i) {
    if (seconds_since(t_start) > max_seconds) throw Failure("no stop packet within max-seconds");
    if (!in->read(&pkt, 1.0)) {
      if (fresh > 0 && seconds_since(t_last) > 3) throw Failure("publisher went silent without a stop packet");
      continue;
    }
    if (pkt.seq == kStop) {
      std::memcpy(&written, pkt.pad, sizeof written);
      break;
    }
    const auto now = Clock::now();
    ++reads;
    for (uint8_t b : pkt.pad) {
      if (b != (pkt.seq & 0xff)) {
        ++torn;
        break;
      }
    }
    const long long s = pkt.seq;
    if (s > last) {
      if (fresh == 0) {
        t_first = now;
        first = s;
      }
      if (last >= 0) lost += s - last - 1;
      ++fresh;
      last = s;
      t_last = now;
    } else if (s == last) {
      ++repeats;
    } else {
      ++older;
    }
  }
  if (written < 0) throw Failure("no stop packet");
  const double window = std::chrono::duration<double>(t_last - t_first).count();
  Json()
      .boolean("ok", true)
      .str("test", "rate_sub")
      .integer("buffers", buffers)
      .integer("written", written)
      .integer("reads", reads)
      .integer("delivered", fresh)
      .integer("repeats", repeats)
      .integer("older", older)
      .integer("lost", lost)
      .integer("first_seq", first)
      .integer("torn", torn)
      .num("window_s", window)
      .num("delivered_per_s", window > 0 ? fresh / window : 0)
      .num("delivered_fraction", written > 0 ? static_cast<double>(fresh) / written : 0)
      .print();
  if (torn > 0) throw Failure(std::to_string(torn) + " torn packets");
  return 0;
}

int pub(ln::client& clnt, const Args& args) {
  const unsigned buffers = static_cast<unsigned>(args.integer("buffers", 1));
  const std::string topic = args.str("topic", "lnbench.rate");
  const double seconds = args.real("seconds", 3);
  const double paced = args.real("rate", 0);  // packets/s; 0: as fast as possible
  ln::outport* out = clnt.publish(topic, "lnbench/p64", buffers);
  // The subscriber is up before we start; wait until the manager told us.
  const auto t_wait = Clock::now();
  while (out->has_subscriber() == 0) {
    if (seconds_since(t_wait) > 20) throw Failure("no subscriber within 20 s");
    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // polling interval of the condition
  }
  const double wait_s = seconds_since(t_wait);
  Packet64 pkt{};
  uint32_t seq = 0;
  const auto t0 = Clock::now();
  double elapsed = 0;
  for (;;) {
    if (paced > 0) {  // spin until this batch is due
      const double due = seq / paced;
      for (long spin = 0; spin < 100000000L && seconds_since(t0) < due; ++spin) {
      }
    }
    for (int k = 0; k < (paced > 0 ? 64 : 256); ++k, ++seq) {
      pkt.seq = seq;
      std::memset(pkt.pad, static_cast<int>(seq & 0xff), sizeof pkt.pad);
      out->write(&pkt);
    }
    elapsed = seconds_since(t0);
    if (elapsed >= seconds || seq >= 0xfff00000u) break;
  }
  const long long written = seq;
  Packet64 stop{};
  stop.seq = kStop;
  std::memcpy(stop.pad, &written, sizeof written);
  out->write(&stop);
  // Keep the topic until the subscriber has read the stop packet and left.
  const auto t_leave = Clock::now();
  while (out->has_subscriber() != 0 && seconds_since(t_leave) < 10)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // polling interval of the condition
  Json()
      .boolean("ok", true)
      .str("test", "rate_pub")
      .integer("buffers", buffers)
      .integer("written", written)
      .num("seconds", elapsed)
      .num("writes_per_s", written / elapsed)
      .num("paced_rate", paced)
      .num("subscriber_wait_s", wait_s)
      .print();
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return role_main(argc, argv, "lnbench_rate_", {{"sub", sub}, {"pub", pub}}); }
