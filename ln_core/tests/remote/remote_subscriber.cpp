// Subscriber of the remote transfer test, written as for LN 2.9 (C++ API,
// header from ln_generate). Checks order and payload of what arrives.
//
// usage: remote_subscriber [LN options] TOPIC packet|big LAST_EPOCH COUNT TIMEOUT_S [reliable]
// Reads until it has packet COUNT of epoch LAST_EPOCH, or LAST_EPOCH has
// been silent for 2 s, or TIMEOUT_S passed. Prints "subscribed", then
// "epoch E first S" when an epoch's data starts, and at the end one line per
// epoch: "epoch E first F last L received R missing M disorder D bad B"
// (missing: holes between F and L; disorder: a packet not newer than the one
// before; bad: wrong payload), then "done" or "timeout".
// ln_core's sample info: "first_info E seq S sequence Q lost L" for an
// epoch's first packet (its seq field, and the publisher sequence and lost
// count the port reported), and at the end per epoch "info E mismatch M lost
// L received R last_sequence Q" (mismatch: packets whose reported sequence
// is not their seq field; lost: summed over the epoch's packets).
#include <ln/ln.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ln_messages.h"
#include "remote_common.h"

namespace {

struct EpochStats {
  uint32_t first = 0, last = 0;
  unsigned long received = 0, missing = 0, disorder = 0, bad = 0;
  unsigned long long mismatch = 0, lost = 0, last_sequence = 0;
};

template <typename Packet>
int receive(ln::client& clnt, const std::string& topic, const char* md, uint32_t last_epoch, unsigned long count,
            double timeout, bool reliable) {
  ln::inport* port = clnt.subscribe(topic, md, RATE_AS_PUBLISHED, 64, reliable);
  std::printf("subscribed\n");
  std::fflush(stdout);
  std::unique_ptr<Packet> packet(new Packet());
  std::map<uint32_t, EpochStats> epochs;
  uint32_t current_epoch = 0;
  const double deadline = ln_get_monotonic_time() + timeout;
  double last_epoch_seen_at = 0;
  bool done = false;
  while (!done && ln_get_monotonic_time() < deadline) {
    if (last_epoch_seen_at > 0 && ln_get_monotonic_time() - last_epoch_seen_at > 2.0) break;
    ln::sample_info info{};
    if (!port->read(packet.get(), 0.1, &info)) continue;
    bool ok = true;
    for (size_t i = 0; i < sizeof packet->pad && ok; ++i)
      ok = packet->pad[i] == remote_pattern(packet->epoch, packet->seq, i);
    EpochStats& stats = epochs[packet->epoch];
    if (packet->epoch < current_epoch) {
      ++stats.disorder;
    } else if (stats.received == 0) {
      stats.first = stats.last = packet->seq;
      current_epoch = packet->epoch;
      std::printf("epoch %u first %u\n", packet->epoch, packet->seq);
      std::printf("first_info %u seq %u sequence %llu lost %llu\n", packet->epoch, packet->seq,
                  static_cast<unsigned long long>(info.sequence), static_cast<unsigned long long>(info.lost));
      std::fflush(stdout);
    } else if (packet->seq <= stats.last) {
      ++stats.disorder;
    } else {
      stats.missing += packet->seq - stats.last - 1;
      stats.last = packet->seq;
    }
    ++stats.received;
    if (!ok) ++stats.bad;
    if (info.sequence != packet->seq) ++stats.mismatch;
    stats.lost += info.lost;
    stats.last_sequence = info.sequence;
    if (packet->epoch == last_epoch) {
      last_epoch_seen_at = ln_get_monotonic_time();
      if (packet->seq == count) done = true;
    }
  }
  for (const auto& [epoch, stats] : epochs)
    std::printf("epoch %u first %u last %u received %lu missing %lu disorder %lu bad %lu\n", epoch, stats.first,
                stats.last, stats.received, stats.missing, stats.disorder, stats.bad);
  for (const auto& [epoch, stats] : epochs)
    std::printf("info %u mismatch %llu lost %llu received %lu last_sequence %llu\n", epoch, stats.mismatch, stats.lost,
                stats.received, stats.last_sequence);
  std::printf(done ? "done\n" : "timeout\n");
  std::fflush(stdout);
  clnt.unsubscribe(port);
  return done ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ln::client clnt("remote_subscriber", argc, argv);
    const std::vector<std::string> args = clnt.get_remaining_args();
    if (args.size() < 6) {
      std::fprintf(stderr,
                   "usage: remote_subscriber [LN options] TOPIC packet|big LAST_EPOCH COUNT TIMEOUT_S [reliable]\n");
      return 2;
    }
    const uint32_t last_epoch = static_cast<uint32_t>(std::strtoul(args[3].c_str(), nullptr, 10));
    const unsigned long count = std::strtoul(args[4].c_str(), nullptr, 10);
    const double timeout = std::strtod(args[5].c_str(), nullptr);
    const bool reliable = args.size() > 6 && args[6] == "reliable";
    if (args[2] == "packet")
      return receive<remote_packet_t>(clnt, args[1], REMOTE_PACKET_MD_NAME, last_epoch, count, timeout, reliable);
    if (args[2] == "big")
      return receive<remote_big_t>(clnt, args[1], REMOTE_BIG_MD_NAME, last_epoch, count, timeout, reliable);
    std::fprintf(stderr, "remote_subscriber: unknown packet kind %s\n", args[2].c_str());
    return 2;
  } catch (const ln::exception& e) {
    std::fprintf(stderr, "remote_subscriber: %s\n", e.what());
    return 3;
  }
}
