// Topic logger probe of the LN 2.9 behaviour tests, written as for LN 2.9
// (C API, header from ln_generate). Compiled unchanged against LN 2.9 and
// against ln_core; test_ln29b_loggers.py compares what both print.
//
// usage: lnbt_logger SCENARIO TOPIC [ARGS] [LN options]
//   record TOPIC FILE   log_size 5 of 8 packets, downloads twice, saves to FILE;
//                       then divisor 3 (10 packets), enable again (7), divisor 0 (3)
//   later TOPIC         enable before the topic is published, then publish and
//                       write 150 packets every 10 ms
//   until_eof TOPIC     enable, print "enabled", wait until stdin closes
//                       (another program publishes meanwhile), then download;
//                       meanwhile download every 20 ms and print "recording"
//                       once a sample came (ln_core: the manager taps the
//                       publisher's segment only after it published, so the
//                       test lets the publisher probe until then; LN 2.9's
//                       download while enabled has no samples: never printed)
//   save TOPIC DIR      two topics (TOPIC.a lnbt/counter, TOPIC.b lnbt/other)
//                       with explicit timestamps; manager_save as raw (TOPIC.a
//                       alone), pcap, auto, pickle and an unknown format
//   differ TOPIC        what LN 2.9 does differently: download while enabled,
//                       only_ts, two loggers of one topic
//   errors TOPIC DIR    bad input
//   load FILE           prints logger data from a file
// Every call prints "<what> <LNE name or OK>"; downloads print
// "topic NAME log_size N divisor N n_samples N sample_size N md_name M",
// "md TEXT" and "sample counter C packet_counter P", plus "timestamps ok"
// when every log_ts >= src_ts and src_ts lies within the run.
#include <ln/ln.h>
#include <poll.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "ln_messages.h"
#include "lnbt_errors.h"

namespace {

using lnbt::error_name;

int report(const char* what, int ret) {
  std::printf("%s %s\n", what, error_name(ret).c_str());
  std::fflush(stdout);
  return ret;
}

void write_counter(ln_outport port, uint32_t i, const double* ts = nullptr) {
  lnbt_counter_t packet;
  packet.counter = i;
  packet.check = i * 7u;
  packet.value = i * 0.5;
  ln_write(port, &packet, sizeof packet, const_cast<double*>(ts));
}

// LN 2.9's daemon reads the newest packet when it wakes up: of packets
// written back to back it records only some. Paced, it records each.
constexpr double kPace = 0.005;

void write_paced(ln_outport port, uint32_t first, uint32_t last) {
  for (uint32_t i = first; i <= last; ++i) {
    write_counter(port, i);
    ln_sleep_seconds(kPace);
  }
}

/// Prints a download (or loaded data); returns the counters of topic 0.
std::vector<uint32_t> print_data(ln_logger_data data, double first_ts = 0, double last_ts = 0) {
  std::vector<uint32_t> counters;
  unsigned int n_topics = 0;
  report("get_info", ln_logger_data_get_info(data, &n_topics));
  std::printf("topics %u\n", n_topics);
  bool timestamps_ok = true;
  for (unsigned int t = 0; t < n_topics; ++t) {
    logger_topic* topic = nullptr;
    if (ln_logger_data_get_topic(data, t, &topic) != 0) continue;
    std::printf("topic %s log_size %llu divisor %u n_samples %u sample_size %u md_name %s\n", topic->name,
                static_cast<unsigned long long>(topic->log_size), topic->divisor, topic->n_samples, topic->sample_size,
                topic->md_name);
    std::printf("md %s\n", topic->md);
    for (uint32_t i = 0; i < topic->n_samples; ++i) {
      const auto* sample = reinterpret_cast<const logger_sample*>(reinterpret_cast<const uint8_t*>(topic->samples) +
                                                                  i * topic->sample_size);
      uint32_t counter = 0;
      if (topic->sample_size >= 24) std::memcpy(&counter, &sample->data, 4);
      std::printf("sample counter %u packet_counter %u\n", counter, sample->packet_counter);
      if (t == 0) counters.push_back(counter);
      if (sample->log_ts < sample->src_ts || (first_ts > 0 && (sample->src_ts < first_ts || sample->src_ts > last_ts)))
        timestamps_ok = false;
    }
  }
  if (first_ts > 0) std::printf("timestamps %s\n", timestamps_ok ? "ok" : "wrong");
  std::fflush(stdout);
  return counters;
}

std::vector<uint32_t> download(ln_logger logger, double first_ts = 0, double last_ts = 0) {
  ln_logger_data data = nullptr;
  if (report("download", ln_logger_download(logger, &data)) != 0) return {};
  return print_data(data, first_ts, last_ts);
}

ln_logger logger_of(ln_client clnt, const char* name) {
  ln_logger logger = nullptr;
  report("get_logger", ln_client_get_logger(clnt, &logger, name));
  return logger;
}

void wait_for_eof(ln_logger logger) {
  std::printf("enabled\n");
  std::fflush(stdout);
  bool recording = false;
  const double deadline = ln_get_monotonic_time() + 60;
  char buffer[64];
  while (ln_get_monotonic_time() < deadline) {
    pollfd in{0, POLLIN, 0};
    const int ready = ::poll(&in, 1, 20);
    if (ready < 0 || (ready > 0 && ::read(0, buffer, sizeof buffer) <= 0)) return;
    if (recording) continue;
    ln_logger_data data = nullptr;
    logger_topic* topic = nullptr;
    if (ln_logger_download(logger, &data) == 0 && ln_logger_data_get_topic(data, 0, &topic) == 0 &&
        topic->n_samples > 0) {
      std::printf("recording\n");
      std::fflush(stdout);
      recording = true;
    }
  }
}

void record(ln_client clnt, const std::string& topic, const std::string& file) {
  ln_outport port = nullptr;
  report("publish", ln_publish(clnt, topic.c_str(), LNBT_COUNTER_MD_NAME, &port));
  ln_logger logger = logger_of(clnt, "record");
  ln_logger again = logger_of(clnt, "record");
  std::printf("same handle %s\n", logger == again ? "yes" : "no");
  report("add_topic", ln_logger_add_topic(logger, topic.c_str(), 5, 1));
  report("enable", ln_logger_enable(logger));
  const double first = ln_get_time();
  write_paced(port, 1, 8);
  const double last = ln_get_time();
  std::printf("has_subscriber %d\n", ln_has_subscriber(port));
  report("disable", ln_logger_disable(logger));
  const std::vector<uint32_t> first_download = download(logger, first, last);
  std::printf("download again %s\n", download(logger) == first_download ? "same" : "different");
  ln_logger_data data = nullptr;
  ln_logger_download(logger, &data);
  report("save", ln_logger_data_save(data, file.c_str()));

  report("add_topic divisor 3", ln_logger_add_topic(logger, topic.c_str(), 100, 3));
  report("enable", ln_logger_enable(logger));
  write_paced(port, 101, 110);
  report("disable", ln_logger_disable(logger));
  download(logger);
  report("enable again", ln_logger_enable(logger));
  write_paced(port, 201, 207);
  report("disable", ln_logger_disable(logger));
  download(logger);
  report("add_topic divisor 0", ln_logger_add_topic(logger, topic.c_str(), 100, 0));
  report("enable", ln_logger_enable(logger));
  write_paced(port, 301, 303);
  report("disable", ln_logger_disable(logger));
  download(logger);
}

void later(ln_client clnt, const std::string& topic) {
  ln_logger logger = logger_of(clnt, "later");
  report("add_topic", ln_logger_add_topic(logger, topic.c_str(), 1000, 1));
  report("enable", ln_logger_enable(logger));
  ln_outport port = nullptr;
  report("publish", ln_publish(clnt, topic.c_str(), LNBT_COUNTER_MD_NAME, &port));
  for (uint32_t i = 1; i <= 150; ++i) {
    write_counter(port, i);
    ln_sleep_seconds(0.01);
  }
  report("disable", ln_logger_disable(logger));
  ln_logger_data data = nullptr;
  report("download", ln_logger_download(logger, &data));
  logger_topic* t = nullptr;
  ln_logger_data_get_topic(data, 0, &t);
  bool consecutive = t->n_samples > 0;
  uint32_t previous = 0, last = 0;
  for (uint32_t i = 0; i < t->n_samples; ++i) {
    const auto* sample = reinterpret_cast<const uint8_t*>(t->samples) + i * t->sample_size;
    std::memcpy(&last, sample + 20, 4);
    if (i > 0 && last != previous + 1) consecutive = false;
    previous = last;
  }
  std::printf("recorded consecutive %s last %u\n", consecutive ? "yes" : "no", last);
}

void until_eof(ln_client clnt, const std::string& topic) {
  ln_logger logger = logger_of(clnt, "until_eof");
  report("add_topic", ln_logger_add_topic(logger, topic.c_str(), 100, 1));
  report("enable", ln_logger_enable(logger));
  wait_for_eof(logger);
  report("disable", ln_logger_disable(logger));
  download(logger);
}

void save(ln_client clnt, const std::string& topic, const std::string& dir) {
  const std::string a = topic + ".a", b = topic + ".b";
  ln_outport port_a = nullptr, port_b = nullptr;
  report("publish a", ln_publish(clnt, a.c_str(), LNBT_COUNTER_MD_NAME, &port_a));
  report("publish b", ln_publish(clnt, b.c_str(), LNBT_OTHER_MD_NAME, &port_b));
  ln_logger both = logger_of(clnt, "save_both");
  ln_logger one = logger_of(clnt, "save_one");
  report("add_topic", ln_logger_add_topic(both, a.c_str(), 10, 1));
  report("add_topic", ln_logger_add_topic(both, b.c_str(), 10, 1));
  report("add_topic", ln_logger_add_topic(one, a.c_str(), 10, 1));
  report("enable", ln_logger_enable(both));
  report("enable", ln_logger_enable(one));
  for (uint32_t i = 1; i <= 4; ++i) {
    const double ts = 1000.0 + 0.25 * i;
    write_counter(port_a, i, &ts);
    ln_sleep_seconds(kPace);  // paced for LN 2.9's daemon (see write_paced)
    lnbt_other_t other;
    other.x = 1000 + i;
    other.y = -0.5 * i;
    const double ts_b = ts + 0.125;
    ln_write(port_b, &other, sizeof other, const_cast<double*>(&ts_b));
    ln_sleep_seconds(kPace);
  }
  report("disable", ln_logger_disable(both));
  report("disable", ln_logger_disable(one));
  report("manager_save raw", ln_logger_manager_save(one, (dir + "/one.raw").c_str(), "raw"));
  report("manager_save raw of two topics", ln_logger_manager_save(both, (dir + "/two.raw").c_str(), "raw"));
  report("manager_save pcap", ln_logger_manager_save(both, (dir + "/both.pcap").c_str(), "pcap"));
  report("manager_save auto", ln_logger_manager_save(both, (dir + "/auto.pcap").c_str(), "auto"));
  report("manager_save pickle", ln_logger_manager_save(both, (dir + "/both.pickle").c_str(), "pickle"));
  report("manager_save unknown", ln_logger_manager_save(both, (dir + "/both.x").c_str(), "no_such_format"));
}

void differ(ln_client clnt, const std::string& topic) {
  ln_outport port = nullptr;
  report("publish", ln_publish(clnt, topic.c_str(), LNBT_COUNTER_MD_NAME, &port));
  // A download while recording.
  ln_logger live = logger_of(clnt, "live");
  report("add_topic", ln_logger_add_topic(live, topic.c_str(), 10, 1));
  report("enable", ln_logger_enable(live));
  write_paced(port, 1, 3);
  std::printf("-- while enabled\n");
  download(live);
  report("disable", ln_logger_disable(live));
  // Timestamps only.
  ln_logger ts = logger_of(clnt, "only_ts");
  report("add_topic", ln_logger_add_topic(ts, topic.c_str(), 10, 1));
  report("set_only_ts", ln_logger_set_only_ts(ts, 1));
  report("enable", ln_logger_enable(ts));
  write_paced(port, 11, 13);
  report("disable", ln_logger_disable(ts));
  std::printf("-- only_ts\n");
  download(ts);
  // Two loggers of one topic, enabled at different times.
  ln_logger first = logger_of(clnt, "first");
  ln_logger second = logger_of(clnt, "second");
  report("add_topic", ln_logger_add_topic(first, topic.c_str(), 10, 1));
  report("add_topic", ln_logger_add_topic(second, topic.c_str(), 3, 1));
  report("enable first", ln_logger_enable(first));
  write_paced(port, 21, 23);
  report("enable second", ln_logger_enable(second));
  write_paced(port, 24, 28);
  report("disable first", ln_logger_disable(first));
  write_paced(port, 29, 30);
  report("disable second", ln_logger_disable(second));
  std::printf("-- first\n");
  download(first);
  std::printf("-- second\n");
  download(second);
}

void errors(ln_client clnt, const std::string& topic, const std::string& dir) {
  ln_outport port = nullptr;
  report("publish", ln_publish(clnt, topic.c_str(), LNBT_COUNTER_MD_NAME, &port));
  ln_logger logger = logger_of(clnt, "errors");
  report("enable without topics", ln_logger_enable(logger));
  report("add_topic log_size 0", ln_logger_add_topic(logger, topic.c_str(), 0, 1));
  report("enable", ln_logger_enable(logger));
  report("clear_topics", ln_logger_clear_topics(logger));
  report("add_topic empty name", ln_logger_add_topic(logger, "", 5, 1));
  report("clear_topics", ln_logger_clear_topics(logger));
  report("add_topic huge", ln_logger_add_topic64(logger, topic.c_str(), uint64_t{1} << 40, 1));
  report("enable huge", ln_logger_enable(logger));
  report("disable", ln_logger_disable(logger));
  ln_logger never = logger_of(clnt, "never_enabled");
  ln_logger_data data = nullptr;
  report("download never enabled", ln_logger_download(never, &data));
  report("clear_topics", ln_logger_clear_topics(logger));
  report("add_topic", ln_logger_add_topic(logger, topic.c_str(), 5, 1));
  report("enable", ln_logger_enable(logger));
  write_counter(port, 1);
  report("disable", ln_logger_disable(logger));
  report("download", ln_logger_download(logger, &data));
  logger_topic* t = nullptr;
  report("get_topic 1", ln_logger_data_get_topic(data, 1, &t));
  report("save into a missing directory", ln_logger_data_save(data, (dir + "/no/such/dir/x").c_str()));
  report("load a missing file", ln_logger_data_load(&data, (dir + "/missing").c_str()));
  const std::string garbage = dir + "/garbage";
  if (FILE* f = std::fopen(garbage.c_str(), "wb")) {
    std::fputs("this is not logger data at all", f);
    std::fclose(f);
  }
  report("load garbage", ln_logger_data_load(&data, garbage.c_str()));
}

}  // namespace

int main(int argc, char** argv) {
  ln_client clnt = nullptr;
  if (report("init", ln_init(&clnt, "lnbt_logger", argc, argv)) != 0) return 3;
  unsigned int n_args = 0;
  char* block = nullptr;
  ln_get_remaining_args(clnt, &n_args, &block);
  std::vector<std::string> args;
  for (unsigned int i = 0; i < n_args; ++i) {
    args.emplace_back(block);
    block += args.back().size() + 1;
  }
  auto arg = [&](std::size_t i) { return i < args.size() ? args[i] : std::string(); };
  const std::string scenario = arg(1);
  if (scenario == "record")
    record(clnt, arg(2), arg(3));
  else if (scenario == "later")
    later(clnt, arg(2));
  else if (scenario == "until_eof")
    until_eof(clnt, arg(2));
  else if (scenario == "save")
    save(clnt, arg(2), arg(3));
  else if (scenario == "differ")
    differ(clnt, arg(2));
  else if (scenario == "errors")
    errors(clnt, arg(2), arg(3));
  else if (scenario == "load") {
    ln_logger_data data = nullptr;
    if (report("load", ln_logger_data_load(&data, arg(2).c_str())) == 0) {
      print_data(data);
      report("deinit", ln_logger_data_deinit(&data));
    }
  } else {
    std::fprintf(stderr, "lnbt_logger: unknown scenario '%s'\n", scenario.c_str());
    ln_deinit(&clnt);
    return 2;
  }
  std::fflush(stdout);
  ln_deinit(&clnt);
  return 0;
}
