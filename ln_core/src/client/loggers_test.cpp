// Topic loggers through the public API (C and C++) against an in-process
// manager, which records (manager/recorder.hpp). The behaviour asserted is
// LN 2.9's where LN 2.9 has one (observed by running it, see
// tests/ln29_behaviour/test_ln29b_loggers.py), ln_core's documented choice
// where LN 2.9 loses data.
#include <gtest/gtest.h>
#include <ln/ln.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "client/client_test_support.hpp"

namespace {

using namespace ln::clienttest;

struct P64 {
  uint32_t seq;
  uint8_t pad[60];
};

constexpr unsigned kSampleSize = 20 + sizeof(P64);

struct Sample {
  double log_ts;
  double src_ts;
  uint32_t packet_counter;
  uint32_t seq;  // the packet's own number
};

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class LoggerTest : public OwnManagerTest {
 protected:
  void SetUp() override { client_ = connect("logging"); }
  void TearDown() override { deinit_clients({&client_, &other_}); }
  ln_outport publish(const char* topic, ln_client client = nullptr) {
    ln_outport port = nullptr;
    client = client != nullptr ? client : client_;
    EXPECT_EQ(ln_publish(client, topic, "test/p64", &port), 0) << ln_get_error_message(client);
    return port;
  }
  ln_logger logger(const char* name, ln_client client = nullptr) {
    ln_logger handle = nullptr;
    EXPECT_EQ(ln_client_get_logger(client != nullptr ? client : client_, &handle, name), 0);
    return handle;
  }
  /// An enabled logger of `topic`.
  ln_logger enabled(const char* name, const char* topic, unsigned log_size, unsigned divisor = 1) {
    ln_logger lg = logger(name);
    EXPECT_EQ(ln_logger_add_topic(lg, topic, log_size, divisor), 0);
    EXPECT_EQ(ln_logger_enable(lg), 0) << ln_get_error_message(client_);
    return lg;
  }
  /// A logger of `topic` that recorded packets 1..count (enabled, written, disabled).
  ln_logger recorded(const char* name, const char* topic, ln_outport out, unsigned log_size, uint32_t count,
                     unsigned divisor = 1) {
    ln_logger lg = enabled(name, topic, log_size, divisor);
    write(out, 1, count);
    EXPECT_EQ(ln_logger_disable(lg), 0);
    return lg;
  }
  static void write(ln_outport port, uint32_t first, uint32_t count, double period = 0.0005) {
    for (uint32_t seq = first; seq < first + count; ++seq) {
      P64 p{};
      p.seq = seq;
      std::memset(p.pad, static_cast<int>(seq & 0xff), sizeof p.pad);
      ASSERT_EQ(ln_write(port, &p, sizeof p, nullptr), 0);
      if (period > 0) ln_sleep_seconds(period);
    }
  }
  /// The samples of topic `index` of a fresh download (checking the payload).
  static std::vector<Sample> download(ln_logger handle, unsigned index = 0) {
    ln_logger_data data = nullptr;
    EXPECT_EQ(ln_logger_download(handle, &data), 0) << ln_get_error_message(nullptr);
    logger_topic* topic = nullptr;
    EXPECT_EQ(ln_logger_data_get_topic(data, index, &topic), 0);
    std::vector<Sample> samples;
    if (topic == nullptr) return samples;
    for (uint32_t i = 0; i < topic->n_samples; ++i) {
      const auto* at = reinterpret_cast<const unsigned char*>(topic->samples) + i * topic->sample_size;
      Sample s{};
      std::memcpy(&s.log_ts, at, 8);
      std::memcpy(&s.src_ts, at + 8, 8);
      std::memcpy(&s.packet_counter, at + 16, 4);
      if (topic->sample_size == kSampleSize) {
        P64 p;
        std::memcpy(&p, at + 20, sizeof p);
        s.seq = p.seq;
        EXPECT_EQ(p.pad[59], p.seq & 0xff);
      }
      samples.push_back(s);
    }
    return samples;
  }
  static std::vector<uint32_t> seqs(const std::vector<Sample>& samples) {
    std::vector<uint32_t> out;
    for (const Sample& s : samples) out.push_back(s.seq);
    return out;
  }
  static std::vector<uint32_t> counters(const std::vector<Sample>& samples) {
    std::vector<uint32_t> out;
    for (const Sample& s : samples) out.push_back(s.packet_counter);
    return out;
  }
  /// Writes (seq from `first` on) until a packet is recorded; returns the
  /// next seq. For publishers that appear while the logger is enabled: the
  /// manager starts reading them soon after, with nobody waiting for it.
  uint32_t write_until_recorded(ln_outport port, ln_logger handle, uint32_t first) {
    const std::size_t before = download(handle).size();
    for (uint32_t seq = first; seq < first + 2000; ++seq) {
      write(port, seq, 1, 0.002);
      if (download(handle).size() > before) return seq + 1;
    }
    ADD_FAILURE() << "nothing was recorded";
    return first;
  }

  ln_client client_ = nullptr;
  ln_client other_ = nullptr;
};

TEST_F(LoggerTest, RecordsTheNewestLogSizePacketsOfAPublishedTopic) {
  ln_outport out = publish("lg.basic");
  ln_logger lg = logger("basic");
  ASSERT_EQ(ln_logger_add_topic(lg, "lg.basic", 5, 1), 0);
  const double before = ln_get_time();
  ASSERT_EQ(ln_logger_enable(lg), 0) << ln_get_error_message(client_);
  write(out, 1, 8);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  write(out, 9, 2);  // after disable: not recorded

  ln_logger_data data = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &data), 0);
  unsigned n_topics = 0;
  ASSERT_EQ(ln_logger_data_get_info(data, &n_topics), 0);
  ASSERT_EQ(n_topics, 1u);
  logger_topic* topic = nullptr;
  ASSERT_EQ(ln_logger_data_get_topic(data, 0, &topic), 0);
  EXPECT_STREQ(topic->name, "lg.basic");
  EXPECT_EQ(topic->log_size, 5u);
  EXPECT_EQ(topic->divisor, 1u);
  EXPECT_EQ(topic->n_samples, 5u);
  EXPECT_EQ(topic->sample_size, kSampleSize);
  EXPECT_STREQ(topic->md_name, "test/p64");
  EXPECT_STREQ(topic->md,
               "{'fields': [['uint32_t', 'seq', 1], ['uint8_t', 'pad', 60]], 'resp_fields': [], "
               "'defines': {}}");
  const auto samples = download(lg);
  EXPECT_EQ(seqs(samples), (std::vector<uint32_t>{4, 5, 6, 7, 8}));
  EXPECT_EQ(counters(samples), (std::vector<uint32_t>{4, 5, 6, 7, 8}));
  for (const Sample& s : samples) {
    EXPECT_GE(s.src_ts, before);
    EXPECT_GE(s.log_ts, s.src_ts);
    EXPECT_LT(s.log_ts - s.src_ts, 1.0);
  }
  EXPECT_EQ(seqs(download(lg)), seqs(samples));  // downloads can be repeated
}

TEST_F(LoggerTest, ALoggerIsNoSubscriber) {
  ln_outport out = publish("lg.hidden");
  ln_logger lg = enabled("hidden", "lg.hidden", 10);
  write(out, 1, 3);
  ln_topic_info* topics = nullptr;
  unsigned count = 0;
  ASSERT_EQ(ln_list_topics(client_, &topics, &count), 0);
  ASSERT_EQ(count, 1u);
  EXPECT_EQ(topics[0].subscribers, 0u);
  ln_free_list(topics);
  ln_client_info* clients = nullptr;
  ASSERT_EQ(ln_list_clients(client_, &clients, &count), 0);
  for (unsigned i = 0; i < count; ++i) EXPECT_EQ(clients[i].subscribed[0], nullptr) << clients[i].name;
  ln_free_list(clients);
  // The manager told the publisher of its reader: has_subscriber would
  // have turned true by now.
  ASSERT_EQ(ln_ping(client_, 5, nullptr), 0);
  EXPECT_EQ(ln_has_subscriber(out), 0);
  EXPECT_EQ(download(lg).size(), 3u);
}

TEST_F(LoggerTest, DivisorCountsFromEnableAndEnableStartsAfresh) {
  ln_outport out = publish("lg.divisor");
  ln_logger lg = recorded("divisor", "lg.divisor", out, 100, 10, 3);
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{3, 6, 9}));
  ASSERT_EQ(ln_logger_enable(lg), 0);  // drops the samples, counts anew
  write(out, 11, 7);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{13, 16}));
  ASSERT_EQ(ln_logger_add_topic(lg, "lg.divisor", 100, 0), 0);  // 0 counts as 1, as in LN 2.9
  ASSERT_EQ(ln_logger_enable(lg), 0);
  write(out, 18, 3);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{18, 19, 20}));
}

TEST_F(LoggerTest, OnlyTimestampsGivesTwentyByteSamples) {
  ln_outport out = publish("lg.ts");
  ln_logger lg = logger("ts");
  ASSERT_EQ(ln_logger_add_topic(lg, "lg.ts", 10, 1), 0);
  ASSERT_EQ(ln_logger_set_only_ts(lg, 1), 0);
  ASSERT_EQ(ln_logger_enable(lg), 0);
  write(out, 1, 4);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  ln_logger_data data = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &data), 0);
  logger_topic* topic = nullptr;
  ASSERT_EQ(ln_logger_data_get_topic(data, 0, &topic), 0);
  EXPECT_EQ(topic->sample_size, 20u);
  EXPECT_EQ(counters(download(lg)), (std::vector<uint32_t>{1, 2, 3, 4}));
}

TEST_F(LoggerTest, ATopicPublishedLaterIsRecordedFromThenOn) {
  ln_logger lg = logger("later");
  ASSERT_EQ(ln_logger_add_topic(lg, "lg.later", 50, 1), 0);
  ASSERT_EQ(ln_logger_add_topic(lg, "lg.never", 50, 1), 0);
  ASSERT_EQ(ln_logger_enable(lg), 0);
  ln_outport out = publish("lg.later");
  const uint32_t next = write_until_recorded(out, lg, 1);
  write(out, next, 5);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  const auto samples = download(lg);
  ASSERT_GE(samples.size(), 6u);
  for (std::size_t i = 1; i < samples.size(); ++i) EXPECT_EQ(samples[i].seq, samples[i - 1].seq + 1);
  EXPECT_EQ(samples.back().seq, next + 4);
  // The topic that never got a publisher: listed, no definition, no samples.
  ln_logger_data data = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &data), 0);
  logger_topic* never = nullptr;
  ASSERT_EQ(ln_logger_data_get_topic(data, 1, &never), 0);
  EXPECT_STREQ(never->name, "lg.never");
  EXPECT_EQ(never->n_samples, 0u);
  EXPECT_EQ(never->sample_size, 0u);
  EXPECT_STREQ(never->md_name, "");
}

TEST_F(LoggerTest, TheRecordingOutlivesItsPublisherAndGoesOnWithTheNext) {
  other_ = connect("first_publisher");
  ln_outport first = publish("lg.outlive", other_);
  ln_logger lg = enabled("outlive", "lg.outlive", 100);
  write(first, 1, 5, 0);
  ASSERT_EQ(ln_deinit(&other_), 0);  // closes the segment right after the writes
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{1, 2, 3, 4, 5}));

  other_ = connect("second_publisher");
  ln_outport second = publish("lg.outlive", other_);
  const uint32_t next = write_until_recorded(second, lg, 100);
  write(second, next, 3);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  const auto samples = download(lg);
  ASSERT_GE(samples.size(), 9u);
  const std::vector<uint32_t> numbers = seqs(samples);
  EXPECT_EQ(std::vector<uint32_t>(numbers.begin(), numbers.begin() + 5), (std::vector<uint32_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(samples.back().seq, next + 2);
  // The second publisher numbers its packets from 1 again.
  EXPECT_EQ(samples.back().packet_counter, next + 2 - 100 + 1);
}

TEST_F(LoggerTest, LoggersOfOneTopicRecordIndependently) {
  ln_outport out = publish("lg.two");
  ln_logger a = logger("two_a");
  ln_logger b = logger("two_b");
  ASSERT_EQ(ln_logger_add_topic(a, "lg.two", 10, 1), 0);
  ASSERT_EQ(ln_logger_add_topic(b, "lg.two", 3, 1), 0);
  ASSERT_EQ(ln_logger_enable(a), 0);
  write(out, 1, 3);
  ASSERT_EQ(ln_logger_enable(b), 0);
  write(out, 4, 5);
  ASSERT_EQ(ln_logger_disable(a), 0);
  write(out, 9, 2);
  ASSERT_EQ(ln_logger_disable(b), 0);
  EXPECT_EQ(seqs(download(a)), (std::vector<uint32_t>{1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(seqs(download(b)), (std::vector<uint32_t>{8, 9, 10}));
}

TEST_F(LoggerTest, DownloadWhileEnabledGivesTheRecordingSoFar) {
  ln_outport out = publish("lg.live");
  ln_logger lg = enabled("live", "lg.live", 100);
  write(out, 1, 3);
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{1, 2, 3}));
  write(out, 4, 2);
  EXPECT_EQ(seqs(download(lg)), (std::vector<uint32_t>{1, 2, 3, 4, 5}));
  ASSERT_EQ(ln_logger_disable(lg), 0);
}

TEST_F(LoggerTest, AOneKilohertzStreamIsRecordedCompletely) {
  ln_outport out = publish("lg.stream");
  ln_logger lg = enabled("stream", "lg.stream", 1000);
  write(out, 1, 600, 0.001);
  ASSERT_EQ(ln_logger_disable(lg), 0);
  const auto samples = download(lg);
  ASSERT_EQ(samples.size(), 600u);
  for (std::size_t i = 0; i < samples.size(); ++i) EXPECT_EQ(samples[i].seq, i + 1);
}

TEST_F(LoggerTest, LoggersAreNamesInTheManagerSharedByClients) {
  ln_outport out = publish("lg.shared");
  ln_logger mine = logger("shared");
  ln_logger again = logger("shared");
  EXPECT_EQ(mine, again);
  ASSERT_EQ(ln_logger_add_topic(mine, "lg.shared", 10, 1), 0);
  ASSERT_EQ(ln_logger_enable(mine), 0);
  write(out, 1, 2);
  other_ = connect("another");
  ln_logger theirs = logger("shared", other_);
  EXPECT_EQ(seqs(download(theirs)), (std::vector<uint32_t>{1, 2}));
  ASSERT_EQ(ln_logger_disable(theirs), 0);
  write(out, 3, 1);
  EXPECT_EQ(seqs(download(mine)), (std::vector<uint32_t>{1, 2}));
}

TEST_F(LoggerTest, BadInputIsRefusedWithTheReason) {
  ln_logger lg = logger("bad");
  EXPECT_EQ(ln_logger_enable(lg), -LNE_NO_LOGGER_TOPICS);
  EXPECT_EQ(ln_logger_add_topic(lg, "lg.bad", 0, 1), -LNE_INVALID_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("at least 1 sample"), std::string::npos);
  EXPECT_EQ(ln_logger_add_topic(lg, "", 5, 1), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_logger_add_topic(lg, nullptr, 5, 1), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_logger_add_topic(lg, "lg\tbad", 5, 1), 0);   // the manager checks names ...
  EXPECT_EQ(ln_logger_enable(lg), -LNE_INVALID_PARAMETER);  // ... when enabled
  ASSERT_EQ(ln_logger_clear_topics(lg), 0);

  // A log that cannot fit the manager's memory, for a topic known or not.
  ln_outport out = publish("lg.huge");
  (void)out;
  for (const char* topic : {"lg.huge", "lg.not_yet"}) {
    ASSERT_EQ(ln_logger_clear_topics(lg), 0);
    ASSERT_EQ(ln_logger_add_topic64(lg, topic, uint64_t{1} << 42, 1), 0);
    EXPECT_EQ(ln_logger_enable(lg), -LNE_NO_MEM) << topic;
    EXPECT_NE(std::string(ln_get_error_message(client_)).find("do not fit"), std::string::npos)
        << ln_get_error_message(client_);
  }

  ln_logger never = logger("never_enabled");
  ln_logger_data data = nullptr;
  EXPECT_EQ(ln_logger_download(never, &data), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("does not exist"), std::string::npos);
  EXPECT_EQ(ln_logger_manager_save(never, "/tmp/x.raw", "raw"), -LNE_REQUEST_FAILED);
  EXPECT_EQ(ln_logger_disable(never), 0);  // as LN 2.9

  int not_a_logger = 0;
  EXPECT_EQ(ln_logger_enable(&not_a_logger), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_logger_enable(nullptr), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_client_get_logger(client_, nullptr, "x"), -LNE_INVALID_PARAMETER);
  EXPECT_EQ(ln_client_get_logger(nullptr, &lg, "x"), -LNE_CLIENT_NOT_INITIALIZED);
  unsigned n = 0;
  EXPECT_EQ(ln_logger_data_get_info(&not_a_logger, &n), -LNE_INVALID_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(nullptr)).find("not a logger data handle"), std::string::npos);
}

TEST_F(LoggerTest, DataHandlesFollowTheirOwners) {
  ln_logger lg = recorded("handles", "lg.handles", publish("lg.handles"), 10, 2);
  ln_logger_data first = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &first), 0);
  logger_topic* topic = nullptr;
  EXPECT_EQ(ln_logger_data_get_topic(first, 1, &topic), -LNE_TOPIC_ID_OUT_OF_RANGE);
  EXPECT_EQ(ln_logger_data_deinit(&first), -LNE_INVALID_PARAMETER);  // belongs to the logger
  EXPECT_NE(first, nullptr);
  ln_logger_data second = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &second), 0);
  unsigned n = 0;
  if (second != first) {
    EXPECT_EQ(ln_logger_data_get_info(first, &n), -LNE_INVALID_PARAMETER);  // replaced
  }

  TempDir dir;
  const std::string path = dir.path() + "/handles.lnlog";
  ASSERT_EQ(ln_logger_data_save(second, path.c_str()), 0);
  ln_logger_data loaded = nullptr;
  ASSERT_EQ(ln_logger_data_load(&loaded, path.c_str()), 0);
  ASSERT_EQ(ln_logger_data_get_topic(loaded, 0, &topic), 0);
  EXPECT_EQ(topic->n_samples, 2u);
  EXPECT_EQ(topic->samples->packet_counter, 1u);
  ASSERT_EQ(ln_logger_data_deinit(&loaded), 0);
  EXPECT_EQ(loaded, nullptr);

  std::ofstream(dir.path() + "/bad.lnlog") << "not logger data";
  EXPECT_EQ(ln_logger_data_load(&loaded, (dir.path() + "/bad.lnlog").c_str()), -LNE_INVALID_PARAMETER);
  EXPECT_NE(std::string(ln_get_error_message(nullptr)).find("not valid LN logger data"), std::string::npos);
  EXPECT_EQ(ln_logger_data_load(&loaded, (dir.path() + "/missing").c_str()), -LNE_CHECK_ERRNO);
  ASSERT_EQ(ln_logger_data_get_info(second, &n), 0);
  EXPECT_STREQ(ln_get_error_message(nullptr), "");  // a detail only after a failed call
}

TEST_F(LoggerTest, ManagerSaveWritesTheFormatsOnTheManagersHost) {
  ln_logger lg = recorded("save", "lg.save", publish("lg.save"), 10, 4);
  TempDir dir;
  const std::string raw = dir.path() + "/log.raw";
  ASSERT_EQ(ln_logger_manager_save(lg, raw.c_str(), "auto"), 0) << ln_get_error_message(client_);
  ln_logger_data data = nullptr;
  ASSERT_EQ(ln_logger_download(lg, &data), 0);
  logger_topic* topic = nullptr;
  ASSERT_EQ(ln_logger_data_get_topic(data, 0, &topic), 0);
  EXPECT_EQ(file_bytes(raw), std::string(reinterpret_cast<const char*>(topic->samples), 4 * kSampleSize));
  for (const char* format : {"pcap", "mat", "mat4"}) {
    const std::string path = dir.path() + "/log." + format;
    EXPECT_EQ(ln_logger_manager_save(lg, path.c_str(), format), 0) << ln_get_error_message(client_);
    EXPECT_GT(file_bytes(path).size(), 4 * sizeof(P64)) << format;
  }
  EXPECT_EQ(file_bytes(dir.path() + "/log.pcap").substr(0, 4), std::string("\xd4\xc3\xb2\xa1", 4));
  EXPECT_EQ(file_bytes(dir.path() + "/log.mat").substr(0, 6), "MATLAB");

  EXPECT_EQ(ln_logger_manager_save(lg, (dir.path() + "/x.pickle").c_str(), "pickle"), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("cannot write Python pickles"), std::string::npos);
  EXPECT_EQ(ln_logger_manager_save(lg, (dir.path() + "/x.h5").c_str(), "hdf5"), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("raw, pcap, mat, mat4"), std::string::npos);
  EXPECT_EQ(ln_logger_manager_save(lg, (dir.path() + "/no/dir/x.raw").c_str(), "raw"), -LNE_REQUEST_FAILED);
  EXPECT_NE(std::string(ln_get_error_message(client_)).find("No such file"), std::string::npos);
}

TEST_F(LoggerTest, CppWrapper) {
  ln::client clnt("cpp_logging", manager_.address());
  ln::outport* out = clnt.publish("lg.cpp", "test/p64");
  ln::logger* lg = clnt.get_logger("cpp");
  EXPECT_EQ(clnt.get_logger("cpp"), lg);
  EXPECT_EQ(lg->name, "cpp");
  EXPECT_THROW(lg->enable(), ln::exception);
  lg->add_topic("lg.cpp", 10);
  lg->enable();
  P64 p{};
  for (uint32_t seq = 1; seq <= 3; ++seq) {
    p.seq = seq;
    out->write(&p);
  }
  lg->disable();
  ln::logger_data* data = lg->download();
  ASSERT_EQ(data->topics.size(), 1u);
  ln::logger_data::topic_cursor* cursor = data->topics.front();
  EXPECT_EQ(cursor->name, "lg.cpp");
  ASSERT_EQ(cursor->topic->n_samples, 3u);
  EXPECT_EQ(cursor->get_sample(2)->packet_counter, 3u);
  EXPECT_EQ(lg->download(), data);  // the logger's one data object, refreshed

  TempDir dir;
  data->save(dir.path() + "/cpp.lnlog");
  std::unique_ptr<ln::logger_data> loaded(ln::logger_data::load(dir.path() + "/cpp.lnlog"));
  EXPECT_EQ(loaded->_logger, nullptr);
  ASSERT_EQ(loaded->topics.size(), 1u);
  EXPECT_EQ(loaded->topics.front()->get_sample(0)->packet_counter, 1u);
  try {
    ln::logger_data::load(dir.path() + "/missing.lnlog");
    FAIL() << "loaded a missing file";
  } catch (const ln::exception& error) {
    EXPECT_NE(std::string(error.what()).find("missing.lnlog"), std::string::npos) << error.what();
  }
  try {
    lg->manager_save(dir.path() + "/x.pickle", "pickle");
    FAIL() << "saved a pickle";
  } catch (const ln::exception& error) {
    EXPECT_NE(std::string(error.what()).find("Python pickles"), std::string::npos) << error.what();
  }
}

}  // namespace
