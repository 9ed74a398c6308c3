// LN service signatures compiled into marshalling programs.
//
// A signature (ln_spec.md §2.9) lists the fields of one side of a service in
// struct order, comma separated, each as "<type>[*] <element size> <count>":
//
//   uint32_t 4 1,char* 1 1|[uint32_t 4 1,char* 1 1]* 4 1
//
// <type> is a C primitive name or a bracketed sub-type signature; "[]" (only
// valid behind '*') is the sub-type currently being described, i.e. the
// innermost enclosing bracket or, at top level, the side itself - the way
// LN 2.9 writes self-recursive definitions. '|' separates request and
// response; either side may be empty.
//
// From the signature alone we know the generated host struct exactly
// (ln_spec.md §2.10): packed, fields in signature order, a dynamic field is a
// host pointer, a sub-type is embedded by value. A dynamic field's element
// count lives in an integer companion field (`X_len`). LN 2.9 always places
// it immediately before the pointer, in whatever integer type the author
// declared it (int32_t in ln2/pyobject). We take the integer scalar right
// before the pointer; only if there is none (a signature written by hand
// or by an older generator that put the length after the pointer) the one
// right after it. A companion serves one pointer. Anything else is an
// invalid signature.
//
// The compiled program is what marshal.hpp runs; it is immutable and may be
// shared between threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "services/status.hpp"

namespace ln::services {

constexpr bool host_is_little_endian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

/// One instruction of a struct program. Offsets are into the host struct.
struct Step {
  enum class Kind : std::uint8_t {
    Copy,     ///< `size` bytes of primitives, travelling as they are (modulo byte order)
    Structs,  ///< `size` consecutive sub-structs of program `program`
    Dynamic,  ///< pointer + companion count; elements follow the count on the wire
  };
  Kind kind = Kind::Copy;
  /// Copy and raw Dynamic elements: reverse every `swap_unit` bytes between
  /// host and wire (1 = never; the case for every field on little-endian hosts).
  std::uint8_t swap_unit = 1;
  /// Dynamic with raw elements: the alignment an element address needs for
  /// the host to use received bytes in place.
  std::uint8_t element_align = 1;
  /// Dynamic: type of the companion count field.
  md::Primitive count_type = md::Primitive::UInt32;
  std::uint32_t host_offset = 0;
  /// Dynamic: offset of the companion count field.
  std::uint32_t count_offset = 0;
  /// Copy: bytes. Structs: element count. Dynamic with raw elements: element size.
  std::size_t size = 0;
  /// Structs, and Dynamic with struct elements: index of the element's
  /// program; -1 for Dynamic with raw elements (primitives, or sub-structs
  /// whose bytes travel unchanged).
  std::int32_t program = -1;
};

/// The marshalling program of one struct type.
struct StructProgram {
  std::vector<Step> steps;
  std::size_t host_size = 0;
  /// The fewest bytes one instance can occupy on the wire (bounds counts a
  /// peer announces).
  std::size_t min_wire_size = 0;
  /// No dynamic field anywhere inside: the flat form is exactly host_size
  /// bytes (the host struct itself on little-endian hosts).
  bool fixed = true;
};

/// One side (request or response) of a service, compiled.
class MessageLayout {
 public:
  /// Compiles one side's signature. `swap_bytes` says whether multi-byte
  /// primitives must be byte-reversed between host and the little-endian
  /// wire; the default is right for this host (tests pass `true` on
  /// little-endian machines to exercise the big-endian code paths).
  static Status compile(std::string_view side_signature, MessageLayout& out, bool swap_bytes = !host_is_little_endian);

  /// Size of the generated host struct (0 for an empty side).
  std::size_t host_size() const { return programs_.empty() ? 0 : programs_[0].host_size; }
  bool empty() const { return host_size() == 0; }
  /// No dynamic fields: every flat instance has host_size() bytes.
  bool fixed_size() const { return programs_.empty() || programs_[0].fixed; }
  /// Program 0 is the side itself; sub-types follow.
  const std::vector<StructProgram>& programs() const { return programs_; }

 private:
  std::vector<StructProgram> programs_;
};

/// A complete service signature: "request|response".
class ServiceSignature {
 public:
  static Status compile(std::string_view signature, ServiceSignature& out, bool swap_bytes = !host_is_little_endian);
  /// Compiled once, shared by handles and requests.
  static Status compile_shared(std::string_view signature, std::shared_ptr<const ServiceSignature>& out);

  const std::string& text() const { return text_; }
  const MessageLayout& request() const { return request_; }
  const MessageLayout& response() const { return response_; }
  /// Where `resp` lies in the generated service struct: right after `req`
  /// (which is absent, size 0, when the request is empty).
  std::size_t response_offset() const { return request_.host_size(); }

 private:
  std::string text_;
  MessageLayout request_;
  MessageLayout response_;
};

/// The check behind ln_service_request_set_data(): LN compares the
/// signature given by the handler with the registered one as plain strings
/// (a mismatch is LNE_SVC_REQ_SET_DATA_WRONG).
bool same_signature(std::string_view registered, const char* given);

}  // namespace ln::services
