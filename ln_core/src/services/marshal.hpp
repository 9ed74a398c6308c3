// Converting service data between the generated host structs and the flat
// form that travels between caller and provider.
//
// The flat form ("LN flat data", owned by ln_core; msg_mapping and language
// bindings produce and consume it too). One side (request or response) of a
// call is one flat struct:
//
//   struct        = its fields in signature order, back to back, no padding
//   primitive     = its bytes in little-endian order (float and double as
//                   IEEE-754 binary32/binary64); a fixed array is its
//                   elements in a row
//   sub-type      = a flat struct (a fixed array of them: that many in a row)
//   dynamic field = u32 element count (little endian), then the elements as
//                   above
//   X_len         = the companion count field of a dynamic field does not
//                   travel on its own: its value is that count
//
// An empty side is zero bytes. A flat struct must use up its buffer exactly.
// Example: request `int32_t a` + `char* s` = "abc" with a = 1 is
// 01 00 00 00 | 03 00 00 00 | 'a' 'b' 'c'.
//
// Big-endian hosts convert every multi-byte primitive; on little-endian
// hosts fixed parts are plain memcpy and large dynamic arrays of bytes (or
// of naturally aligned primitives) are used in place on arrival.
//
// Nothing here trusts its input: flattening checks the counts and pointers
// of the host struct (negative or NULL-backed lengths, cyclic structures via
// the nesting limit, the size limit) before writing a byte; unflattening
// checks every count against the bytes that remain and never reads or
// writes out of bounds, whatever it is given.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "services/signature.hpp"
#include "services/status.hpp"

namespace ln::services {

/// Memory that unflattened dynamic fields point into. Everything handed out
/// stays valid until clear() or destruction.
class Arena {
 public:
  /// A new block of `size` bytes, aligned for any primitive.
  char* allocate(std::size_t size);
  void clear() { blocks_.clear(); }

 private:
  struct Free {
    void operator()(char* p) const { std::free(p); }
  };
  std::vector<std::unique_ptr<char[], Free>> blocks_;
};

/// Validates the data reachable from `host` (a struct laid out as `layout`
/// says) and reports its flat size. Fails with LNE_INVALID_PARAMETER for
/// a negative count, a count > 0 with a NULL pointer, a count beyond
/// 2^32-1 or nesting beyond the limit, and with LNE_PACKET_TOO_LARGE when
/// the flat form would exceed limits.max_data_size.
Status flat_size(const MessageLayout& layout, const void* host, const Limits& limits, std::size_t& size);

/// Writes the flat form of `host` to `out`: exactly the bytes flat_size()
/// reported for the same, unchanged data.
void write_flat(const MessageLayout& layout, const void* host, char* out);

/// flat_size() and write_flat() into a string (for tests and tools).
Status flatten(const MessageLayout& layout, const void* host, const Limits& limits, std::string& out);

/// Checks that `data` holds exactly one well-formed flat struct of `layout`
/// (LNE_INVALID_PARAMETER with the reason otherwise). Reads only.
Status check_flat(const MessageLayout& layout, const char* data, std::size_t size, const Limits& limits);

/// Fills `host` from flat data. Dynamic fields point either into `data`
/// itself (elements that need no conversion and are suitably aligned there)
/// or into a block of `arena`: both must outlive the use of `host`. On
/// failure (as check_flat()) `host` is left untouched.
Status unflatten(const MessageLayout& layout, char* data, std::size_t size, void* host, const Limits& limits,
                 Arena& arena);

}  // namespace ln::services
