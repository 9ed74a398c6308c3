#include "protocol/wire.hpp"

#include <gtest/gtest.h>

#include <random>

namespace ln::protocol {
namespace {

Message sample() {
  Message m = Message::request(42, "publish");
  m.set("topic", "robot.joints").set("buffers", 4).set("rate", -1.5).set("reliable", true);
  m.set("names", StringList{"a", "", std::string("b\0c", 3)});
  m.set("negative", std::int64_t{-9000000000});
  return m;
}

TEST(Wire, RoundTripsEveryValueType) {
  const std::string frame = encode(sample());
  FrameReader reader;
  reader.append(frame.data(), frame.size());
  const auto m = reader.next();
  ASSERT_TRUE(m);
  EXPECT_EQ(m->kind(), Kind::Request);
  EXPECT_EQ(m->id(), 42u);
  EXPECT_EQ(m->method(), "publish");
  EXPECT_EQ(m->get_string("topic"), "robot.joints");
  EXPECT_EQ(m->get_int("buffers"), 4);
  EXPECT_EQ(m->get_double("rate"), -1.5);
  EXPECT_TRUE(m->get_bool("reliable"));
  EXPECT_EQ(m->get_list("names"), (StringList{"a", "", std::string("b\0c", 3)}));
  EXPECT_EQ(m->get_int("negative"), -9000000000);
  EXPECT_FALSE(reader.next());
}

TEST(Wire, ReassemblesFramesSplitAnywhere) {
  std::string stream;
  for (int i = 0; i < 3; ++i) stream += encode(sample());
  for (std::size_t chunk = 1; chunk < 17; ++chunk) {
    FrameReader reader;
    int received = 0;
    for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
      reader.append(stream.data() + pos, std::min(chunk, stream.size() - pos));
      while (reader.next()) ++received;
    }
    EXPECT_EQ(received, 3) << "chunk size " << chunk;
    EXPECT_EQ(reader.buffered(), 0u);
  }
}

TEST(Wire, ValidatesTypesAndRanges) {
  const Message m = sample();
  EXPECT_THROW(m.get_int("topic"), ProtocolError);
  EXPECT_THROW(m.get_string("absent"), ProtocolError);
  EXPECT_THROW(m.get_int("buffers", 5, 10), ProtocolError);
  EXPECT_EQ(m.get_int_or("absent", 7), 7);
  const Message error = Message::error_response_to(m, 21, "lost connection");
  EXPECT_TRUE(error.is_error());
  EXPECT_EQ(error.error_code(), 21);
  EXPECT_EQ(error.error_text(), "lost connection");
  EXPECT_EQ(error.id(), 42u);
}

TEST(Wire, RefusesHugeAnnouncedSizesBeforeAllocating) {
  FrameReader reader;
  const char header[4] = {'\xff', '\xff', '\xff', '\x7f'};
  EXPECT_THROW(reader.append(header, 4), ProtocolError);
}

TEST(Wire, RejectsMalformedPayloads) {
  const std::string frame = encode(sample());
  const std::string payload = frame.substr(4);
  for (std::size_t cut = 0; cut < payload.size(); ++cut)
    EXPECT_THROW(decode_payload(payload.substr(0, cut)), ProtocolError) << "cut at " << cut;
  EXPECT_THROW(decode_payload(payload + "x"), ProtocolError);
  std::string bad_kind = payload;
  bad_kind[0] = 9;
  EXPECT_THROW(decode_payload(bad_kind), ProtocolError);
  // A list claiming 2^32-1 items in a tiny payload must not allocate them.
  Message list_message(Kind::Notification, 0);
  list_message.set("l", StringList{});
  std::string huge_list = encode(list_message).substr(4);
  huge_list.replace(huge_list.size() - 4, 4, "\xff\xff\xff\xff");
  EXPECT_THROW(decode_payload(huge_list), ProtocolError);
}

// Random bytes must produce ProtocolError or a valid message, never a crash
// (the sanitizer build checks memory safety).
TEST(Wire, SurvivesRandomGarbage) {
  std::mt19937 random(1234);
  const std::string valid = encode(sample()).substr(4);
  for (int round = 0; round < 20000; ++round) {
    std::string data = valid;
    const int flips = 1 + static_cast<int>(random() % 8);
    for (int f = 0; f < flips; ++f) data[random() % data.size()] = static_cast<char>(random());
    if (round % 3 == 0) data.resize(random() % (data.size() + 1));
    try {
      decode_payload(data);
    } catch (const ProtocolError&) {
    }
  }
}

}  // namespace
}  // namespace ln::protocol
