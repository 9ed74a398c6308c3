// Counter publisher of the LN 2.9 behaviour tests, written as for LN 2.9
// (C++ API, header from ln_generate). Compiled unchanged against LN 2.9 and
// against ln_core.
//
// usage: lnbt_publisher [LN options] TOPIC COUNT PERIOD_S [options]
//   --wait-subscriber S   first wait (at most S s) until has_subscriber()
//   --settle S            then sleep S s before the first write
//   --buffers N           publish with N buffers (default 1)
//   --linger S            stay published S s after the last write
// Packet i (1..COUNT): counter = i, check = i * 2654435761, value = i * 0.5.
// Prints "publishing", "subscriber seen" or "no subscriber", "published N".
#include <ln/ln.h>

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
    double wait_subscriber = 0, settle = 0, linger = 0;
    unsigned buffers = 1;
    for (std::size_t i = 4; i + 1 < args.size(); i += 2) {
      const double value = std::strtod(args[i + 1].c_str(), nullptr);
      if (args[i] == "--wait-subscriber")
        wait_subscriber = value;
      else if (args[i] == "--settle")
        settle = value;
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
    if (settle > 0) ln_sleep_seconds(settle);

    lnbt_counter_t packet;
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
