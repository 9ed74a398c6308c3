#include "client/logger_data.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <tuple>

#include "client/failure.hpp"
#include "testing/temp_dir.hpp"

namespace ln::clientlib {
namespace {

class LoggerDataTest : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& bytes) const { return temp.write(name, bytes); }
  std::string read(const std::string& path) const {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  static int load_error(const std::string& path, std::string* text = nullptr) {
    try {
      LoggerData::load(path);
    } catch (const Failure& failure) {
      if (text != nullptr) *text = failure.what();
      return failure.code();
    }
    return 0;
  }

  test::TempDir temp{"ln_logger_data_test"};
  const std::string dir = temp.path();
};

/// Two topics: one with samples (36 bytes each), one never published.
std::vector<LoggerData::Topic> example_topics() {
  LoggerData::Topic recorded;
  recorded.name = "lg.t1";
  recorded.log_size = 5;
  recorded.divisor = 2;
  recorded.n_samples = 3;
  recorded.sample_size = 36;
  recorded.md_name = "lg/c";
  recorded.md = "{'fields': [['uint32_t', 'counter', 1]], 'resp_fields': [], 'defines': {}}";
  for (int i = 0; i < 3 * 36; ++i) recorded.samples.push_back(static_cast<unsigned char>(i * 7));
  LoggerData::Topic silent;
  silent.name = "never.published";
  silent.log_size = std::uint64_t{1} << 33;  // needs the 64-bit field
  return {recorded, silent};
}

/// Every field of a topic, to compare topics whole.
auto fields(const LoggerData::Topic& t) {
  return std::tie(t.name, t.log_size, t.divisor, t.n_samples, t.sample_size, t.md_name, t.md, t.samples);
}

// The layout of ln/ln.h's logger data files, written here field by field.
struct FileBuilder {
  std::string bytes;
  template <typename T>
  FileBuilder& put(T value) {
    bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
    return *this;
  }
  FileBuilder& text(const std::string& value) {
    put(static_cast<std::uint32_t>(value.size()));
    bytes += value;
    return *this;
  }
};

TEST_F(LoggerDataTest, RoundTripsEveryField) {
  LoggerData data(example_topics());
  ASSERT_EQ(data.size(), 2u);
  const std::string path = dir + "/log.lnlog";
  data.save(path);
  auto loaded = LoggerData::load(path);
  EXPECT_TRUE(loaded->loaded());
  EXPECT_FALSE(data.loaded());
  ASSERT_EQ(loaded->size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const LoggerData::Topic& a = data.contents(i);
    const LoggerData::Topic& b = loaded->contents(i);
    EXPECT_EQ(fields(a), fields(b));
  }
  // The ln.h view points at the same contents.
  logger_topic* view = loaded->topic(0);
  ASSERT_NE(view, nullptr);
  EXPECT_STREQ(view->name, "lg.t1");
  EXPECT_EQ(view->n_samples, 3u);
  EXPECT_EQ(reinterpret_cast<const unsigned char*>(view->samples) + 36, loaded->contents(0).samples.data() + 36);
  EXPECT_EQ(loaded->topic(1)->samples, nullptr);
  EXPECT_STREQ(loaded->topic(1)->md, "");
  EXPECT_EQ(loaded->topic(2), nullptr);
}

TEST_F(LoggerDataTest, WritesLn29sLayout) {
  LoggerData data(example_topics());
  data.save(dir + "/ours.lnlog");
  const std::string ours = read(dir + "/ours.lnlog");
  // Same layout built by hand, with the comment ours carries.
  std::uint32_t comment_length;
  std::memcpy(&comment_length, ours.data() + 6, 4);
  FileBuilder expected;
  expected.put<std::uint16_t>(0x0420).put<std::uint32_t>(3).text(ours.substr(10, comment_length)).put<std::uint32_t>(2);
  for (const LoggerData::Topic& topic : example_topics()) {
    expected.text(topic.name).put(topic.log_size).put(topic.divisor).put(topic.n_samples).put(topic.sample_size);
    expected.text(topic.md_name).text(topic.md);
    expected.bytes.append(topic.samples.begin(), topic.samples.end());
  }
  EXPECT_EQ(ours, expected.bytes);
}

TEST_F(LoggerDataTest, ReadsFilesWithAnyCommentAndVersion2) {
  const auto topics = example_topics();
  FileBuilder v3;
  v3.put<std::uint16_t>(0x0420)
      .put<std::uint32_t>(3)
      .text("\r# this file comes from another writer\n")
      .put<std::uint32_t>(1);
  v3.text("a").put<std::uint64_t>(9).put<std::uint32_t>(1).put<std::uint32_t>(1).put<std::uint32_t>(20).text("x").text(
      "y");
  v3.bytes += std::string(20, 'z');
  auto loaded = LoggerData::load(write("v3.lnlog", v3.bytes));
  EXPECT_EQ(loaded->contents(0).log_size, 9u);
  EXPECT_EQ(loaded->contents(0).samples, std::vector<unsigned char>(20, 'z'));

  FileBuilder v2;  // LN before 64-bit log sizes: a u32 log_size
  v2.put<std::uint16_t>(0x0420).put<std::uint32_t>(2).text("").put<std::uint32_t>(1);
  v2.text("a").put<std::uint32_t>(9).put<std::uint32_t>(1).put<std::uint32_t>(0).put<std::uint32_t>(0).text("").text(
      "");
  loaded = LoggerData::load(write("v2.lnlog", v2.bytes));
  EXPECT_EQ(loaded->contents(0).log_size, 9u);
  EXPECT_EQ(loaded->contents(0).n_samples, 0u);
}

TEST_F(LoggerDataTest, RefusesForeignAndDamagedFilesWithTheReason) {
  LoggerData(example_topics()).save(dir + "/good.lnlog");
  const std::string good = read(dir + "/good.lnlog");
  std::string text;

  std::string swapped = good;
  std::swap(swapped[0], swapped[1]);
  EXPECT_EQ(load_error(write("swapped", swapped), &text), LNE_WRONG_BYTE_ORDER);
  EXPECT_NE(text.find("other byte order"), std::string::npos);

  std::string newer = good;
  newer[2] = 4;
  EXPECT_EQ(load_error(write("newer", newer), &text), LNE_LOG_FILE_TOO_NEW);
  EXPECT_NE(text.find("version 4"), std::string::npos);

  EXPECT_EQ(load_error(write("garbage", "garbage!garbage!garbage!"), &text), LNE_INVALID_PARAMETER);
  EXPECT_NE(text.find("not valid LN logger data"), std::string::npos);
  EXPECT_EQ(load_error(write("empty", ""), &text), LNE_INVALID_PARAMETER);
  EXPECT_EQ(load_error(write("extra", good + "x"), &text), LNE_INVALID_PARAMETER);
  EXPECT_NE(text.find("after the last topic"), std::string::npos);
  EXPECT_EQ(load_error(dir + "/missing"), LNE_CHECK_ERRNO);

  // Every truncation is refused, never read beyond the end.
  for (std::size_t size = 0; size < good.size(); ++size)
    EXPECT_EQ(load_error(write("cut", good.substr(0, size))), LNE_INVALID_PARAMETER) << "cut at " << size;

  // Random damage anywhere: a clear refusal or consistent data, never a crash.
  std::mt19937 random(14);
  for (int round = 0; round < 300; ++round) {
    std::string damaged = good;
    for (int flips = 0; flips < 3; ++flips) damaged[random() % damaged.size()] = static_cast<char>(random());
    const std::string path = write("damaged", damaged);
    try {
      auto loaded = LoggerData::load(path);
      for (std::size_t i = 0; i < loaded->size(); ++i)
        EXPECT_EQ(loaded->contents(i).samples.size(),
                  std::uint64_t{loaded->contents(i).n_samples} * loaded->contents(i).sample_size);
    } catch (const Failure& failure) {
      EXPECT_NE(failure.code(), 0);
    }
  }
}

TEST_F(LoggerDataTest, SavingWhereItCannotNamesTheSystemsReason) {
  LoggerData data(example_topics());
  try {
    data.save(dir + "/no/such/dir/x.lnlog");
    FAIL() << "saved into a missing directory";
  } catch (const Failure& failure) {
    EXPECT_EQ(failure.code(), LNE_CHECK_ERRNO);
    EXPECT_NE(std::string(failure.what()).find("x.lnlog"), std::string::npos);
  }
}

TEST_F(LoggerDataTest, InconsistentContentsAreRefused) {
  auto topics = example_topics();
  topics[0].samples.pop_back();
  EXPECT_THROW(LoggerData data(topics), Failure);
  topics = example_topics();
  topics[0].sample_size = 10;
  topics[0].samples.resize(30);
  EXPECT_THROW(LoggerData data(topics), Failure);
}

TEST_F(LoggerDataTest, HandlesOfFreedDataAreNotAlive) {
  auto data = std::make_unique<LoggerData>(example_topics());
  const void* handle = data.get();
  EXPECT_TRUE(LoggerData::alive(handle));
  data.reset();
  EXPECT_FALSE(LoggerData::alive(handle));
  int not_data = 0;
  EXPECT_FALSE(LoggerData::alive(&not_data));
}

}  // namespace
}  // namespace ln::clientlib
