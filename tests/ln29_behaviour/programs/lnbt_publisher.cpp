// Counter publisher of the LN 2.9 behaviour tests, written as for LN 2.9
// (C++ API, header from ln_generate). Compiled unchanged against LN 2.9 and
// against ln_core.
//
// usage: lnbt_publisher [LN options] TOPIC COUNT PERIOD_S [options]
//   --wait-subscriber S   first wait (at most S s) until has_subscriber()
//   --probe S             then write probe packets (counter 0) every 5 ms
//                         until a line arrives on stdin, at most S s: the
//                         test sends it once the subscriber printed "ready"
//                         (it received a probe, so it reads this stream)
//   --buffers N           publish with N buffers (default 1)
//   --linger S            stay published S s after the last write
// Packet i (1..COUNT): counter = i, check = i * 2654435761, value = i * 0.5.
// Prints "publishing", "subscriber seen" or "no subscriber", "published N",
// and "no go" (exit status 4) when --probe got no line in time.
//
// Why probe: has_subscriber() turning true does not mean that the subscriber
// reads the segment yet. LN 2.9's manager tells the publisher about a
// subscriber on a 250 ms timer and, independently, sends a subscriber that
// came before the publisher the segment's name (delayed_init_inport), which
// its library maps in its own thread; a reader starts at the newest packet,
// so what is written before it mapped the segment never reaches it. Only a
// packet that arrived proves the subscriber is there. Likewise ln_core's
// manager records a topic for a logger only once it tapped the publisher's
// segment, after publish (test_ln29b_loggers.py).
#include <ln/ln.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ln_messages.h"

int main(int argc, char** argv) {
  try {
    ln::client clnt("lnbt_publisher", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() < 4) {
      std::fprintf(stderr, "usage: lnbt_publisher [LN options] TOPIC COUNT PERIOD_S [options]\n");
      return 2;
    }
    const std::string topic = args[1];
    const unsigned long count = std::strtoul(args[2].c_str(), nullptr, 10);
    const double period = std::strtod(args[3].c_str(), nullptr);
    double wait_subscriber = 0, probe = 0, linger = 0;
    unsigned buffers = 1;
    for (std::size_t i = 4; i + 1 < args.size(); i += 2) {
      const double value = std::strtod(args[i + 1].c_str(), nullptr);
      if (args[i] == "--wait-subscriber")
        wait_subscriber = value;
      else if (args[i] == "--probe")
        probe = value;
      else if (args[i] == "--buffers")
        buffers = static_cast<unsigned>(value);
      else if (args[i] == "--linger")
        linger = value;
      else {
        std::fprintf(stderr, "lnbt_publisher: unknown option %s\n", args[i].c_str());
        return 2;
      }
    }
    ln::outport* port = clnt.publish(topic, LNBT_COUNTER_MD_NAME, buffers);
    std::printf("publishing\n");
    std::fflush(stdout);
    if (wait_subscriber > 0) {
      const double deadline = ln_get_monotonic_time() + wait_subscriber;
      while (!port->has_subscriber() && ln_get_monotonic_time() < deadline) ln_sleep_seconds(0.005);
      std::printf(port->has_subscriber() ? "subscriber seen\n" : "no subscriber\n");
      std::fflush(stdout);
    }
    lnbt_counter_t packet;
    if (probe > 0) {
      packet.counter = 0;
      packet.check = 0;
      packet.value = 0;
      const double deadline = ln_get_monotonic_time() + probe;
      bool go = false;
      while (!go && ln_get_monotonic_time() < deadline) {
        port->write(&packet);
        pollfd in{0, POLLIN, 0};
        if (::poll(&in, 1, 5) > 0) {
          char buffer[64];
          go = ::read(0, buffer, sizeof buffer) > 0;
          if (!go) break;  // stdin closed: nobody will say go
        }
      }
      if (!go) {
        std::printf("no go\n");
        std::fflush(stdout);
        clnt.unpublish(port);
        return 4;
      }
    }

    const double start = ln_get_monotonic_time();
    for (unsigned long i = 1; i <= count; ++i) {
      packet.counter = static_cast<uint32_t>(i);
      packet.check = static_cast<uint32_t>(i * 2654435761ul);
      packet.value = static_cast<double>(i) * 0.5;
      port->write(&packet);
      // Absolute schedule: the rate does not drift with the write's cost.
      const double next = start + static_cast<double>(i) * period;
      const double now = ln_get_monotonic_time();
      if (next > now) ln_sleep_seconds(next - now);
    }
    std::printf("published %lu\n", count);
    std::fflush(stdout);
    if (linger > 0) ln_sleep_seconds(linger);
    clnt.unpublish(port);
    return 0;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "lnbt_publisher: %s\n", e.what());
    return 3;
  }
}
