// Parameter values as LN 2.9 moves them between providers and clients:
// element types and shapes, the binary form of ln/parameters/query (type
// strings like "double[2, 3]", matrices column-major), the Python-literal
// text of ln/parameters/query_dict, and the conversion of override text
// ("2.5", "array([[1, 2], [3, 4]])") into the parameter's own type.
//
// Inside the library every value is kept row-major in its element type; the
// program's own layout (row- or column-major) is converted at its boundary.
//
// Where LN 2.9 answers bad input with a silent wrong value (an override
// "abc" becomes 0, "300" wraps to 44 in an int8), these functions answer an
// error naming the parameter; where it loses precision in the text form
// (1e-20 shown as "-0."), the text here is exact. Everything LN 2.9 accepts
// and applies correctly is accepted.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "parameters/literal.hpp"

namespace ln::paramcore {

/// LN's parameter element types; the values are LN's type ids
/// (ln::parameters::DataType, LN_PARAM_* in Python).
enum class ElementType : unsigned {
  Double = 0,
  Single = 1,
  Int8 = 2,
  UInt8 = 3,
  Int16 = 4,
  UInt16 = 5,
  Int32 = 6,
  UInt32 = 7,
  Boolean = 8,
  Int64 = 9,
  UInt64 = 10,
};
inline constexpr unsigned kElementTypeCount = 11;

enum class ElementKind { Floating, Signed, Unsigned, Boolean };

std::optional<ElementType> element_type_from_id(unsigned id);
std::size_t element_size(ElementType type);
ElementKind element_kind(ElementType type);
/// LN's name: "double", "float", "int8", ..., "bool" (data_type and dtype).
const char* element_type_name(ElementType type);
std::optional<ElementType> element_type_from_name(std::string_view name);

/// The dimensions a parameter was registered with (one or two, each >= 1).
struct Shape {
  std::vector<std::uint32_t> dims;

  std::size_t elements() const;
  std::size_t rows() const { return dims.size() == 2 ? dims[0] : 1; }
  std::size_t columns() const { return dims.empty() ? 1 : dims.back(); }
  /// How LN shows and accepts the value as text: one element registered as
  /// a scalar or a one-element array is a scalar; two dimensions with more
  /// than one row are a matrix; everything else is a list.
  enum class Form { Scalar, List, Matrix };
  Form form() const;
  bool operator==(const Shape& other) const { return dims == other.dims; }
};

/// "" if `dims` is a valid shape (1 or 2 dimensions, each >= 1, at most
/// 2^28 elements), else why not.
std::string check_dims(const std::uint32_t* dims, unsigned n_dims);

/// The data_type of ln/parameters/value: "double" (scalar), "double4" (one
/// dimension), "double[2, 3]" (two).
std::string binary_type_string(ElementType type, const Shape& shape);
/// Inverse of binary_type_string(); a scalar comes back with dims {1}.
bool parse_binary_type_string(std::string_view text, ElementType& type, Shape& shape);

/// Copies a value between a program's layout and row-major (no-op for
/// fewer than two dimensions or `row_major`).
void to_row_major(const void* from, void* to, ElementType type, const Shape& shape, bool from_row_major);
void from_row_major(const void* from, void* to, ElementType type, const Shape& shape, bool to_row_major);

/// One element, widened: what a value is, independent of its storage.
struct Scalar {
  enum class Kind { Float, Signed, Unsigned } kind = Kind::Signed;
  double f = 0;
  std::int64_t s = 0;
  std::uint64_t u = 0;

  static Scalar of_float(double v) { return Scalar{Kind::Float, v, 0, 0}; }
  static Scalar of_signed(std::int64_t v) { return Scalar{Kind::Signed, 0, v, 0}; }
  static Scalar of_unsigned(std::uint64_t v) { return Scalar{Kind::Unsigned, 0, 0, v}; }
};

Scalar load_element(ElementType type, const void* element);
/// Stores `value` converted to `type`: integers must fit; a finite number
/// with a fraction is truncated toward zero for integer types (as C and
/// LN 2.9 do); bool takes any number (non-zero is true); nan/inf only for
/// floating types; a finite double beyond float's range does not fit a
/// float. Returns "" or why the value does not fit (e.g. "300 does not fit
/// int8 (-128..127)").
std::string store_element(ElementType type, const Scalar& value, void* element);

/// An element as the text of query_dict: LN 2.9's form (floats with 16
/// decimals, trailing zeros dropped: "0.1", "7.", "3.1415926535897931")
/// whenever that form is exact, else the shortest exact form ("1e-20");
/// "nan", "inf", "-inf"; integers in decimal; "True"/"False".
std::string format_element_for_display(ElementType type, const void* element);
/// An element as override text for a provider: the shortest text that
/// reads back as the same value of `type`; bools as "True"/"False".
std::string format_element_exact(ElementType type, const void* element);

/// A whole value (row-major) as query_dict shows it: a scalar, or
/// "array([1., 2.], dtype=double)", or "array([[1, 2], [3, 4]], dtype=int16)".
std::string format_value_for_display(ElementType type, const Shape& shape, const std::uint8_t* row_major);
/// A whole value (row-major) as override text: the element, or
/// "array([1, 2])", or "array([[1, 2], [3, 4]])". A matrix with one row is
/// sent as a list (LN 2.9 providers accept only that form for it).
std::string format_value_for_override(ElementType type, const Shape& shape, const std::uint8_t* row_major);

/// Converts override text (already parsed) into the parameter's value,
/// row-major, `elements() * element_size(type)` bytes. Accepts numbers,
/// True/False, nan/inf, numpy scalar calls ("np.float64(2.5)"), lists and
/// array(...) calls (any dtype keyword), rows as lists of lists; a
/// one-element list for a scalar and rows for a 1 x n parameter too.
/// Returns "" or what is wrong, naming `parameter_name`.
std::string literal_to_value(const Literal& literal, ElementType type, const Shape& shape,
                             const std::string& parameter_name, std::vector<std::uint8_t>& row_major);

}  // namespace ln::paramcore
