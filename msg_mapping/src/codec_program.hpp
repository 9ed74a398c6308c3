// The compiled form of a codec (CodecProgram: one op list per ROS type) and
// the cursors both directions run it with. Internal to msg_mapping:
// codec_compiler.cpp builds programs, codec_ln_to_cdr.cpp and
// codec_cdr_to_ln.cpp run them.
#ifndef MSG_MAPPING_CODEC_PROGRAM_HPP
#define MSG_MAPPING_CODEC_PROGRAM_HPP

#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "msg_mapping/codec.hpp"

namespace msg_mapping {

static_assert(
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
    "LN flat bytes are host order and the CDR we write is little-endian: big-endian hosts need byte swapping");

namespace codec_detail {

enum class OpCode : std::uint8_t {
  Copy,            // CDR-align, then `size` bytes identical on both sides
  Bool,            // like Copy, but LN -> CDR writes each byte as 0/1
  Zero,            // rosidl's dummy member: one zero CDR byte, nothing in LN
  String,          // LN uint32 n + n bytes      <-> CDR string
  InlineString,    // LN uint32 n + char[count]  <-> CDR string
  Sequence,        // LN uint32 n + n elements   <-> CDR uint32 n + elements
  InlineSequence,  // LN uint32 n + count elements (n used) <-> CDR sequence
  Repeat,          // `count` elements of `routine` (fixed arrays of structs)
  Opaque,          // LN T* (recursive) <-> CDR uint8[] holding its LN flat bytes
};

struct Op {
  OpCode code = OpCode::Copy;
  std::uint8_t align = 1;     // CDR alignment of the (element) data
  bool runtime_align = true;  // Copy/Bool: align at run time, else `pad` static bytes
  std::uint8_t pad = 0;
  // Sequences of 2/4/8-byte numbers: Fast DDS's size estimate aligns their
  // element block even when it is empty (see Writer).
  bool align_empty = false;
  std::uint32_t size = 0;          // Copy/Bool: bytes; memcpy-able elements: element bytes
  std::uint32_t count = 0;         // Repeat: N; InlineString/InlineSequence: LN capacity
  std::uint32_t bound = 0;         // ROS bound of a string / sequence (0: none)
  std::int32_t routine = -1;       // element routine; -1: memcpy-able elements
  std::uint32_t elem_ln_size = 0;  // InlineSequence: LN bytes per element (to skip/zero unused capacity)
  std::uint32_t field = 0;         // index into CodecProgram::names
};

struct Routine {
  std::string name;  // ROS type name, for error messages
  std::vector<Op> ops;
  bool fixed = false;        // the LN size is independent of the data (a topic packet)
  std::size_t fixed_ln = 0;  // valid when `fixed`
  std::size_t min_ln = 0;    // lower bounds, used to reject impossible counts early
  std::size_t min_cdr = 0;
};

inline std::string u(std::size_t v) { return std::to_string(v); }

}  // namespace codec_detail

struct CodecProgram {
  std::string ros_name, ln_name;
  std::vector<codec_detail::Routine> routines;  // routines[0] is the top-level type
  std::vector<std::string> names;
  std::size_t fixed_ln_size = 0, fixed_cdr_size = 0;
  std::size_t trailing_zeros = 0;  // written after the message (see fastdds_plain)
};

namespace codec_detail {

// Adds the CDR bytes of `routine` starting at `pos` when they do not depend
// on the data; false otherwise.
bool cdr_is_fixed(const CodecProgram& p, int routine, std::size_t& pos);

// ------------------------------------------------------------------ cursors

struct Fail {
  [[noreturn]] static void truncated(std::size_t need, std::size_t left) {
    throw CodecError("input truncated: needs " + u(need) + " more byte(s), " + u(left) + " left");
  }
};

// Reads LN flat bytes (no alignment) or a CDR body (aligned relative to its start).
class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t left() const { return size_ - pos_; }
  std::size_t pos() const { return pos_; }
  const std::uint8_t* here() const { return data_ + pos_; }

  void need(std::size_t n) const {
    if (n > size_ - pos_) Fail::truncated(n, size_ - pos_);
  }
  const std::uint8_t* take(std::size_t n) {
    need(n);
    const std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  void align(std::size_t a) { take((a - pos_ % a) % a); }
  std::uint32_t u32() {
    std::uint32_t v;
    std::memcpy(&v, take(4), 4);
    return v;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// Fast DDS writes no alignment before the elements of an empty sequence of
// 2/4/8-byte numbers, but its size estimate (which rmw_fastrtps uses as the
// message length) counts that alignment. Sinks therefore track the estimate
// next to the real position; the difference ends the message as zero padding.

// Writes into a caller's buffer, checking its capacity on every write.
class Writer {
 public:
  Writer(std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::size_t pos() const { return pos_; }
  std::size_t estimate() const { return est_; }
  void put(const std::uint8_t* src, std::size_t n) {
    std::uint8_t* p = reserve(n);
    if (n) std::memcpy(p, src, n);
    est_ += n;
  }
  void zero(std::size_t n) {
    std::uint8_t* p = reserve(n);
    if (n) std::memset(p, 0, n);
    est_ += n;
  }
  void u32(std::uint32_t v) {
    std::memcpy(reserve(4), &v, 4);
    est_ += 4;
  }
  void align(std::size_t a) {
    const std::size_t pad = (a - pos_ % a) % a;
    std::uint8_t* p = reserve(pad);
    if (pad) std::memset(p, 0, pad);
    align_estimate(a);
  }
  void align_estimate(std::size_t a) { est_ += (a - est_ % a) % a; }

 private:
  std::uint8_t* reserve(std::size_t n) {
    if (n > size_ - pos_)
      throw CodecError("output buffer too small: needs " + u(n) + " more byte(s), " + u(size_ - pos_) + " left");
    std::uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }

  std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0, est_ = 0;
};

// Counts what a Writer would write (the size pass).
class Counter {
 public:
  std::size_t pos() const { return pos_; }
  std::size_t estimate() const { return est_; }
  void put(const std::uint8_t*, std::size_t n) { advance(n); }
  void zero(std::size_t n) { advance(n); }
  void u32(std::uint32_t) { advance(4); }
  void align(std::size_t a) {
    pos_ += (a - pos_ % a) % a;
    align_estimate(a);
  }
  void align_estimate(std::size_t a) { est_ += (a - est_ % a) % a; }

 private:
  void advance(std::size_t n) {
    pos_ += n;
    est_ += n;
  }
  std::size_t pos_ = 0, est_ = 0;
};

// The CDR padding before a Copy or Bool element: aligned at run time, or the compiler's static
// count of bytes (skipped when decoding, written as zeros when encoding).
inline void skip_cdr_padding(Reader& cdr, const Op& op) {
  if (op.runtime_align)
    cdr.align(op.align);
  else
    cdr.take(op.pad);
}

template <class CdrOut>
void put_cdr_padding(CdrOut& cdr, const Op& op) {
  if (op.runtime_align)
    cdr.align(op.align);
  else
    cdr.zero(op.pad);
}

inline constexpr int max_depth = 64;  // nesting of recursive (opaque) LN data

// Prefixes the field path to an error on its way out (only paid when failing).
[[noreturn]] inline void rethrow_in(const std::string& where, const CodecError& e) {
  if (where.empty()) throw e;
  throw CodecError(where + ": " + e.what());
}

// Runs `element()` n times (the elements of an array or sequence); a failure names the element.
template <class Element>
void for_each_element(std::uint32_t n, Element&& element) {
  for (std::uint32_t i = 0; i < n; ++i) {
    try {
      element();
    } catch (const CodecError& e) {
      rethrow_in("[" + u(i) + "]", e);
    }
  }
}

// Runs `step` for each op of a routine; a failure names the field it failed in.
template <class Step>
void for_each_op(const CodecProgram& p, int routine, Step&& step) {
  for (const Op& op : p.routines[routine].ops) {
    try {
      step(op);
    } catch (const CodecError& e) {
      rethrow_in(p.names[op.field], e);
    }
  }
}

// Reads `n` LN flat elements of `routine` from `in` (checking them as LN ->
// CDR does); CDR -> LN uses it for the LN bytes an opaque field carries.
void walk_ln_elements(const CodecProgram& p, Reader& in, int routine, std::uint32_t n);

}  // namespace codec_detail
}  // namespace msg_mapping

#endif  // MSG_MAPPING_CODEC_PROGRAM_HPP
