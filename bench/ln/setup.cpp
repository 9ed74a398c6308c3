// Set-up costs, LN 2.9 C++ API: REPS times (after one untimed warm-up, which
// also lets LN 2.9's manager start its daemon): construct an ln::client
// (connect + register), publish a new topic, subscribe to it, unsubscribe,
// unpublish, delete the client. Each step is checked to have worked.
//
//   ln_setup run --reps N [--topic T]
#include "common.hpp"
#include "ln_messages.h"

#include <unistd.h>

using namespace bench;

int main(int argc, char** argv) {
  return guarded_main([&] {
    Args args(argc, argv);
    const long reps = args.integer("reps", 30);
    const std::string topic = args.str("topic", "lnbench.setup") + "." + std::to_string(::getpid());
    const double max_seconds = args.real("max-seconds", 60);
    std::vector<double> reg, pub, sub, unsub, unpub, shutdown;
    const auto t_start = Clock::now();
    for (long i = -1; i < reps; ++i) {
      if (seconds_since(t_start) > max_seconds) throw Failure("set-up repetitions took longer than max-seconds");
      const std::string name = topic + "." + std::to_string(i + 1);
      auto ms = [](Clock::time_point a, Clock::time_point b) {
        return std::chrono::duration<double, std::milli>(b - a).count();
      };
      const auto t0 = Clock::now();
      auto* clnt = new ln::client("lnbench_setup");
      const auto t1 = Clock::now();
      ln::outport* out = clnt->publish(name, "lnbench/p64", 1);
      const auto t2 = Clock::now();
      ln::inport* in = clnt->subscribe(name, "lnbench/p64", -1, 1);
      const auto t3 = Clock::now();
      if (out->message_size != 64 || in->message_size != 64) throw Failure("ports report a message size other than 64");
      clnt->unsubscribe(in);
      const auto t4 = Clock::now();
      clnt->unpublish(out);
      const auto t5 = Clock::now();
      delete clnt;
      const auto t6 = Clock::now();
      if (i < 0) continue;  // warm-up
      reg.push_back(ms(t0, t1));
      pub.push_back(ms(t1, t2));
      sub.push_back(ms(t2, t3));
      unsub.push_back(ms(t3, t4));
      unpub.push_back(ms(t4, t5));
      shutdown.push_back(ms(t5, t6));
    }
    Json j;
    j.boolean("ok", true).str("test", "setup").integer("reps", reps);
    const std::pair<const char*, std::vector<double>*> steps[] = {{"register", &reg},    {"publish", &pub},
                                                                  {"subscribe", &sub},   {"unsubscribe", &unsub},
                                                                  {"unpublish", &unpub}, {"shutdown", &shutdown}};
    for (const auto& step : steps) {
      const Stats s = stats_of(*step.second);
      j.num(std::string(step.first) + "_median_ms", s.median).num(std::string(step.first) + "_p90_ms", s.p90);
    }
    j.print();
    return 0;
  });
}
