// The frames of a service connection.
//
// A caller opens one connection per service handle to the provider's peer
// server and sends the `call` handshake (protocol/methods.hpp). After the
// peer server's ok, the connection carries only these frames and belongs to
// the services code on both ends (the provider's dispatch.hpp, the caller's
// call_state.hpp):
//
//   frame    = u32 payload_size | payload         (the envelope of wire.hpp)
//   request  = u8 0x10 | u8 version 1 | u16 0 | u32 service_id | u32 request_id
//              | u32 client_id | flat request                            (caller -> provider)
//   response = u8 0x11 | u8 version 1 | u16 0 | u32 request_id | i32 result
//              | u32 text_size | text | flat response                      (provider -> caller)
//
// All integers little endian. `flat` is the format of marshal.hpp. result
// 0: success, the flat response follows and text is empty; < 0: an LN error
// (-LNE_*, e.g. -LNE_SVC_HANDLER_NO_RESP, -LNE_SVC_HANDLER_EXC); > 0: the
// error code the provider's handler returned. `text` explains a failure
// (may be empty). client_id is the caller's id at the manager (0 if it does
// not know it; service logging reports it). request_id counts per
// connection; a response answers the
// request with the same id. A caller that gives up on a call (timeout,
// abort) closes the connection, which is how the provider learns that the
// request was aborted; so there is no abort frame and never a late
// response on a live connection. Kinds 0x10/0x11 differ from wire.hpp's
// message kinds 1..3, so a stream that was not switched is rejected at
// once.
//
// Why not protocol::Message: encoding and decoding one small call as
// Message (a map of named fields, string copies) costs ~0.6 µs against
// ~0.08 µs for these frames (service_rtt_bench --modes codec), ~0.7 µs of a
// ~8 µs round trip on one core; Message also copies large payloads several
// times and caps frames at wire.hpp's 64 MiB, while service data may be
// configured up to 4 GiB (Limits::max_data_size, 256 MiB by default). The
// fixed 16-byte headers let the flat data start 8-aligned in a received
// buffer, so arrays can be used in place (marshal.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <memory>
#include <string_view>

#include "services/status.hpp"

namespace ln::services::frames {

constexpr std::uint8_t request_kind = 0x10;
constexpr std::uint8_t response_kind = 0x11;
constexpr std::uint8_t format_version = 1;
constexpr std::size_t size_prefix = 4;
constexpr std::size_t header_size = 16;
/// Bytes in front of the flat request in a complete request frame.
constexpr std::size_t request_overhead = size_prefix + header_size;
/// Longest failure text a response carries (longer texts are cut).
constexpr std::size_t max_text_size = 4096;

/// Largest payload a side accepts for service data of `max_data_size`.
std::size_t max_payload_for(std::size_t max_data_size);

/// One received frame's payload (without the size prefix), in memory of its
/// own: flat data inside may be used in place for as long as it lives.
class Payload {
 public:
  Payload() = default;
  /// Uninitialised bytes; false if memory is short.
  bool allocate(std::size_t size);
  /// Resizes keeping the contents (the rest uninitialised); false if
  /// memory is short (then nothing changed).
  bool grow(std::size_t size);
  char* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

 private:
  struct Free {
    void operator()(char* p) const { std::free(p); }
  };
  std::unique_ptr<char[], Free> data_;
  std::size_t size_ = 0;
};

/// Memory for outgoing frames, reused from call to call. Not zero-filled
/// (a 16 MiB request would pay a memset for nothing); a buffer that grew
/// for a large call shrinks again with the next small one.
class FrameBuffer {
 public:
  /// Makes size() == `size`; the contents are unspecified afterwards.
  bool resize(std::size_t size);
  char* data() const { return data_.get(); }
  std::size_t size() const { return size_; }

 private:
  struct Free {
    void operator()(char* p) const { std::free(p); }
  };
  std::unique_ptr<char[], Free> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

struct RequestHead {
  std::uint32_t service_id = 0;
  std::uint32_t request_id = 0;
  std::uint32_t client_id = 0;
};

struct ResponseHead {
  std::uint32_t request_id = 0;
  std::int32_t result = 0;
};

/// Writes size prefix and header of a request frame; the flat request of
/// `body_size` bytes goes to out + request_overhead.
void write_request_head(char* out, const RequestHead& head, std::size_t body_size);

/// Bytes in front of the flat response in a response frame with `text`
/// (cut to max_text_size).
std::size_t response_overhead(std::string_view text);
/// Writes size prefix, header and text of a response frame; the flat
/// response of `body_size` bytes goes to out + response_overhead(text).
void write_response_head(char* out, const ResponseHead& head, std::string_view text, std::size_t body_size);

/// Checks a request payload; the flat request is payload.data() +
/// header_size, payload.size() - header_size bytes.
Status parse_request(const Payload& payload, RequestHead& head);
/// Checks a response payload; the flat response is body_offset.. end.
Status parse_response(const Payload& payload, ResponseHead& head, std::string_view& text, std::size_t& body_offset);

/// Cuts a byte stream into payloads. Small frames are gathered in a
/// scratch buffer; a large one is received straight into its own payload
/// memory, so big requests are not copied on the way in.
class FrameAssembler {
 public:
  explicit FrameAssembler(std::size_t max_payload);

  /// Where the next received bytes go; `capacity` >= 1. Never more than
  /// the rest of a large frame, so no bytes of the next frame land there.
  char* space(std::size_t& capacity);
  /// `n` bytes arrived in space(). Fails (and the stream is unusable) when
  /// a frame announces more than max_payload or memory is short.
  Status commit(std::size_t n);
  /// Takes the next complete payload, if any.
  bool next(Payload& out);
  /// Whether part of a frame has arrived but not all of it.
  bool in_frame() const { return large_active_ || end_ > begin_; }
  /// Whether next() has a payload to give.
  bool has_ready() const { return !ready_.empty(); }

 private:
  Status split_scratch();

  static constexpr std::size_t scratch_capacity = 64 * 1024;
  /// First allocation for a large frame; it doubles as the frame arrives.
  static constexpr std::size_t large_start = 4 * 1024 * 1024;
  std::size_t max_payload_;
  std::unique_ptr<char[]> scratch_;
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
  Payload large_;
  std::size_t large_filled_ = 0;
  std::size_t large_total_ = 0;  // the announced size large_ grows to
  bool large_active_ = false;
  std::deque<Payload> ready_;
};

}  // namespace ln::services::frames
