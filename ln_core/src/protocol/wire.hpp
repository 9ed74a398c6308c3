// The framing and encoding of every message between clients and the
// manager (and between clients, for set-up). Deliberately small and strict:
// a peer that sends anything malformed gets a ProtocolError and is
// disconnected; nothing a peer sends is ever evaluated.
//
// Frame:   u32 payload_size (little endian) | payload
// Payload: u8 kind | u32 id | u16 field_count | field*
// Field:   u8 key_size | key (ASCII, 1..64) | u8 type | value
//   type 1 int64   8 bytes little endian
//   type 2 double  8 bytes IEEE-754 little endian
//   type 3 bool    1 byte, 0 or 1
//   type 4 string  u32 size | bytes (any bytes; UTF-8 by convention)
//   type 5 list    u32 count | (u32 size | bytes)*   (a list of strings)
// Keys are unique within a message. The method name travels as the string
// field "method" in requests and notifications.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace ln::protocol {

/// Frames larger than this are refused before anything is allocated.
constexpr std::size_t max_frame_size = 64u * 1024 * 1024;

class ProtocolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Kind : std::uint8_t {
  Request = 1,       ///< expects exactly one Response with the same id
  Response = 2,      ///< answers the Request with the same id
  Notification = 3,  ///< one-way; id is 0
};

using StringList = std::vector<std::string>;
using Value = std::variant<std::int64_t, double, bool, std::string, StringList>;

class Message {
 public:
  Message() = default;
  Message(Kind kind, std::uint32_t id) : kind_(kind), id_(id) {}
  /// A request or notification for `method`.
  static Message request(std::uint32_t id, std::string_view method);
  static Message notification(std::string_view method);
  /// A successful response to `request`.
  static Message response_to(const Message& request);
  /// A failed response: `error_code` is a positive LNE_* value, `text`
  /// the human-readable reason shown to the user.
  static Message error_response_to(const Message& request, int error_code, std::string_view text);

  Kind kind() const { return kind_; }
  std::uint32_t id() const { return id_; }
  /// "" for responses.
  std::string method() const;
  bool is_error() const;
  int error_code() const;
  std::string error_text() const;

  Message& set(std::string_view key, std::int64_t value);
  Message& set(std::string_view key, int value) { return set(key, static_cast<std::int64_t>(value)); }
  Message& set(std::string_view key, unsigned value) { return set(key, static_cast<std::int64_t>(value)); }
  Message& set(std::string_view key, double value);
  Message& set(std::string_view key, bool value);
  Message& set(std::string_view key, std::string value);
  Message& set(std::string_view key, const char* value) { return set(key, std::string(value)); }
  Message& set(std::string_view key, StringList value);

  bool has(std::string_view key) const;
  /// Typed access; a missing key or another type throws ProtocolError
  /// naming the key, so handlers can validate by simply reading.
  std::int64_t get_int(std::string_view key) const;
  /// get_int checked to lie within [min, max].
  std::int64_t get_int(std::string_view key, std::int64_t min, std::int64_t max) const;
  double get_double(std::string_view key) const;
  bool get_bool(std::string_view key) const;
  const std::string& get_string(std::string_view key) const;
  const StringList& get_list(std::string_view key) const;

  std::int64_t get_int_or(std::string_view key, std::int64_t fallback) const;
  double get_double_or(std::string_view key, double fallback) const;
  bool get_bool_or(std::string_view key, bool fallback) const;
  std::string get_string_or(std::string_view key, std::string fallback) const;

  const std::map<std::string, Value, std::less<>>& fields() const { return fields_; }

 private:
  const Value& require(std::string_view key) const;

  Kind kind_ = Kind::Notification;
  std::uint32_t id_ = 0;
  std::map<std::string, Value, std::less<>> fields_;
};

/// The complete frame (size prefix included) for `message`.
std::string encode(const Message& message);
/// Decodes one payload (without the size prefix). Throws ProtocolError.
Message decode_payload(std::string_view payload);

/// Reassembles frames from a byte stream that arrives in arbitrary pieces.
class FrameReader {
 public:
  /// Adds received bytes. Throws ProtocolError as soon as a frame header
  /// announces more than max_frame_size.
  void append(const char* data, std::size_t size);
  /// The next complete message, if one has fully arrived. Throws
  /// ProtocolError on a malformed payload.
  std::optional<Message> next();
  /// Bytes received but not yet returned as messages.
  std::size_t buffered() const { return buffer_.size() - consumed_; }
  /// Gives the buffer's memory back once nothing is buffered (after a large
  /// message, the buffer would otherwise keep its size).
  void release_memory();

 private:
  void check_announced_size() const;

  std::string buffer_;
  std::size_t consumed_ = 0;
};

}  // namespace ln::protocol
