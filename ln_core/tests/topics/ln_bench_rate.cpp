// One-way rate benchmark, the same procedure as the LN 2.9 reference
// measurement: the publisher waits for a subscriber, then writes 64-byte
// packets (test/p64, payload filled with seq & 0xff) as fast as it can; the
// subscriber reads blocking and counts packets, distinct sequence numbers,
// repeats, packets older than the previous one and torn payloads.
//
// usage: ln_bench_rate [LN options] pub SECONDS BUFFERS
//        ln_bench_rate [LN options] sub BUFFERS
// Each prints one JSON line.
#include <ln/ln.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "ln_messages.h"

namespace {

constexpr uint32_t kStop = 0xffffffffu;
using Clock = std::chrono::steady_clock;

int publish(ln::client& clnt, double seconds, unsigned buffers) {
  ln::outport* out = clnt.publish("bench.rate", TEST_P64_MD_NAME, buffers);
  const auto wait_until = Clock::now() + std::chrono::seconds(10);
  while (!out->has_subscriber() && Clock::now() < wait_until) ln_sleep_seconds(0.001);
  if (!out->has_subscriber()) {
    std::fprintf(stderr, "pub: no subscriber within 10 s\n");
    return 1;
  }
  test_p64_t packet;
  std::memset(&packet, 0, sizeof packet);
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  uint32_t seq = 0;
  for (;;) {
    ++seq;
    packet.seq = seq;
    std::memset(packet.pad, static_cast<int>(seq & 0xff), sizeof packet.pad);
    out->write(&packet);
    if ((seq & 1023) == 0 && Clock::now() >= end) break;
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  packet.seq = kStop;
  for (int i = 0; i < 100; ++i) {
    out->write(&packet);
    ln_sleep_seconds(0.001);
  }
  std::printf("{\"role\": \"pub\", \"buffers\": %u, \"writes\": %u, \"writes_per_s\": %.0f}\n", buffers, seq,
              seq / elapsed);
  return 0;
}

int subscribe(ln::client& clnt, unsigned buffers) {
  ln::inport* in = clnt.subscribe("bench.rate", TEST_P64_MD_NAME, RATE_AS_PUBLISHED, buffers);
  test_p64_t packet;
  unsigned long received = 0, distinct = 0, repeats = 0, older = 0, torn = 0;
  uint32_t first = 0, last = 0;
  Clock::time_point first_time{}, last_time{};
  const auto give_up = Clock::now() + std::chrono::seconds(30);
  while (Clock::now() < give_up) {
    if (!in->read(&packet, received > 0 ? 1.0 : 0.1)) {
      if (received > 0) break;  // the publisher finished
      continue;
    }
    if (packet.seq == kStop) break;
    const auto now = Clock::now();
    if (received == 0) {
      first = packet.seq;
      first_time = now;
    }
    ++received;
    last_time = now;
    if (packet.seq > last || received == 1) {
      ++distinct;
      last = packet.seq;
    } else if (packet.seq == last) {
      ++repeats;
    } else {
      ++older;
    }
    for (unsigned char byte : packet.pad) {
      if (byte != (packet.seq & 0xff)) {
        ++torn;
        break;
      }
    }
  }
  const double elapsed = std::chrono::duration<double>(last_time - first_time).count();
  const double span = last >= first ? static_cast<double>(last - first + 1) : 1.0;
  std::printf(
      "{\"role\": \"sub\", \"buffers\": %u, \"received\": %lu, \"received_per_s\": %.0f, "
      "\"distinct_fraction\": %.3f, \"repeats\": %lu, \"older\": %lu, \"torn\": %lu}\n",
      buffers, received, elapsed > 0 ? received / elapsed : 0.0, distinct / span, repeats, older, torn);
  return torn == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ln::client clnt("bench_rate", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() >= 4 && args[1] == "pub")
      return publish(clnt, std::strtod(args[2].c_str(), nullptr), static_cast<unsigned>(std::atoi(args[3].c_str())));
    if (args.size() >= 3 && args[1] == "sub") return subscribe(clnt, static_cast<unsigned>(std::atoi(args[2].c_str())));
    std::fprintf(stderr, "usage: ln_bench_rate [LN options] pub SECONDS BUFFERS | sub BUFFERS\n");
    return 2;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "ln_bench_rate: %s\n", e.what());
    return 2;
  }
}
