#include "protocol/wire.hpp"

#include <cstring>

namespace ln::protocol {
namespace {

enum class Type : std::uint8_t { Int = 1, Double = 2, Bool = 3, String = 4, List = 5 };

constexpr std::size_t max_key_size = 64;
constexpr std::size_t header_size = 1 + 4 + 2;

void put_u8(std::string& out, std::uint8_t v) { out.push_back(static_cast<char>(v)); }

void put_u16(std::string& out, std::uint16_t v) {
  for (int i = 0; i < 2; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

void put_u64(std::string& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
}

void put_bytes(std::string& out, std::string_view bytes) {
  if (bytes.size() > max_frame_size) throw ProtocolError("a string field is too large to send");
  put_u32(out, static_cast<std::uint32_t>(bytes.size()));
  out.append(bytes);
}

// Bounds-checked reader over one payload.
class Cursor {
 public:
  explicit Cursor(std::string_view data) : data_(data) {}

  std::uint64_t unsigned_le(std::size_t bytes, const char* what) {
    need(bytes, what);
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < bytes; ++i) v |= std::uint64_t{static_cast<unsigned char>(data_[pos_ + i])} << (8 * i);
    pos_ += bytes;
    return v;
  }
  std::string_view bytes(std::size_t n, const char* what) {
    need(n, what);
    auto v = data_.substr(pos_, n);
    pos_ += n;
    return v;
  }
  std::string_view sized_bytes(const char* what) {
    const auto n = static_cast<std::size_t>(unsigned_le(4, what));
    return bytes(n, what);
  }
  bool at_end() const { return pos_ == data_.size(); }
  std::size_t remaining() const { return data_.size() - pos_; }

 private:
  void need(std::size_t n, const char* what) const {
    if (n > data_.size() - pos_) throw ProtocolError(std::string("truncated message (") + what + ")");
  }
  std::string_view data_;
  std::size_t pos_ = 0;
};

const char* type_name(const Value& v) {
  switch (v.index()) {
    case 0:
      return "an integer";
    case 1:
      return "a number";
    case 2:
      return "a boolean";
    case 3:
      return "a string";
    default:
      return "a list";
  }
}

template <typename T>
const T& typed(const Value& v, std::string_view key, const char* expected) {
  if (const T* p = std::get_if<T>(&v)) return *p;
  throw ProtocolError("field '" + std::string(key) + "' is " + type_name(v) + ", expected " + expected);
}

}  // namespace

Message Message::request(std::uint32_t id, std::string_view method) {
  Message m(Kind::Request, id);
  m.set("method", std::string(method));
  return m;
}

Message Message::notification(std::string_view method) {
  Message m(Kind::Notification, 0);
  m.set("method", std::string(method));
  return m;
}

Message Message::response_to(const Message& request) { return Message(Kind::Response, request.id()); }

Message Message::error_response_to(const Message& request, int error_code, std::string_view text) {
  Message m(Kind::Response, request.id());
  m.set("error_code", error_code);
  m.set("error", std::string(text));
  return m;
}

std::string Message::method() const { return get_string_or("method", ""); }
bool Message::is_error() const { return has("error_code"); }
int Message::error_code() const { return static_cast<int>(get_int_or("error_code", 0)); }
std::string Message::error_text() const { return get_string_or("error", ""); }

Message& Message::set(std::string_view key, std::int64_t value) {
  fields_[std::string(key)] = value;
  return *this;
}
Message& Message::set(std::string_view key, double value) {
  fields_[std::string(key)] = value;
  return *this;
}
Message& Message::set(std::string_view key, bool value) {
  fields_[std::string(key)] = value;
  return *this;
}
Message& Message::set(std::string_view key, std::string value) {
  fields_[std::string(key)] = std::move(value);
  return *this;
}
Message& Message::set(std::string_view key, StringList value) {
  fields_[std::string(key)] = std::move(value);
  return *this;
}

bool Message::has(std::string_view key) const { return fields_.find(key) != fields_.end(); }

const Value& Message::require(std::string_view key) const {
  const auto it = fields_.find(key);
  if (it == fields_.end()) throw ProtocolError("missing field '" + std::string(key) + "'");
  return it->second;
}

std::int64_t Message::get_int(std::string_view key) const {
  return typed<std::int64_t>(require(key), key, "an integer");
}

std::int64_t Message::get_int(std::string_view key, std::int64_t min, std::int64_t max) const {
  const std::int64_t v = get_int(key);
  if (v < min || v > max)
    throw ProtocolError("field '" + std::string(key) + "' is " + std::to_string(v) + ", outside " +
                        std::to_string(min) + ".." + std::to_string(max));
  return v;
}

double Message::get_double(std::string_view key) const {
  const Value& v = require(key);
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  return typed<double>(v, key, "a number");
}
bool Message::get_bool(std::string_view key) const { return typed<bool>(require(key), key, "a boolean"); }
const std::string& Message::get_string(std::string_view key) const {
  return typed<std::string>(require(key), key, "a string");
}
const StringList& Message::get_list(std::string_view key) const {
  return typed<StringList>(require(key), key, "a list");
}

std::int64_t Message::get_int_or(std::string_view key, std::int64_t fallback) const {
  return has(key) ? get_int(key) : fallback;
}
double Message::get_double_or(std::string_view key, double fallback) const {
  return has(key) ? get_double(key) : fallback;
}
bool Message::get_bool_or(std::string_view key, bool fallback) const { return has(key) ? get_bool(key) : fallback; }
std::string Message::get_string_or(std::string_view key, std::string fallback) const {
  return has(key) ? get_string(key) : fallback;
}

std::string encode(const Message& message) {
  std::string out(4, '\0');  // size, patched below
  put_u8(out, static_cast<std::uint8_t>(message.kind()));
  put_u32(out, message.id());
  if (message.fields().size() > 0xffff) throw ProtocolError("too many fields in one message");
  put_u16(out, static_cast<std::uint16_t>(message.fields().size()));
  for (const auto& [key, value] : message.fields()) {
    if (key.empty() || key.size() > max_key_size) throw ProtocolError("invalid field name '" + key + "'");
    put_u8(out, static_cast<std::uint8_t>(key.size()));
    out += key;
    if (const auto* i = std::get_if<std::int64_t>(&value)) {
      put_u8(out, static_cast<std::uint8_t>(Type::Int));
      put_u64(out, static_cast<std::uint64_t>(*i));
    } else if (const auto* d = std::get_if<double>(&value)) {
      put_u8(out, static_cast<std::uint8_t>(Type::Double));
      std::uint64_t bits;
      std::memcpy(&bits, d, sizeof bits);
      put_u64(out, bits);
    } else if (const auto* b = std::get_if<bool>(&value)) {
      put_u8(out, static_cast<std::uint8_t>(Type::Bool));
      put_u8(out, *b ? 1 : 0);
    } else if (const auto* s = std::get_if<std::string>(&value)) {
      put_u8(out, static_cast<std::uint8_t>(Type::String));
      put_bytes(out, *s);
    } else {
      const auto& list = std::get<StringList>(value);
      put_u8(out, static_cast<std::uint8_t>(Type::List));
      put_u32(out, static_cast<std::uint32_t>(list.size()));
      for (const auto& item : list) put_bytes(out, item);
    }
  }
  const std::size_t payload = out.size() - 4;
  if (payload > max_frame_size) throw ProtocolError("message too large to send");
  for (int i = 0; i < 4; ++i) out[static_cast<std::size_t>(i)] = static_cast<char>(payload >> (8 * i));
  return out;
}

Message decode_payload(std::string_view payload) {
  if (payload.size() < header_size) throw ProtocolError("truncated message (header)");
  Cursor in(payload);
  const auto kind = static_cast<std::uint8_t>(in.unsigned_le(1, "kind"));
  if (kind < 1 || kind > 3) throw ProtocolError("unknown message kind " + std::to_string(kind));
  Message message(static_cast<Kind>(kind), static_cast<std::uint32_t>(in.unsigned_le(4, "id")));
  const auto count = static_cast<std::size_t>(in.unsigned_le(2, "field count"));
  for (std::size_t i = 0; i < count; ++i) {
    const auto key_size = static_cast<std::size_t>(in.unsigned_le(1, "key size"));
    if (key_size == 0 || key_size > max_key_size) throw ProtocolError("invalid field name size");
    const std::string key(in.bytes(key_size, "key"));
    for (unsigned char c : key)
      if (c < 0x21 || c > 0x7e) throw ProtocolError("field names must be printable ASCII");
    if (message.has(key)) throw ProtocolError("field '" + key + "' appears twice");
    const auto type = static_cast<Type>(in.unsigned_le(1, "type"));
    switch (type) {
      case Type::Int:
        message.set(key, static_cast<std::int64_t>(in.unsigned_le(8, "integer")));
        break;
      case Type::Double: {
        const std::uint64_t bits = in.unsigned_le(8, "number");
        double d;
        std::memcpy(&d, &bits, sizeof d);
        message.set(key, d);
        break;
      }
      case Type::Bool: {
        const auto b = in.unsigned_le(1, "boolean");
        if (b > 1) throw ProtocolError("field '" + key + "': invalid boolean");
        message.set(key, b == 1);
        break;
      }
      case Type::String:
        message.set(key, std::string(in.sized_bytes("string")));
        break;
      case Type::List: {
        const auto n = static_cast<std::size_t>(in.unsigned_le(4, "list size"));
        // Every item needs at least its 4-byte size: refuse counts the
        // payload cannot hold before reserving memory for them.
        if (n > in.remaining() / 4) throw ProtocolError("truncated message (list)");
        StringList list;
        list.reserve(n);
        for (std::size_t k = 0; k < n; ++k) list.emplace_back(in.sized_bytes("list item"));
        message.set(key, std::move(list));
        break;
      }
      default:
        throw ProtocolError("field '" + key + "' has unknown type " + std::to_string(static_cast<int>(type)));
    }
  }
  if (!in.at_end()) throw ProtocolError("trailing bytes after the last field");
  return message;
}

void FrameReader::append(const char* data, std::size_t size) {
  if (consumed_ > 0 && consumed_ == buffer_.size()) {
    buffer_.clear();
    consumed_ = 0;
  }
  buffer_.append(data, size);
  check_announced_size();
}

void FrameReader::check_announced_size() const {
  if (buffered() < 4) return;
  std::uint32_t announced = 0;
  for (int i = 0; i < 4; ++i)
    announced |= std::uint32_t{static_cast<unsigned char>(buffer_[consumed_ + static_cast<std::size_t>(i)])} << (8 * i);
  if (announced > max_frame_size)
    throw ProtocolError("a peer announced a " + std::to_string(announced) + "-byte message; the limit is " +
                        std::to_string(max_frame_size));
}

void FrameReader::release_memory() {
  if (buffered() != 0 || buffer_.capacity() <= 65536) return;
  std::string().swap(buffer_);
  consumed_ = 0;
}

std::optional<Message> FrameReader::next() {
  if (buffered() < 4) return std::nullopt;
  std::uint32_t size = 0;
  for (int i = 0; i < 4; ++i)
    size |= std::uint32_t{static_cast<unsigned char>(buffer_[consumed_ + static_cast<std::size_t>(i)])} << (8 * i);
  if (size > max_frame_size) throw ProtocolError("message too large");
  if (buffered() < 4 + std::size_t{size}) return std::nullopt;
  Message message = decode_payload(std::string_view(buffer_).substr(consumed_ + 4, size));
  consumed_ += 4 + size;
  // Compact once most of the buffer is consumed, so memory stays bounded.
  if (consumed_ > 65536 && consumed_ * 2 > buffer_.size()) {
    buffer_.erase(0, consumed_);
    consumed_ = 0;
  }
  check_announced_size();  // of the following frame, as early as possible
  return message;
}

}  // namespace ln::protocol
