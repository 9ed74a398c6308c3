#include "services/call_frames.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#define NO_CPP_WRAPPER
#include "ln/ln.h"

namespace ln::services::frames {
namespace {

std::string request_frame(RequestHead head, const std::string& body) {
  std::string frame(request_overhead + body.size(), '\0');
  write_request_head(frame.data(), head, body.size());
  std::memcpy(frame.data() + request_overhead, body.data(), body.size());
  return frame;
}

std::string response_frame(ResponseHead head, const std::string& text, const std::string& body) {
  std::string frame(response_overhead(text) + body.size(), '\0');
  write_response_head(frame.data(), head, text, body.size());
  std::memcpy(frame.data() + response_overhead(text), body.data(), body.size());
  return frame;
}

// Feeds `stream` in pieces of at most `piece` bytes; returns the payloads.
std::vector<Payload> assemble(FrameAssembler& assembler, const std::string& stream, std::size_t piece) {
  std::vector<Payload> out;
  std::size_t pos = 0;
  while (pos < stream.size()) {
    std::size_t capacity = 0;
    char* space = assembler.space(capacity);
    EXPECT_GE(capacity, 1u);
    const std::size_t n = std::min({capacity, piece, stream.size() - pos});
    std::memcpy(space, stream.data() + pos, n);
    pos += n;
    const Status s = assembler.commit(n);
    EXPECT_TRUE(s.ok()) << s.detail();
    Payload p;
    while (assembler.next(p)) out.push_back(std::move(p));
  }
  return out;
}

TEST(CallFrames, RequestLayoutOnTheWire) {
  const std::string frame = request_frame({0x01020304, 7}, "ab");
  const std::string expected(
      "\x12\x00\x00\x00"  // payload size 18
      "\x10\x01\x00\x00"  // kind, version
      "\x04\x03\x02\x01"  // service id
      "\x07\x00\x00\x00"  // request id
      "\x00\x00\x00\x00"
      "ab",
      22);
  EXPECT_EQ(frame, expected);
}

TEST(CallFrames, RoundTripThroughTheAssembler) {
  const std::string stream = request_frame({5, 1}, "hello") + response_frame({1, 0}, "", "flat") +
                             response_frame({2, -LNE_SVC_HANDLER_EXC}, "it threw", "") + request_frame({5, 3}, "");
  for (std::size_t piece : {std::size_t{1}, std::size_t{3}, std::size_t{7}, stream.size()}) {
    FrameAssembler assembler(1 << 20);
    std::vector<Payload> payloads = assemble(assembler, stream, piece);
    ASSERT_EQ(payloads.size(), 4u) << piece;
    EXPECT_FALSE(assembler.in_frame());

    RequestHead request;
    ASSERT_TRUE(parse_request(payloads[0], request).ok());
    EXPECT_EQ(request.service_id, 5u);
    EXPECT_EQ(request.request_id, 1u);
    EXPECT_EQ(std::string(payloads[0].data() + header_size, payloads[0].size() - header_size), "hello");

    ResponseHead response;
    std::string_view text;
    std::size_t body = 0;
    ASSERT_TRUE(parse_response(payloads[1], response, text, body).ok());
    EXPECT_EQ(response.result, 0);
    EXPECT_EQ(std::string(payloads[1].data() + body, payloads[1].size() - body), "flat");
    ASSERT_TRUE(parse_response(payloads[2], response, text, body).ok());
    EXPECT_EQ(response.result, -LNE_SVC_HANDLER_EXC);
    EXPECT_EQ(text, "it threw");
    ASSERT_TRUE(parse_request(payloads[3], request).ok());
    EXPECT_EQ(payloads[3].size(), header_size);
  }
}

TEST(CallFrames, LargeFramesLandInTheirOwnBuffer) {
  std::string body(5u << 20, '\0');
  for (std::size_t i = 0; i < body.size(); ++i) body[i] = static_cast<char>(i * 31);
  const std::string stream = request_frame({1, 1}, "x") + request_frame({1, 2}, body) + request_frame({1, 3}, "y");
  FrameAssembler assembler(16u << 20);
  std::vector<Payload> payloads = assemble(assembler, stream, 100000);
  ASSERT_EQ(payloads.size(), 3u);
  ASSERT_EQ(payloads[1].size(), header_size + body.size());
  EXPECT_EQ(std::memcmp(payloads[1].data() + header_size, body.data(), body.size()), 0);
  EXPECT_EQ(std::string(payloads[2].data() + header_size, 1), "y");
  // Flat data starts 8-aligned in a payload buffer.
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(payloads[1].data() + header_size) % 8, 0u);
}

TEST(CallFrames, WhatAPeerAnnouncesIsNotAllocatedBeforeItArrives) {
  FrameAssembler assembler(256u << 20);
  std::size_t capacity = 0;
  char* space = assembler.space(capacity);
  const std::uint32_t announced = 200u << 20;
  std::memcpy(space, &announced, 4);  // little endian, as the wire
  ASSERT_TRUE(assembler.commit(4).ok());
  space = assembler.space(capacity);
  ASSERT_NE(space, nullptr);
  EXPECT_LE(capacity, 4u << 20) << "the buffer grows with the data, from 4 MiB";
}

TEST(CallFrames, OversizedFrameIsRefusedBeforeAllocation) {
  FrameAssembler assembler(1000);
  std::size_t capacity = 0;
  char* space = assembler.space(capacity);
  const char huge[4] = {'\xff', '\xff', '\xff', '\x7f'};
  std::memcpy(space, huge, 4);
  EXPECT_EQ(assembler.commit(4).code(), -LNE_PACKET_TOO_LARGE);
  EXPECT_EQ(max_payload_for(std::size_t{1} << 40), std::size_t{UINT32_MAX});
}

TEST(CallFrames, RejectsWrongKindsVersionsAndLengths) {
  Payload p;
  ASSERT_TRUE(p.allocate(header_size));
  std::memset(p.data(), 0, header_size);
  RequestHead request;
  ResponseHead response;
  std::string_view text;
  std::size_t body = 0;
  p.data()[0] = 1;  // a protocol::Message request kind
  p.data()[1] = format_version;
  EXPECT_FALSE(parse_request(p, request).ok());
  p.data()[0] = static_cast<char>(request_kind);
  p.data()[1] = 9;
  EXPECT_FALSE(parse_request(p, request).ok());

  std::string frame = response_frame({1, 0}, "", "");
  frame[16] = 100;  // text size beyond the frame
  Payload q;
  ASSERT_TRUE(q.allocate(frame.size() - size_prefix));
  std::memcpy(q.data(), frame.data() + size_prefix, q.size());
  EXPECT_FALSE(parse_response(q, response, text, body).ok());

  frame = response_frame({1, 5}, "", "data");  // a failure carries no data
  ASSERT_TRUE(q.allocate(frame.size() - size_prefix));
  std::memcpy(q.data(), frame.data() + size_prefix, q.size());
  EXPECT_FALSE(parse_response(q, response, text, body).ok());

  Payload tiny;
  ASSERT_TRUE(tiny.allocate(3));
  EXPECT_FALSE(parse_request(tiny, request).ok());
}

TEST(CallFrames, LongTextsAreCut) {
  const std::string text(10000, 'e');
  const std::string frame = response_frame({1, 3}, text, "");
  EXPECT_EQ(frame.size(), size_prefix + header_size + max_text_size);
}

TEST(CallFrames, RandomStreamsNeverCrash) {
  std::mt19937 random(7);
  for (int round = 0; round < 2000; ++round) {
    FrameAssembler assembler(4096);
    std::string stream(random() % 300, '\0');
    for (char& c : stream) c = static_cast<char>(random() % 8 == 0 ? 0x10 : random());
    std::size_t pos = 0;
    bool failed = false;
    while (pos < stream.size() && !failed) {
      std::size_t capacity = 0;
      char* space = assembler.space(capacity);
      const std::size_t n = std::min<std::size_t>({capacity, 1 + random() % 40, stream.size() - pos});
      std::memcpy(space, stream.data() + pos, n);
      pos += n;
      failed = !assembler.commit(n).ok();
      Payload p;
      RequestHead head;
      while (!failed && assembler.next(p)) parse_request(p, head);
    }
  }
}

}  // namespace
}  // namespace ln::services::frames
