// Pub/sub round-trip benchmark, the same procedure as the LN 2.9 reference
// measurement: "ping" writes its sequence number on bench.ping and blocks
// reading bench.pong until the echo with that number arrives; "pong" echoes.
// Both topics have one buffer.
//
// usage: ln_bench_pingpong [LN options] pong [MD]
//        ln_bench_pingpong [LN options] ping ROUND_TRIPS [MD]
// MD defaults to test/p64. ping prints one JSON line with the results (µs).
#include <ln/ln.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

constexpr uint32_t kHandshake = 0xfffffff0u;
constexpr uint32_t kStop = 0xffffffffu;
using Clock = std::chrono::steady_clock;

int pong(ln::client& clnt, const std::string& md) {
  ln::inport* in = clnt.subscribe("bench.ping", md);
  ln::outport* out = clnt.publish("bench.pong", md);
  std::vector<unsigned char> packet(in->message_size);
  auto last_activity = Clock::now();
  for (;;) {
    if (in->read(packet.data(), 0.5)) {
      uint32_t seq;
      std::memcpy(&seq, packet.data(), sizeof seq);
      if (seq == kStop) return 0;
      out->write(packet.data());
      last_activity = Clock::now();
    } else if (Clock::now() - last_activity > std::chrono::seconds(20)) {
      std::fprintf(stderr, "pong: nobody pinged for 20 s\n");
      return 1;
    }
  }
}

// Writes `seq` and waits (blocking read, as LN's benchmark) for its echo.
bool round_trip(ln::outport* out, ln::inport* in, std::vector<unsigned char>& packet, uint32_t seq) {
  std::memcpy(packet.data(), &seq, sizeof seq);
  out->write(packet.data());
  for (;;) {
    if (!in->read(packet.data(), true)) return false;
    uint32_t echoed;
    std::memcpy(&echoed, packet.data(), sizeof echoed);
    if (echoed == seq) return true;
  }
}

int ping(ln::client& clnt, const std::string& md, long round_trips) {
  ln::outport* out = clnt.publish("bench.ping", md);
  ln::inport* in = clnt.subscribe("bench.pong", md);
  std::vector<unsigned char> packet(out->message_size);
  // Retrying handshake: a subscriber only sees packets written after it attached.
  bool connected = false;
  for (int attempt = 0; attempt < 1000 && !connected; ++attempt) {
    uint32_t token = kHandshake;
    std::memcpy(packet.data(), &token, sizeof token);
    out->write(packet.data());
    connected = in->read(packet.data(), 0.01) && std::memcmp(packet.data(), &token, sizeof token) == 0;
  }
  if (!connected) {
    std::fprintf(stderr, "ping: no echo within 10 s\n");
    return 1;
  }
  const long warmup = out->message_size > 100000 ? 50 : 500;
  for (long i = 1; i <= warmup; ++i) {
    if (!round_trip(out, in, packet, static_cast<uint32_t>(i))) return 1;
  }
  std::vector<double> rtt;
  rtt.reserve(static_cast<size_t>(round_trips));
  for (long i = 1; i <= round_trips; ++i) {
    const auto start = Clock::now();
    if (!round_trip(out, in, packet, static_cast<uint32_t>(warmup + i))) return 1;
    rtt.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
  }
  uint32_t stop = kStop;
  std::memcpy(packet.data(), &stop, sizeof stop);
  out->write(packet.data());
  std::sort(rtt.begin(), rtt.end());
  double sum = 0;
  for (double value : rtt) sum += value;
  std::printf(
      "{\"test\": \"pingpong\", \"size\": %u, \"n\": %ld, \"median_us\": %.2f, \"p99_us\": %.2f, "
      "\"mean_us\": %.2f, \"max_us\": %.1f}\n",
      out->message_size, round_trips, rtt[rtt.size() / 2], rtt[rtt.size() * 99 / 100], sum / rtt.size(), rtt.back());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ln::client clnt("bench_pingpong", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() >= 2 && args[1] == "pong") return pong(clnt, args.size() >= 3 ? args[2] : "test/p64");
    if (args.size() >= 3 && args[1] == "ping")
      return ping(clnt, args.size() >= 4 ? args[3] : "test/p64", std::strtol(args[2].c_str(), nullptr, 10));
    std::fprintf(stderr, "usage: ln_bench_pingpong [LN options] pong [MD] | ping ROUND_TRIPS [MD]\n");
    return 2;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "ln_bench_pingpong: %s\n", e.what());
    return 2;
  }
}
