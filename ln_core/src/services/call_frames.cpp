#include "services/call_frames.hpp"

#include <algorithm>
#include <cstring>
#include <string>

#define NO_CPP_WRAPPER
#include "ln/ln.h"
#include "services/byte_order.hpp"

namespace ln::services::frames {
namespace {

Status malformed(const std::string& what) {
  return Status::failure(LNE_GOT_INVALID_RESPONSE, "malformed service frame: " + what);
}

Status check_header(const Payload& payload, std::uint8_t kind) {
  if (payload.size() < header_size) return malformed("shorter than its header");
  const auto* p = reinterpret_cast<const unsigned char*>(payload.data());
  if (p[0] != kind) return malformed("unexpected frame kind " + std::to_string(p[0]));
  if (p[1] != format_version) return malformed("unsupported format version " + std::to_string(p[1]));
  return {};
}

void write_prefix_and_kind(char* out, std::uint8_t kind, std::size_t payload_size) {
  store_le32(out, static_cast<std::uint32_t>(payload_size));
  out[size_prefix] = static_cast<char>(kind);
  out[size_prefix + 1] = static_cast<char>(format_version);
  out[size_prefix + 2] = 0;
  out[size_prefix + 3] = 0;
}

}  // namespace

std::size_t max_payload_for(std::size_t max_data_size) {
  const std::size_t overhead = header_size + max_text_size;
  const std::size_t limit = UINT32_MAX - overhead;  // the size prefix is 32 bits
  return std::min(max_data_size, limit) + overhead;
}

bool Payload::allocate(std::size_t size) {
  data_.reset(static_cast<char*>(std::malloc(size == 0 ? 1 : size)));
  size_ = data_ ? size : 0;
  return data_ != nullptr;
}

bool Payload::grow(std::size_t size) {
  char* grown = static_cast<char*>(std::realloc(data_.get(), size == 0 ? 1 : size));
  if (grown == nullptr) return false;
  (void)data_.release();
  data_.reset(grown);
  size_ = size;
  return true;
}

bool FrameBuffer::resize(std::size_t size) {
  constexpr std::size_t keep_below = std::size_t{1} << 20;
  if (size > capacity_ || (capacity_ > keep_below && size < capacity_ / 4)) {
    data_.reset(static_cast<char*>(std::malloc(size == 0 ? 1 : size)));
    capacity_ = data_ ? size : 0;
    if (!data_) {
      size_ = 0;
      return false;
    }
  }
  size_ = size;
  return true;
}

void write_request_head(char* out, const RequestHead& head, std::size_t body_size) {
  write_prefix_and_kind(out, request_kind, header_size + body_size);
  store_le32(out + size_prefix + 4, head.service_id);
  store_le32(out + size_prefix + 8, head.request_id);
  store_le32(out + size_prefix + 12, head.client_id);
}

std::size_t response_overhead(std::string_view text) {
  return size_prefix + header_size + std::min(text.size(), max_text_size);
}

void write_response_head(char* out, const ResponseHead& head, std::string_view text, std::size_t body_size) {
  const std::size_t text_size = std::min(text.size(), max_text_size);
  write_prefix_and_kind(out, response_kind, header_size + text_size + body_size);
  store_le32(out + size_prefix + 4, head.request_id);
  store_le32(out + size_prefix + 8, static_cast<std::uint32_t>(head.result));
  store_le32(out + size_prefix + 12, static_cast<std::uint32_t>(text_size));
  if (text_size > 0) std::memcpy(out + size_prefix + header_size, text.data(), text_size);
}

Status parse_request(const Payload& payload, RequestHead& head) {
  Status s = check_header(payload, request_kind);
  if (!s.ok()) return s;
  head.service_id = load_le32(payload.data() + 4);
  head.request_id = load_le32(payload.data() + 8);
  head.client_id = load_le32(payload.data() + 12);
  return {};
}

Status parse_response(const Payload& payload, ResponseHead& head, std::string_view& text, std::size_t& body_offset) {
  Status s = check_header(payload, response_kind);
  if (!s.ok()) return s;
  head.request_id = load_le32(payload.data() + 4);
  head.result = static_cast<std::int32_t>(load_le32(payload.data() + 8));
  const std::size_t text_size = load_le32(payload.data() + 12);
  if (text_size > payload.size() - header_size) return malformed("text longer than the frame");
  text = std::string_view(payload.data() + header_size, text_size);
  body_offset = header_size + text_size;
  if (head.result != 0 && body_offset != payload.size()) return malformed("data in a failed response");
  return {};
}

FrameAssembler::FrameAssembler(std::size_t max_payload)
    : max_payload_(max_payload), scratch_(new char[scratch_capacity]) {}

char* FrameAssembler::space(std::size_t& capacity) {
  if (large_active_) {
    capacity = large_.size() - large_filled_;
    return large_.data() + large_filled_;
  }
  if (begin_ > 0 && scratch_capacity - end_ < scratch_capacity / 4) {
    std::memmove(scratch_.get(), scratch_.get() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  capacity = scratch_capacity - end_;
  return scratch_.get() + end_;
}

Status FrameAssembler::commit(std::size_t n) {
  if (large_active_) {
    large_filled_ += n;
    if (large_filled_ == large_total_) {
      ready_.push_back(std::move(large_));
      large_active_ = false;
    } else if (large_filled_ == large_.size() && !large_.grow(std::min(2 * large_.size(), large_total_))) {
      return Status::failure(LNE_NO_MEM, "no memory for a service frame of " + std::to_string(large_total_) + " bytes");
    }
    return {};
  }
  end_ += n;
  return split_scratch();
}

Status FrameAssembler::split_scratch() {
  while (end_ - begin_ >= size_prefix) {
    const std::size_t size = load_le32(scratch_.get() + begin_);
    if (size > max_payload_)
      return Status::failure(LNE_PACKET_TOO_LARGE, "peer announced a service frame of " + std::to_string(size) +
                                                       " bytes; the limit is " + std::to_string(max_payload_));
    const std::size_t available = end_ - begin_ - size_prefix;
    const char* payload_start = scratch_.get() + begin_ + size_prefix;
    if (available >= size) {
      Payload payload;
      if (!payload.allocate(size)) return Status::failure(LNE_NO_MEM, "no memory for a service frame");
      if (size > 0) std::memcpy(payload.data(), payload_start, size);
      ready_.push_back(std::move(payload));
      begin_ += size_prefix + size;
      continue;
    }
    if (size_prefix + size > scratch_capacity) {
      // Too big for the scratch buffer: receive the rest in place, in
      // memory that grows with what arrives (what a peer announces is only
      // a claim: 256 MiB announced and never sent must not cost 256 MiB).
      if (!large_.allocate(std::min(size, large_start)))
        return Status::failure(LNE_NO_MEM, "no memory for a service frame of " + std::to_string(size) + " bytes");
      std::memcpy(large_.data(), payload_start, available);
      large_filled_ = available;
      large_total_ = size;
      large_active_ = true;
      begin_ = end_ = 0;
      return {};
    }
    if (begin_ + size_prefix + size > scratch_capacity) {
      std::memmove(scratch_.get(), scratch_.get() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    break;
  }
  if (begin_ == end_) begin_ = end_ = 0;
  return {};
}

bool FrameAssembler::next(Payload& out) {
  if (ready_.empty()) return false;
  out = std::move(ready_.front());
  ready_.pop_front();
  return true;
}

}  // namespace ln::services::frames
