// Counter subscriber of the LN 2.9 behaviour tests, written as for LN 2.9
// (C++ API, header from ln_generate). Compiled unchanged against LN 2.9 and
// against ln_core. Prints what it receives, one line per packet.
//
// usage: lnbt_subscriber [LN options] TOPIC [options]
//   --rate R              subscribe with rate R (default -1: as published)
//   --buffers N           subscribe with N buffers (default 1)
//   --count N             stop after N packets (default: no limit)
//   --duration S          stop after S s of reading (default 10)
//   --first-timeout S     give up if no packet came within S s (default 10)
//   --sleep S             sleep S s before every read (a slow reader)
//   --stall-after K       after the K-th packet sleep --stall s once ...
//   --stall S             ... then read without sleeping
//   --watch-publisher S   at the end, wait at most S s for has_publisher()
//                         to become false
// A packet with counter 0 is lnbt_publisher's probe: the first one that comes
// while has_publisher() is true prints "ready" (this subscriber reads the
// stream and knows its publisher); probes are neither counted nor printed.
// Output: "has_publisher_at_start 0|1", then per packet
// "counter C value V check ok|BAD", then "received N", "elapsed T" (the time
// from the first to the last packet), and with --watch-publisher
// "has_publisher_before_watch 0|1" and "publisher_gone" or
// "publisher_still_there".
#include <ln/ln.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ln_messages.h"

int main(int argc, char** argv) {
  try {
    ln::client clnt("lnbt_subscriber", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() < 2) {
      std::fprintf(stderr, "usage: lnbt_subscriber [LN options] TOPIC [options]\n");
      return 2;
    }
    double rate = -1, duration = 10, first_timeout = 10, sleep_per_read = 0, stall = 0, watch = 0;
    unsigned buffers = 1;
    unsigned long count = 0, stall_after = 0;
    for (std::size_t i = 2; i + 1 < args.size(); i += 2) {
      const std::string& option = args[i];
      const double value = std::strtod(args[i + 1].c_str(), nullptr);
      if (option == "--rate")
        rate = value;
      else if (option == "--buffers")
        buffers = static_cast<unsigned>(value);
      else if (option == "--count")
        count = static_cast<unsigned long>(value);
      else if (option == "--duration")
        duration = value;
      else if (option == "--first-timeout")
        first_timeout = value;
      else if (option == "--sleep")
        sleep_per_read = value;
      else if (option == "--stall-after")
        stall_after = static_cast<unsigned long>(value);
      else if (option == "--stall")
        stall = value;
      else if (option == "--watch-publisher")
        watch = value;
      else {
        std::fprintf(stderr, "lnbt_subscriber: unknown option %s\n", option.c_str());
        return 2;
      }
    }
    ln::inport* port = clnt.subscribe(args[1], LNBT_COUNTER_MD_NAME, rate, buffers);
    std::printf("has_publisher_at_start %d\n", port->has_publisher() ? 1 : 0);
    std::printf("subscribed\n");
    std::fflush(stdout);

    lnbt_counter_t packet;
    unsigned long received = 0;
    double first = 0, last = 0;
    double deadline = ln_get_monotonic_time() + first_timeout;
    bool ready = false;
    while (count == 0 || received < count) {
      const double now = ln_get_monotonic_time();
      if (now >= deadline) break;
      if (sleep_per_read > 0) ln_sleep_seconds(sleep_per_read);
      if (!port->read(&packet, 0.05)) continue;
      if (packet.counter == 0) {
        // LN 2.9 tells a subscriber that came first of the publisher 250 ms
        // after it mapped the segment: data can come before has_publisher().
        if (!ready && port->has_publisher()) {
          std::printf("ready\n");
          std::fflush(stdout);
          ready = true;
        }
        continue;
      }
      const double at = ln_get_monotonic_time();
      if (received == 0) {
        first = at;
        deadline = at + duration;
      }
      last = at;
      ++received;
      const bool ok = packet.check == static_cast<uint32_t>(packet.counter * 2654435761ul) &&
                      packet.value == static_cast<double>(packet.counter) * 0.5;
      std::printf("counter %u value %.1f check %s\n", packet.counter, packet.value, ok ? "ok" : "BAD");
      std::fflush(stdout);
      if (stall > 0 && received == stall_after) ln_sleep_seconds(stall);
    }
    std::printf("received %lu\n", received);
    std::printf("elapsed %.3f\n", last - first);
    if (watch > 0) {
      std::printf("has_publisher_before_watch %d\n", port->has_publisher() ? 1 : 0);
      std::fflush(stdout);
      const double watch_deadline = ln_get_monotonic_time() + watch;
      while (port->has_publisher() && ln_get_monotonic_time() < watch_deadline) ln_sleep_seconds(0.01);
      std::printf(port->has_publisher() ? "publisher_still_there\n" : "publisher_gone\n");
    }
    std::fflush(stdout);
    clnt.unsubscribe(port);
    return 0;
  } catch (const ln::exception& e) {
    std::printf("error %d\n", static_cast<int>(e.error));
    std::fprintf(stderr, "lnbt_subscriber: %s\n", e.what());
    return 3;
  }
}
