// Pub/sub round trip, LN 2.9 C++ API (compiled against LN 2.9 and ln_core).
//
//   ln_pingpong pong --size S [--topic T] [--mode copy|loan|borrow|zc] [--idle 20 (lending modes)]
//   ln_pingpong ping --size S [--topic T] [--mode ...] --n N --warmup W
//
// Topics T.ping (ping -> pong) and T.pong (pong -> ping), buffers=1, rate -1,
// message lnbench/p64, p4k or p1m. ping stamps sequence number + payload
// pattern, writes, and reads T.pong until the echo of that number arrives
// (timed: write -> matching read), then checks the payload. Modes:
//   copy    LN 2.9 usage: write() copies in, read() copies out (4 copies/RTT)
//   loan    LN 2.9 API too: loaned writes (get_next_buffer) + copying reads:
//           ping produces the stamped packet in the loaned buffer before the
//           timer starts, pong reads straight into its loaned buffer and
//           writes that (2 copies/RTT where write() of a loaned buffer does
//           not copy it again)
//   borrow  ln_core: reads lend the packet in place (ln_read_borrow); pong
//           writes straight from the lent packet (2 copies/RTT)
//   zc      ln_core: loaned writes (get_next_buffer) + lent reads, no payload
//           copy: ping produces the stamped packet in the loaned slot before the
//           timer starts, pong echoes a packet carrying the sequence number and
//           the last payload word it read from ping's packet (proof that it saw
//           the far end of the payload); ping checks both
// Once connected, copying reads block without timeout, like the usual LN
// subscriber (read(buffer)); the harness bounds each run in time, and the stop
// packet ends pong. (ln_core copies a large packet out while it is being
// written only in such reads: a read that times out must leave the buffer
// untouched.)
#include "common.hpp"
#include "ln_messages.h"

using namespace bench;

namespace {

struct Ports {
  ln::outport* out;
  ln::inport* in;
};

std::string g_mode;

bool mode_lends() { return g_mode == "borrow" || g_mode == "zc"; }
bool mode_loans_writes() { return g_mode == "loan" || g_mode == "zc"; }

#ifdef LN_CORE_EXTENSIONS
// Waits (at most `timeout` s) for a packet on `in` and lends it.
ln::borrowed_sample borrow(ln::inport* in, double timeout) { return in->borrow(timeout); }
#endif

void check_mode() {
  if (g_mode == "copy" || g_mode == "loan") return;
#ifdef LN_CORE_EXTENSIONS
  if (g_mode == "borrow" || g_mode == "zc") return;
#endif
  throw ln::exception("mode '" + g_mode + "' needs ln_core's zero-copy read: not yet implemented here", LNE_UNKNOWN);
}

int pong(ln::client& clnt, const Args& args) {
  const long size = args.integer("size", 64);
  const std::string topic = args.str("topic", "lnbench.rtt");
  const double idle_limit = args.real("idle", 20);
  ln::inport* in = clnt.subscribe(topic + ".ping", md_for_size(size), -1, 1);
  ln::outport* out = clnt.publish(topic + ".pong", md_for_size(size), 1);
  std::vector<unsigned char> packet(in->message_size);
  print_ready();
  auto last = Clock::now();
  for (long i = 0; i < 100000000L; ++i) {
    uint32_t seq = 0;
    bool got = false;
    if (!mode_lends()) {
      unsigned int len = 0;
      void* target = g_mode == "loan" ? out->get_next_buffer(&len) : packet.data();
      got = in->read(target);  // blocks until ping's next packet
      if (got) {
        std::memcpy(&seq, target, 4);
        if (seq != kStop) out->write(target);
      }
    }
#ifdef LN_CORE_EXTENSIONS
    else {
      ln::borrowed_sample s = borrow(in, 0.5);
      got = static_cast<bool>(s);
      if (got) {
        std::memcpy(&seq, s.data(), 4);
        if (seq != kStop) {
          if (g_mode == "borrow") {
            out->write(const_cast<void*>(s.data()));
          } else {
            unsigned int len = 0;
            void* buf = out->get_next_buffer(&len);
            copy_ends(buf, s.data(), size);
            out->write(buf);
          }
        }
      }
    }
#endif
    if (got) {
      if (seq == kStop) return 0;
      last = Clock::now();
    } else if (seconds_since(last) > idle_limit) {
      throw Failure("pong: nothing to echo for " + std::to_string(idle_limit) + " s");
    }
  }
  return 0;
}

// Writes packet `seq` (stamped) on ports.out.
void send(Ports& p, std::vector<unsigned char>& local, long size, uint32_t seq) {
  if (mode_loans_writes()) {
    unsigned int len = 0;
    void* buf = p.out->get_next_buffer(&len);
    stamp(buf, size, seq);
    p.out->write(buf);
  } else {
    stamp(local.data(), size, seq);
    p.out->write(local.data());
  }
}

// Waits for the echo of `seq`, checks it; false if none within `timeout`.
// Echoes of other numbers are counted in *stale and skipped.
bool receive(Ports& p, std::vector<unsigned char>& local, long size, uint32_t seq, double timeout, long* stale,
             double* t_arrived, bool check) {
  const auto t0 = Clock::now();
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const double left = timeout - seconds_since(t0);
    if (left <= 0) return false;
    if (!mode_lends()) {
      if (!p.in->read(local.data(), left)) return false;
      *t_arrived = seconds_since(t0);
      uint32_t got;
      std::memcpy(&got, local.data(), 4);
      if (got != seq) {
        ++*stale;
        continue;
      }
      if (check) {
        const std::string bad = check_stamp(local.data(), size, seq);
        if (!bad.empty()) throw Failure("echo check failed: " + bad);
      }
      return true;
    }
#ifdef LN_CORE_EXTENSIONS
    ln::borrowed_sample s = borrow(p.in, left);
    if (!s) return false;
    *t_arrived = seconds_since(t0);
    uint32_t got;
    std::memcpy(&got, s.data(), 4);
    if (got != seq) {
      ++*stale;
      continue;
    }
    if (check) {
      const std::string bad = g_mode == "zc" ? check_ends(s.data(), size, seq) : check_stamp(s.data(), size, seq);
      if (!bad.empty()) throw Failure("echo check failed: " + bad);
    }
    return true;
#endif
  }
  throw Failure("1000 stale echoes in a row");
}

int ping(ln::client& clnt, const Args& args) {
  const long size = args.integer("size", 64);
  const std::string topic = args.str("topic", "lnbench.rtt");
  const long n = args.integer("n", 20000);
  const long warmup = args.integer("warmup", 500);
  const double max_seconds = args.real("max-seconds", 60);
  Ports p{clnt.publish(topic + ".ping", md_for_size(size), 1),
          clnt.subscribe(topic + ".pong", md_for_size(size), -1, 1)};
  std::vector<unsigned char> local(p.out->message_size);
  long stale = 0;
  double dummy;

  // Handshake: the pong only sees packets written after its port attached,
  // so repeat the handshake packet until its echo comes back (deadline 20 s).
  const auto t_hs = Clock::now();
  bool connected = false;
  for (int attempt = 0; attempt < 2000 && seconds_since(t_hs) < 20; ++attempt) {
    send(p, local, size, kHandshake);
    if (receive(p, local, size, kHandshake, 0.05, &stale, &dummy, false)) {
      connected = true;
      break;
    }
  }
  if (!connected) throw Failure("handshake: no echo from pong within 20 s");
  const double handshake_s = seconds_since(t_hs);
  stale = 0;

  std::vector<double> rtt;
  rtt.reserve(n);
  const auto t_start = Clock::now();
  uint32_t seq = 0;
  for (long i = 0; i < warmup + n; ++i, ++seq) {
    if (seconds_since(t_start) > max_seconds)
      throw Failure("round trips took longer than " + std::to_string(max_seconds) + " s");
    // The packet is produced before the timed part: in the local buffer, or
    // (loan, zc) in place in the loaned buffer.
    void* produced = local.data();
    if (mode_loans_writes()) {
      unsigned int len = 0;
      produced = p.out->get_next_buffer(&len);
    }
    stamp(produced, size, seq);
    const auto t0 = Clock::now();
    p.out->write(produced);
    // Timed up to the arrival of the matching echo; its payload is checked after.
    bool ok = false;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      if (!mode_lends()) {
        if (!p.in->read(local.data())) break;
        uint32_t got;
        std::memcpy(&got, local.data(), 4);
        if (got != seq) {
          ++stale;
          continue;
        }
        const auto t1 = Clock::now();
        if (i >= warmup) rtt.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
        const std::string bad = check_stamp(local.data(), size, seq);
        if (!bad.empty()) throw Failure("echo check failed: " + bad);
        ok = true;
        break;
      }
#ifdef LN_CORE_EXTENSIONS
      ln::borrowed_sample s = borrow(p.in, 2.0);
      if (!s) break;
      uint32_t got;
      std::memcpy(&got, s.data(), 4);
      if (got != seq) {
        ++stale;
        continue;
      }
      const auto t1 = Clock::now();
      if (i >= warmup) rtt.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      const std::string bad = g_mode == "zc" ? check_ends(s.data(), size, seq) : check_stamp(s.data(), size, seq);
      if (!bad.empty()) throw Failure("echo check failed: " + bad);
      ok = true;
      break;
#endif
    }
    if (!ok) throw Failure("no echo of packet " + std::to_string(seq) + " within 2 s");
  }
  const double seconds = seconds_since(t_start);
  send(p, local, size, kStop);
  Json j;
  j.boolean("ok", true).str("test", "pingpong").integer("size", size).str("mode", g_mode);
  add_stats(j, stats_of(rtt)).integer("stale_echoes", stale).num("handshake_s", handshake_s).num("seconds", seconds);
  j.print();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return role_main(argc, argv, "lnbench_", {{"ping", ping}, {"pong", pong}}, [](const Args& args) {
    g_mode = args.str("mode", "copy");
    check_mode();
  });
}
