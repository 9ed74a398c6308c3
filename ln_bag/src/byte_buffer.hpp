// A growable byte buffer that does not zero what it adds (a 1 MiB message is
// written once, by the codec, not cleared first), with little-endian appends.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <utility>

namespace ln_bag {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP and LN packets are written in host order");

class ByteBuffer {
 public:
  ByteBuffer() = default;
  ByteBuffer(ByteBuffer&& other) noexcept { *this = std::move(other); }
  ByteBuffer& operator=(ByteBuffer&& other) noexcept {
    if (this != &other) {
      data_ = std::move(other.data_);
      size_ = other.size_;
      capacity_ = other.capacity_;
      other.size_ = other.capacity_ = 0;
    }
    return *this;
  }
  ByteBuffer(const ByteBuffer&) = delete;
  ByteBuffer& operator=(const ByteBuffer&) = delete;

  std::uint8_t* data() { return data_.get(); }
  const std::uint8_t* data() const { return data_.get(); }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  void clear() { size_ = 0; }
  void truncate(std::size_t size) { size_ = size < size_ ? size : size_; }

  void reserve(std::size_t capacity) {
    if (capacity <= capacity_) return;
    std::size_t grown = capacity_ ? capacity_ : 4096;
    while (grown < capacity) grown *= 2;
    void* p = std::realloc(data_.get(), grown);
    if (!p) throw std::bad_alloc();
    data_.release();
    data_.reset(static_cast<std::uint8_t*>(p));
    capacity_ = grown;
  }
  /// `n` more bytes at the end, uninitialized; returns where they start.
  std::uint8_t* extend(std::size_t n) {
    reserve(size_ + n);
    std::uint8_t* p = data_.get() + size_;
    size_ += n;
    return p;
  }

  void put(const void* bytes, std::size_t n) {
    if (n) std::memcpy(extend(n), bytes, n);
  }
  void u8(std::uint8_t v) { put(&v, 1); }
  void u16(std::uint16_t v) { put(&v, 2); }
  void u32(std::uint32_t v) { put(&v, 4); }
  void u64(std::uint64_t v) { put(&v, 8); }
  /// MCAP string: uint32 length, then the bytes.
  void str(const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size()));
    put(s.data(), s.size());
  }

 private:
  struct Free {
    void operator()(std::uint8_t* p) const { std::free(p); }
  };
  std::unique_ptr<std::uint8_t, Free> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

template <class T>
inline void store_le(std::uint8_t* at, T value) {
  std::memcpy(at, &value, sizeof value);
}

}  // namespace ln_bag
