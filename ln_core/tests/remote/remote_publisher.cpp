// Publisher of the remote transfer test, written as for LN 2.9 (C++ API,
// header from ln_generate).
//
// usage: remote_publisher [LN options] TOPIC packet|big EPOCH COUNT PERIOD_S
//                         [--wait-subscriber S] [--settle S] [--linger S]
// Packet seq = 1..COUNT carries epoch, seq and remote_pattern() padding.
// Prints "publishing", "subscriber seen" / "no subscriber", "wrote N" every
// 10 packets, "subscriber counted after N" when has_subscriber() first turns
// true while writing (after packet N; packet N+1 is written after that) and
// "published COUNT".
#include <ln/ln.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "ln_messages.h"
#include "remote_common.h"

namespace {

template <typename Packet>
int publish(ln::client& clnt, const std::string& topic, const char* md, uint32_t epoch, unsigned long count,
            double period, double wait_subscriber, double settle, double linger) {
  ln::outport* port = clnt.publish(topic, md, 4);
  std::printf("publishing\n");
  std::fflush(stdout);
  if (wait_subscriber > 0) {
    const double deadline = ln_get_monotonic_time() + wait_subscriber;
    while (!port->has_subscriber() && ln_get_monotonic_time() < deadline) ln_sleep_seconds(0.005);
    std::printf(port->has_subscriber() ? "subscriber seen\n" : "no subscriber\n");
    std::fflush(stdout);
  }
  if (settle > 0) ln_sleep_seconds(settle);
  std::unique_ptr<Packet> packet(new Packet());
  const double start = ln_get_monotonic_time();
  bool counted = port->has_subscriber();
  for (unsigned long seq = 1; seq <= count; ++seq) {
    if (!counted && port->has_subscriber()) {
      counted = true;
      std::printf("subscriber counted after %lu\n", seq - 1);
      std::fflush(stdout);
    }
    packet->epoch = epoch;
    packet->seq = static_cast<uint32_t>(seq);
    for (size_t i = 0; i < sizeof packet->pad; ++i) packet->pad[i] = remote_pattern(epoch, packet->seq, i);
    port->write(packet.get());
    if (seq % 10 == 0) {
      std::printf("wrote %lu\n", seq);
      std::fflush(stdout);
    }
    const double next = start + static_cast<double>(seq) * period;
    const double now = ln_get_monotonic_time();
    if (next > now) ln_sleep_seconds(next - now);
  }
  std::printf("published %lu\n", count);
  std::fflush(stdout);
  if (linger > 0) ln_sleep_seconds(linger);
  clnt.unpublish(port);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ln::client clnt("remote_publisher", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() < 6) {
      std::fprintf(stderr, "usage: remote_publisher [LN options] TOPIC packet|big EPOCH COUNT PERIOD_S [options]\n");
      return 2;
    }
    const uint32_t epoch = static_cast<uint32_t>(std::strtoul(args[3].c_str(), nullptr, 10));
    const unsigned long count = std::strtoul(args[4].c_str(), nullptr, 10);
    const double period = std::strtod(args[5].c_str(), nullptr);
    double wait_subscriber = 0, settle = 0, linger = 0;
    for (size_t i = 6; i + 1 < args.size(); i += 2) {
      const double value = std::strtod(args[i + 1].c_str(), nullptr);
      if (args[i] == "--wait-subscriber")
        wait_subscriber = value;
      else if (args[i] == "--settle")
        settle = value;
      else if (args[i] == "--linger")
        linger = value;
      else {
        std::fprintf(stderr, "remote_publisher: unknown option %s\n", args[i].c_str());
        return 2;
      }
    }
    if (args[2] == "packet")
      return publish<remote_packet_t>(clnt, args[1], REMOTE_PACKET_MD_NAME, epoch, count, period, wait_subscriber,
                                      settle, linger);
    if (args[2] == "big")
      return publish<remote_big_t>(clnt, args[1], REMOTE_BIG_MD_NAME, epoch, count, period, wait_subscriber, settle,
                                   linger);
    std::fprintf(stderr, "remote_publisher: unknown packet kind %s\n", args[2].c_str());
    return 2;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "remote_publisher: %s\n", e.what());
    return 3;
  }
}
