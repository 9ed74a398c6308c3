// A subscriber written as for LN 2.9, with the C++ API: reads test/p64
// packets until it has seen sequence number COUNT, and checks that once data
// flows no packet is missing (256 buffers) or torn.
//
// usage: ln_test_subscriber [LN options] TOPIC COUNT TIMEOUT_S [reliable]
// Prints "subscribed" when ready, "received N last L gaps G torn T first F" at
// the end (F: the first sequence number received, 0 for none);
// exit status 0 when the last packet arrived without gaps or torn packets.
#include <ln/ln.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "ln_messages.h"

int main(int argc, char** argv) {
  try {
    ln::client clnt("cpp_subscriber", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() < 4) {
      std::fprintf(stderr, "usage: ln_test_subscriber [LN options] TOPIC COUNT TIMEOUT_S [reliable]\n");
      return 2;
    }
    const unsigned long count = std::strtoul(args[2].c_str(), nullptr, 10);
    const double timeout = std::strtod(args[3].c_str(), nullptr);
    const bool reliable = args.size() >= 5 && args[4] == "reliable";
    ln::inport* port = clnt.subscribe(args[1], TEST_P64_MD_NAME, RATE_AS_PUBLISHED, 256, reliable);
    std::printf("subscribed\n");
    std::fflush(stdout);

    test_p64_t packet;
    unsigned long received = 0, gaps = 0, torn = 0, last = 0, first = 0;
    const double deadline = ln_get_monotonic_time() + timeout;
    while (last < count && ln_get_monotonic_time() < deadline) {
      if (!port->read(&packet, 0.1)) continue;
      if (received > 0 && packet.seq != last + 1) ++gaps;
      for (unsigned char byte : packet.pad) {
        if (byte != (packet.seq & 0xff)) {
          ++torn;
          break;
        }
      }
      if (received == 0) first = packet.seq;
      ++received;
      last = packet.seq;
    }
    std::printf("received %lu last %lu gaps %lu torn %lu first %lu\n", received, last, gaps, torn, first);
    return last == count && gaps == 0 && torn == 0 ? 0 : 1;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "ln_test_subscriber: %s\n", e.what());
    return 2;
  }
}
