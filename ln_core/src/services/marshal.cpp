#include "services/marshal.hpp"

#include <cstdint>
#include <cstring>
#include <new>
#include <type_traits>

#define NO_CPP_WRAPPER
#include "ln/ln.h"
#include "services/byte_order.hpp"

namespace ln::services {
namespace {

using Programs = std::vector<StructProgram>;
constexpr std::size_t count_size = 4;
// Dynamic arrays copied into an arena start at this alignment.
constexpr std::size_t arena_alignment = 8;

std::uint64_t align_up(std::uint64_t n) { return (n + arena_alignment - 1) & ~std::uint64_t{arena_alignment - 1}; }

// Copies `bytes`, reversing every `unit` bytes (host <-> little endian).
void copy_units(char* dst, const char* src, std::size_t bytes, unsigned unit) {
  if (bytes == 0) return;
  if (unit <= 1) {
    std::memcpy(dst, src, bytes);
    return;
  }
  for (std::size_t i = 0; i < bytes; i += unit)
    for (unsigned b = 0; b < unit; ++b) dst[i + b] = src[i + unit - 1 - b];
}

template <class T>
bool load_count_as(const char* p, std::uint64_t& n) {
  T v;
  std::memcpy(&v, p, sizeof v);
  if constexpr (std::is_signed_v<T>) {
    if (v < 0) return false;
  }
  n = static_cast<std::uint64_t>(v);
  return true;
}

// The companion's value; false if it is negative.
bool load_count(const char* p, md::Primitive type, std::uint64_t& n) {
  switch (type) {
    case md::Primitive::Int8:
      return load_count_as<std::int8_t>(p, n);
    case md::Primitive::UInt8:
      return load_count_as<std::uint8_t>(p, n);
    case md::Primitive::Int16:
      return load_count_as<std::int16_t>(p, n);
    case md::Primitive::UInt16:
      return load_count_as<std::uint16_t>(p, n);
    case md::Primitive::Int32:
      return load_count_as<std::int32_t>(p, n);
    case md::Primitive::UInt32:
      return load_count_as<std::uint32_t>(p, n);
    case md::Primitive::Int64:
      return load_count_as<std::int64_t>(p, n);
    default:
      return load_count_as<std::uint64_t>(p, n);  // the compiler admits integers only
  }
}

template <class T>
void store_count_as(char* p, std::uint64_t n) {
  const T v = static_cast<T>(n);
  std::memcpy(p, &v, sizeof v);
}

void store_count(char* p, md::Primitive type, std::uint64_t n) {
  switch (type) {
    case md::Primitive::Int8:
      return store_count_as<std::int8_t>(p, n);
    case md::Primitive::UInt8:
      return store_count_as<std::uint8_t>(p, n);
    case md::Primitive::Int16:
      return store_count_as<std::int16_t>(p, n);
    case md::Primitive::UInt16:
      return store_count_as<std::uint16_t>(p, n);
    case md::Primitive::Int32:
      return store_count_as<std::int32_t>(p, n);
    case md::Primitive::UInt32:
      return store_count_as<std::uint32_t>(p, n);
    case md::Primitive::Int64:
      return store_count_as<std::int64_t>(p, n);
    default:
      return store_count_as<std::uint64_t>(p, n);
  }
}

bool count_fits(md::Primitive type, std::uint64_t n) {
  const std::size_t bits = 8 * md::size_of(type) - (md::is_signed(type) ? 1 : 0);
  return bits >= 64 || n < (std::uint64_t{1} << bits);
}

const char* load_pointer(const char* p) {
  const char* pointer;
  std::memcpy(&pointer, p, sizeof pointer);
  return pointer;
}

void store_pointer(char* p, const char* pointer) { std::memcpy(p, &pointer, sizeof pointer); }

// Received elements can be used where they lie when they need no byte
// swapping and sit at an address their type may live at.
bool usable_in_place(const char* at, const Step& step) {
  return step.swap_unit == 1 && reinterpret_cast<std::uintptr_t>(at) % step.element_align == 0;
}

Status invalid(const std::string& what) { return Status::failure(LNE_INVALID_PARAMETER, what); }

Status too_large(std::size_t size, const Limits& limits) {
  return Status::failure(LNE_PACKET_TOO_LARGE, std::to_string(size) + " bytes of service data exceed the limit of " +
                                                   std::to_string(limits.max_data_size) + " bytes");
}

std::string field_at(const Step& step) { return "dynamic field at struct offset " + std::to_string(step.host_offset); }

// ------------------------------------------------------------- flattening

class Measurer {
 public:
  Measurer(const Programs& programs, const Limits& limits) : programs_(programs), limits_(limits) {}

  Status measure(int index, const char* host, unsigned depth) {
    if (depth > limits_.max_nesting)
      return invalid("data nested deeper than " + std::to_string(limits_.max_nesting) + " levels (a cycle?)");
    for (const Step& step : programs_[static_cast<std::size_t>(index)].steps) {
      Status s;
      switch (step.kind) {
        case Step::Kind::Copy:
          s = add(step.size);
          break;
        case Step::Kind::Structs:
          s = elements(step.program, host + step.host_offset, step.size, depth);
          break;
        case Step::Kind::Dynamic:
          s = dynamic(step, host, depth);
          break;
      }
      if (!s.ok()) return s;
    }
    return {};
  }

  std::size_t total() const { return total_; }

 private:
  Status dynamic(const Step& step, const char* host, unsigned depth) {
    std::uint64_t n = 0;
    if (!load_count(host + step.count_offset, step.count_type, n)) return invalid(field_at(step) + ": negative length");
    if (n > UINT32_MAX) return invalid(field_at(step) + ": more than 2^32-1 elements");
    const char* elements_at = load_pointer(host + step.host_offset);
    if (n > 0 && elements_at == nullptr)
      return invalid(field_at(step) + ": length " + std::to_string(n) + " but the pointer is NULL");
    Status s = add(count_size);
    if (!s.ok()) return s;
    if (step.program < 0) return add(n * step.size);
    return elements(step.program, elements_at, n, depth);
  }

  Status elements(int index, const char* first, std::uint64_t n, unsigned depth) {
    const StructProgram& sub = programs_[static_cast<std::size_t>(index)];
    if (sub.fixed) return add(n * sub.host_size);
    for (std::uint64_t i = 0; i < n; ++i) {
      Status s = measure(index, first + i * sub.host_size, depth + 1);
      if (!s.ok()) return s;
    }
    return {};
  }

  Status add(std::uint64_t bytes) {
    if (bytes > limits_.max_data_size - total_)
      return Status::failure(LNE_PACKET_TOO_LARGE, "service data larger than the limit of " +
                                                       std::to_string(limits_.max_data_size) + " bytes");
    total_ += static_cast<std::size_t>(bytes);
    return {};
  }

  const Programs& programs_;
  const Limits& limits_;
  std::size_t total_ = 0;
};

class Writer {
 public:
  Writer(const Programs& programs, char* out) : programs_(programs), out_(out) {}

  void write(int index, const char* host) {
    for (const Step& step : programs_[static_cast<std::size_t>(index)].steps) {
      switch (step.kind) {
        case Step::Kind::Copy:
          bytes(host + step.host_offset, step.size, step.swap_unit);
          break;
        case Step::Kind::Structs:
          elements(step.program, host + step.host_offset, step.size);
          break;
        case Step::Kind::Dynamic: {
          std::uint64_t n = 0;
          load_count(host + step.count_offset, step.count_type, n);
          const char* elements_at = load_pointer(host + step.host_offset);
          store_le32(out_, static_cast<std::uint32_t>(n));
          out_ += count_size;
          if (step.program < 0)
            bytes(elements_at, static_cast<std::size_t>(n) * step.size, step.swap_unit);
          else
            elements(step.program, elements_at, n);
          break;
        }
      }
    }
  }

 private:
  void bytes(const char* from, std::size_t size, unsigned unit) {
    copy_units(out_, from, size, unit);
    out_ += size;
  }

  void elements(int index, const char* first, std::uint64_t n) {
    const std::size_t host_size = programs_[static_cast<std::size_t>(index)].host_size;
    for (std::uint64_t i = 0; i < n; ++i) write(index, first + i * host_size);
  }

  const Programs& programs_;
  char* out_;
};

// ----------------------------------------------------------- unflattening

// Pass 1: walks the flat data without writing, validating every count and
// adding up the arena memory the copies will need.
class Checker {
 public:
  Checker(const Programs& programs, const Limits& limits, const char* data, std::size_t size)
      : programs_(programs), limits_(limits), cur_(data), end_(data + size) {}

  Status check_all() {
    Status s = check(0, 0);
    if (s.ok() && cur_ != end_) return invalid(std::to_string(end_ - cur_) + " unexpected bytes after the data");
    return s;
  }

  std::uint64_t arena_size() const { return arena_; }

 private:
  Status check(int index, unsigned depth) {
    if (depth > limits_.max_nesting)
      return invalid("data nested deeper than " + std::to_string(limits_.max_nesting) + " levels");
    for (const Step& step : programs_[static_cast<std::size_t>(index)].steps) {
      Status s;
      switch (step.kind) {
        case Step::Kind::Copy:
          s = skip(step.size);
          break;
        case Step::Kind::Structs:
          s = elements(step.program, step.size, depth);
          break;
        case Step::Kind::Dynamic:
          s = dynamic(step, depth);
          break;
      }
      if (!s.ok()) return s;
    }
    return {};
  }

  Status dynamic(const Step& step, unsigned depth) {
    if (remaining() < count_size) return truncated();
    const std::uint64_t n = load_le32(cur_);
    cur_ += count_size;
    if (!count_fits(step.count_type, n))
      return invalid(field_at(step) + ": " + std::to_string(n) + " elements do not fit its " +
                     std::string(md::c_name(step.count_type)) + " length");
    if (step.program < 0) {
      const std::uint64_t bytes = n * step.size;
      if (bytes > remaining()) return truncated();
      if (!usable_in_place(cur_, step)) arena_ += align_up(bytes);
      cur_ += bytes;
      return {};
    }
    const StructProgram& sub = programs_[static_cast<std::size_t>(step.program)];
    // Cheap rejection of absurd counts before walking them.
    if (n * sub.min_wire_size > remaining()) return truncated();
    arena_ += align_up(n * sub.host_size);
    return elements(step.program, n, depth);
  }

  Status elements(int index, std::uint64_t n, unsigned depth) {
    const StructProgram& sub = programs_[static_cast<std::size_t>(index)];
    if (sub.fixed) return skip(n * sub.host_size);
    for (std::uint64_t i = 0; i < n; ++i) {
      Status s = check(index, depth + 1);
      if (!s.ok()) return s;
    }
    return {};
  }

  Status skip(std::uint64_t bytes) {
    if (bytes > remaining()) return truncated();
    cur_ += bytes;
    return {};
  }

  std::uint64_t remaining() const { return static_cast<std::uint64_t>(end_ - cur_); }
  Status truncated() const { return invalid("data ends early (truncated or corrupt lengths)"); }

  const Programs& programs_;
  const Limits& limits_;
  const char* cur_;
  const char* end_;
  std::uint64_t arena_ = 0;
};

// Pass 2: fills the host struct from data Checker accepted; cannot fail.
class Filler {
 public:
  Filler(const Programs& programs, char* data, char* arena) : programs_(programs), cur_(data), arena_(arena) {}

  void fill(int index, char* host) {
    for (const Step& step : programs_[static_cast<std::size_t>(index)].steps) {
      switch (step.kind) {
        case Step::Kind::Copy:
          copy_units(host + step.host_offset, cur_, step.size, step.swap_unit);
          cur_ += step.size;
          break;
        case Step::Kind::Structs:
          elements(step.program, host + step.host_offset, step.size);
          break;
        case Step::Kind::Dynamic:
          dynamic(step, host);
          break;
      }
    }
  }

 private:
  void dynamic(const Step& step, char* host) {
    const std::uint32_t n = load_le32(cur_);
    cur_ += count_size;
    store_count(host + step.count_offset, step.count_type, n);
    char* elements_at = cur_;  // also what an empty array points at: valid, never read
    if (step.program < 0) {
      const std::size_t bytes = std::size_t{n} * step.size;
      if (!usable_in_place(cur_, step)) {
        elements_at = take(bytes);
        copy_units(elements_at, cur_, bytes, step.swap_unit);
      }
      cur_ += bytes;
    } else if (n > 0) {
      elements_at = take(std::size_t{n} * programs_[static_cast<std::size_t>(step.program)].host_size);
      elements(step.program, elements_at, n);
    }
    store_pointer(host + step.host_offset, elements_at);
  }

  void elements(int index, char* first, std::uint64_t n) {
    const std::size_t host_size = programs_[static_cast<std::size_t>(index)].host_size;
    for (std::uint64_t i = 0; i < n; ++i) fill(index, first + i * host_size);
  }

  char* take(std::size_t bytes) {
    char* p = arena_;
    arena_ += align_up(bytes);
    return p;
  }

  const Programs& programs_;
  char* cur_;
  char* arena_;
};

}  // namespace

char* Arena::allocate(std::size_t size) {
  // malloc'ed memory is aligned for every fundamental type.
  char* block = static_cast<char*>(std::malloc(size == 0 ? 1 : size));
  if (block == nullptr) return nullptr;
  blocks_.emplace_back(block);
  return block;
}

Status flat_size(const MessageLayout& layout, const void* host, const Limits& limits, std::size_t& size) {
  if (layout.empty()) {
    size = 0;
    return {};
  }
  if (layout.fixed_size()) {
    size = layout.host_size();
    if (size > limits.max_data_size)
      return Status::failure(LNE_PACKET_TOO_LARGE, "service data larger than the limit of " +
                                                       std::to_string(limits.max_data_size) + " bytes");
    return {};
  }
  Measurer measurer(layout.programs(), limits);
  Status s = measurer.measure(0, static_cast<const char*>(host), 0);
  if (s.ok()) size = measurer.total();
  return s;
}

void write_flat(const MessageLayout& layout, const void* host, char* out) {
  if (layout.empty()) return;
  Writer(layout.programs(), out).write(0, static_cast<const char*>(host));
}

Status flatten(const MessageLayout& layout, const void* host, const Limits& limits, std::string& out) {
  std::size_t size = 0;
  Status s = flat_size(layout, host, limits, size);
  if (!s.ok()) return s;
  out.resize(size);
  write_flat(layout, host, out.data());
  return {};
}

Status check_flat(const MessageLayout& layout, const char* data, std::size_t size, const Limits& limits) {
  if (size > limits.max_data_size) return too_large(size, limits);
  if (layout.empty()) return size == 0 ? Status() : invalid(std::to_string(size) + " bytes for an empty struct");
  return Checker(layout.programs(), limits, data, size).check_all();
}

Status unflatten(const MessageLayout& layout, char* data, std::size_t size, void* host, const Limits& limits,
                 Arena& arena) {
  if (size > limits.max_data_size) return too_large(size, limits);
  if (layout.empty()) return size == 0 ? Status() : invalid(std::to_string(size) + " bytes for an empty struct");
  Checker checker(layout.programs(), limits, data, size);
  Status s = checker.check_all();
  if (!s.ok()) return s;
  char* arena_block = nullptr;
  if (checker.arena_size() > 0) {
    arena_block = arena.allocate(static_cast<std::size_t>(checker.arena_size()));
    if (arena_block == nullptr)
      return Status::failure(LNE_NO_MEM,
                             "no memory for " + std::to_string(checker.arena_size()) + " bytes of service data");
  }
  Filler(layout.programs(), data, arena_block).fill(0, static_cast<char*>(host));
  return {};
}

}  // namespace ln::services
