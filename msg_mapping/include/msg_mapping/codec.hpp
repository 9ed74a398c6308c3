// LN bytes <-> ROS 2 CDR for one paired type, at memcpy speed for arrays.
//
// ---------------------------------------------------------------------------
// The LN side: "LN flat" bytes
// ---------------------------------------------------------------------------
// One byte format covers topic packets and service requests/responses (and
// event data). The bridge and ln_core's service implementation exchange
// exactly these bytes (ln_spec.md §6.5, made precise here):
//
//   flat(struct)   = flat(field) for each field in model order (ln::md::Definition
//                    field order, i.e. after LN moved/inserted the X_len companions),
//                    except that a dynamic field's companion X_len is NOT written
//                    at its own position (see below)
//   flat(field)    = count x flat(element)               scalar (count 1) or T x[N]
//                  | uint32 n, then n x flat(element)     dynamic field T* x, n = X_len
//   flat(element)  = the primitive's bytes                int/float types
//                  | flat(struct)                         sub-types, recursively
//
//   * little-endian (LN uses host order; every supported host is little-endian),
//     packed: no padding or alignment anywhere;
//   * a dynamic field's element count is always written as uint32 right before
//     its elements, whatever integer type its X_len companion was declared with
//     (LN 2.9 itself ships `uint64_t data_len` and `int data_len`). In the usual
//     layout (uint32_t X_len right before X) this is byte-for-byte the field
//     order of the generated C struct with each pointer replaced by its data;
//   * `char* s` is n bytes of text, no terminating NUL;
//   * a definition without dynamic fields (every LN topic) is exactly its LN
//     packet (ln::md::packet_size bytes).
//
// ---------------------------------------------------------------------------
// The ROS side: CDR
// ---------------------------------------------------------------------------
// XCDR1 little-endian with the 4-byte encapsulation header 00 01 00 00, as
// rclpy.serialization.serialize_message produces (ros2_wire_and_rosidl.md C.5):
// primitives aligned to their size relative to the byte after the header,
// strings as uint32 length including the NUL, then bytes and NUL; sequences as
// uint32 count then elements. Padding is written as zeros (rclpy leaves it
// uninitialized, so only padding bytes may differ from rclpy's output). The
// length matches rmw_fastrtps too: an empty sequence of 2/4/8-byte numbers gets
// no alignment but its size estimate counts it (trailing zeros), and "plain"
// fixed-layout types are rounded up to 4 bytes.
//
// ---------------------------------------------------------------------------
// Errors
// ---------------------------------------------------------------------------
// Malformed input (truncated, impossible lengths, counts beyond an LN capacity
// or a ROS bound, strings without NUL, output buffer too small) throws
// CodecError naming the type and field path. Nothing is ever read or written
// outside the given buffers, and nothing is silently truncated.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "msg_mapping/mapping.hpp"

namespace msg_mapping {

class CodecError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bytes of the CDR encapsulation header (00 01 00 00: CDR, little-endian).
constexpr std::size_t cdr_header_size = 4;

struct Bytes {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};
struct MutableBytes {
  std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

struct CodecProgram;  // the compiled op lists (src/codec_program.hpp)

/// The conversion program for one paired type, compiled once from the
/// mapping: a flat list of copy/convert ops per struct in which runs of
/// fields with identical LN and CDR layout (no padding) are merged into one
/// memcpy and arrays of such structs are copied as one block.
class Codec {
 public:
  explicit Codec(const PairedType& type);
  ~Codec();
  Codec(Codec&&) noexcept;
  Codec& operator=(Codec&&) noexcept;

  const std::string& ros_name() const;
  const std::string& ln_name() const;

  /// LN flat size when every message of this type has the same size (no
  /// dynamic fields), else 0.
  std::size_t fixed_ln_size() const;
  /// CDR size (header included) when it does not depend on the data, else 0.
  std::size_t fixed_cdr_size() const;

  /// Exact CDR size (header included) of the conversion of `ln`; validates `ln`.
  std::size_t cdr_size(Bytes ln) const;
  /// Converts LN flat bytes to CDR into `out`; returns the bytes written.
  /// `ln` must be exactly one message (trailing bytes are an error).
  std::size_t ln_to_cdr(Bytes ln, MutableBytes out) const;
  std::vector<std::uint8_t> ln_to_cdr(Bytes ln) const;

  /// Exact LN flat size of the conversion of `cdr`; validates `cdr`.
  std::size_t ln_size(Bytes cdr) const;
  /// Converts CDR (with header) to LN flat bytes into `out`; returns the bytes
  /// written. Trailing bytes after the message are allowed (DDS pads samples
  /// to 4 bytes).
  std::size_t cdr_to_ln(Bytes cdr, MutableBytes out) const;
  std::vector<std::uint8_t> cdr_to_ln(Bytes cdr) const;

  /// Human-readable listing of the compiled ops (tests, debugging).
  std::string describe() const;

 private:
  std::unique_ptr<CodecProgram> program_;
};

}  // namespace msg_mapping
