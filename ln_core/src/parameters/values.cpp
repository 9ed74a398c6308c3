#include "parameters/values.hpp"

#include <cctype>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace ln::paramcore {

namespace {

struct TypeInfo {
  const char* name;
  std::size_t size;
  ElementKind kind;
};

// Indexed by the LN type id.
constexpr TypeInfo kTypes[kElementTypeCount] = {
    {"double", 8, ElementKind::Floating}, {"float", 4, ElementKind::Floating},  {"int8", 1, ElementKind::Signed},
    {"uint8", 1, ElementKind::Unsigned},  {"int16", 2, ElementKind::Signed},    {"uint16", 2, ElementKind::Unsigned},
    {"int32", 4, ElementKind::Signed},    {"uint32", 4, ElementKind::Unsigned}, {"bool", 1, ElementKind::Boolean},
    {"int64", 8, ElementKind::Signed},    {"uint64", 8, ElementKind::Unsigned},
};

const TypeInfo& info(ElementType type) { return kTypes[static_cast<unsigned>(type)]; }

constexpr std::size_t kMaxElements = std::size_t{1} << 28;

std::int64_t signed_min(std::size_t size) { return size == 8 ? INT64_MIN : -(std::int64_t{1} << (size * 8 - 1)); }
std::int64_t signed_max(std::size_t size) { return size == 8 ? INT64_MAX : (std::int64_t{1} << (size * 8 - 1)) - 1; }
std::uint64_t unsigned_max(std::size_t size) { return size == 8 ? UINT64_MAX : (std::uint64_t{1} << (size * 8)) - 1; }

template <typename T>
T read_as(const void* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <typename T>
void write_as(void* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

// The low `size` bytes of `bits`: an unsigned value, or a signed one in
// two's complement.
void write_integer(void* p, std::size_t size, std::uint64_t bits) {
  switch (size) {
    case 1:
      write_as<std::uint8_t>(p, static_cast<std::uint8_t>(bits));
      break;
    case 2:
      write_as<std::uint16_t>(p, static_cast<std::uint16_t>(bits));
      break;
    case 4:
      write_as<std::uint32_t>(p, static_cast<std::uint32_t>(bits));
      break;
    default:
      write_as<std::uint64_t>(p, bits);
  }
}

std::string range_text(ElementType type) {
  const std::size_t size = info(type).size;
  switch (info(type).kind) {
    case ElementKind::Signed:
      return std::string(info(type).name) + " (" + std::to_string(signed_min(size)) + ".." +
             std::to_string(signed_max(size)) + ")";
    case ElementKind::Unsigned:
      return std::string(info(type).name) + " (0.." + std::to_string(unsigned_max(size)) + ")";
    default:
      return info(type).name;
  }
}

std::string scalar_text(const Scalar& v) {
  switch (v.kind) {
    case Scalar::Kind::Signed:
      return std::to_string(v.s);
    case Scalar::Kind::Unsigned:
      return std::to_string(v.u);
    case Scalar::Kind::Float:
      break;
  }
  char text[64];
  std::snprintf(text, sizeof text, "%.17g", v.f);
  return text;
}

// The shortest text that reads back as `v` (as a float if `single`), laid
// out as Python's repr() does: fixed notation for exponents -4..15
// ("1000.0", "0.0001"), else scientific ("1e+16", "1e-05").
std::string shortest_float_text(double v, bool single) {
  char text[64];
  int precision = 0;
  for (; precision < 17; ++precision) {
    std::snprintf(text, sizeof text, "%.*e", precision, v);
    const double back = std::strtod(text, nullptr);
    if (single ? static_cast<float>(back) == static_cast<float>(v) : back == v) break;
  }
  // text is "[-]d.ddde[+-]xx": split into sign, digits and exponent.
  std::string mantissa(text, std::strchr(text, 'e'));
  const int exponent = std::atoi(std::strchr(text, 'e') + 1);
  const bool negative = mantissa[0] == '-';
  std::string digits;
  for (const char c : mantissa)
    if (std::isdigit(static_cast<unsigned char>(c))) digits.push_back(c);
  while (digits.size() > 1 && digits.back() == '0') digits.pop_back();
  std::string out = negative ? "-" : "";
  if (exponent >= -4 && exponent < 16) {
    if (exponent < 0) {
      out += "0." + std::string(static_cast<std::size_t>(-exponent - 1), '0') + digits;
    } else if (static_cast<std::size_t>(exponent) + 1 >= digits.size()) {
      out += digits + std::string(static_cast<std::size_t>(exponent) + 1 - digits.size(), '0') + ".0";
    } else {
      out += digits.substr(0, static_cast<std::size_t>(exponent) + 1) + "." +
             digits.substr(static_cast<std::size_t>(exponent) + 1);
    }
    return out;
  }
  out += digits.substr(0, 1);
  if (digits.size() > 1) out += "." + digits.substr(1);
  char exponent_text[16];
  std::snprintf(exponent_text, sizeof exponent_text, "e%c%02d", exponent < 0 ? '-' : '+', std::abs(exponent));
  return out + exponent_text;
}

std::string float_text(double v, bool single, bool ln29_form) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v < 0 ? "-inf" : "inf";
  if (ln29_form) {
    // LN 2.9 prints 16 decimals and drops trailing zeros ("7.", "0.1").
    char buffer[400];
    const int n = std::snprintf(buffer, sizeof buffer, "%.16f", v);
    if (n > 0 && static_cast<std::size_t>(n) < sizeof buffer) {
      std::string text(buffer);
      while (text.back() == '0') text.pop_back();
      const double back = std::strtod(text.c_str(), nullptr);
      if (single ? static_cast<float>(back) == static_cast<float>(v) : back == v) return text;
    }
  }
  return shortest_float_text(v, single);
}

// Reads a number literal: integers exactly (decimal, 0x/0o/0b), everything
// else as a double; nullopt if it is not a number.
std::optional<Scalar> number_value(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const bool negative = text[0] == '-';
  const std::string digits = (negative || text[0] == '+') ? text.substr(1) : text;
  if (digits.empty()) return std::nullopt;
  int base = 10;
  std::string body = digits;
  if (digits.size() > 2 && digits[0] == '0' && std::strchr("xXoObB", digits[1]) != nullptr) {
    base = (digits[1] == 'x' || digits[1] == 'X') ? 16 : (digits[1] == 'o' || digits[1] == 'O') ? 8 : 2;
    body = digits.substr(2);
  }
  const bool all_digits =
      body.find_first_not_of(base == 16 ? "0123456789abcdefABCDEF" : "0123456789") == std::string::npos &&
      !body.empty();
  if (all_digits &&
      (base != 10 || body.size() == 1 || body[0] != '0' || body.find_first_not_of('0') == std::string::npos)) {
    errno = 0;
    char* end = nullptr;
    const unsigned long long magnitude = std::strtoull(body.c_str(), &end, base);
    if (errno == ERANGE || *end != '\0') return Scalar::of_float(std::strtod(text.c_str(), nullptr));
    if (!negative) return Scalar::of_unsigned(magnitude);
    if (magnitude <= static_cast<unsigned long long>(INT64_MAX))
      return Scalar::of_signed(-static_cast<std::int64_t>(magnitude));
    if (magnitude == static_cast<unsigned long long>(INT64_MAX) + 1) return Scalar::of_signed(INT64_MIN);
    return Scalar::of_float(-static_cast<double>(magnitude));
  }
  if (base != 10) return std::nullopt;
  // A float: digits, one '.', an exponent; nothing else (no "0x1p3", "nan").
  if (digits.find_first_not_of("0123456789.eE+-") != std::string::npos) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0') return std::nullopt;
  return Scalar::of_float(v);
}

// One element of override text as a Scalar, or an error.
std::string literal_scalar(const Literal& literal, Scalar& out) {
  switch (literal.kind) {
    case Literal::Kind::Number: {
      const std::optional<Scalar> v = number_value(literal.text);
      if (!v) return "'" + literal.text + "' is not a number";
      out = *v;
      return "";
    }
    case Literal::Kind::Name:
      if (literal.text == "True" || literal.text == "true")
        out = Scalar::of_unsigned(1);
      else if (literal.text == "False" || literal.text == "false")
        out = Scalar::of_unsigned(0);
      else if (literal.text == "nan" || literal.text == "-nan" || literal.text == "NaN")
        out = Scalar::of_float(NAN);
      else if (literal.text == "inf" || literal.text == "Infinity")
        out = Scalar::of_float(INFINITY);
      else if (literal.text == "-inf" || literal.text == "-Infinity")
        out = Scalar::of_float(-INFINITY);
      else
        return "'" + literal.text + "' is not a number";
      return "";
    case Literal::Kind::Call:
      // numpy scalars: np.float64(2.5), float32(1), np.True_ is a Name.
      if (literal.items.size() == 1 && literal.keywords.empty() &&
          (literal.items[0].kind == Literal::Kind::Number || literal.items[0].kind == Literal::Kind::Name))
        return literal_scalar(literal.items[0], out);
      return "'" + literal.text + "(...)' is not a number";
    case Literal::Kind::String:
      return "a string is not a number";
    default:
      return "a list is not a number";
  }
}

// The elements of a list literal (array(...) unwrapped), or nullptr if
// `literal` is not a list.
const std::vector<Literal>* list_items(const Literal& literal) {
  if (literal.kind == Literal::Kind::List || literal.kind == Literal::Kind::Tuple) return &literal.items;
  if (literal.kind == Literal::Kind::Call &&
      (literal.text == "array" || literal.text == "np.array" || literal.text == "numpy.array") &&
      literal.items.size() == 1)
    return list_items(literal.items[0]);
  return nullptr;
}

bool is_zero_dim_array(const Literal& literal) {
  return literal.kind == Literal::Kind::Call && literal.items.size() == 1 && list_items(literal) == nullptr &&
         (literal.text == "array" || literal.text == "np.array" || literal.text == "numpy.array");
}

}  // namespace

// ------------------------------------------------------------------- types

std::optional<ElementType> element_type_from_id(unsigned id) {
  if (id >= kElementTypeCount) return std::nullopt;
  return static_cast<ElementType>(id);
}
std::size_t element_size(ElementType type) { return info(type).size; }
ElementKind element_kind(ElementType type) { return info(type).kind; }
const char* element_type_name(ElementType type) { return info(type).name; }

std::optional<ElementType> element_type_from_name(std::string_view name) {
  for (unsigned id = 0; id < kElementTypeCount; ++id)
    if (name == kTypes[id].name) return static_cast<ElementType>(id);
  return std::nullopt;
}

// ------------------------------------------------------------------ shapes

std::size_t Shape::elements() const {
  std::size_t n = 1;
  for (const std::uint32_t d : dims) n *= d;
  return n;
}

Shape::Form Shape::form() const {
  if (dims.size() == 1 && dims[0] == 1) return Form::Scalar;
  if (dims.size() == 2 && dims[0] > 1) return Form::Matrix;
  return Form::List;
}

std::string check_dims(const std::uint32_t* dims, unsigned n_dims) {
  if (n_dims < 1 || n_dims > 2) return "a parameter has 1 or 2 dimensions, not " + std::to_string(n_dims);
  if (dims == nullptr) return "the dimensions are missing";
  std::size_t n = 1;
  for (unsigned i = 0; i < n_dims; ++i) {
    if (dims[i] == 0) return "dimension " + std::to_string(i) + " is 0";
    n *= dims[i];
    if (n > kMaxElements) return "more than " + std::to_string(kMaxElements) + " elements";
  }
  return "";
}

std::string binary_type_string(ElementType type, const Shape& shape) {
  std::string text = info(type).name;
  if (shape.dims.size() == 2)
    return text + "[" + std::to_string(shape.dims[0]) + ", " + std::to_string(shape.dims[1]) + "]";
  if (shape.elements() != 1) text += std::to_string(shape.elements());
  return text;
}

bool parse_binary_type_string(std::string_view text, ElementType& type, Shape& shape) {
  // No type name is a prefix of another, so the one the text starts with is
  // the type; what follows is the count ("int162": int16 x 2) or "[r, c]".
  std::size_t name_end = 0;
  std::optional<ElementType> found;
  for (unsigned id = 0; id < kElementTypeCount && !found; ++id) {
    const std::string_view name = kTypes[id].name;
    if (text.substr(0, name.size()) == name) {
      name_end = name.size();
      found = static_cast<ElementType>(id);
    }
  }
  if (!found) return false;
  std::string_view rest = text.substr(name_end);
  Shape parsed;
  auto read_number = [](std::string_view digits, std::uint32_t& out) {
    if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string_view::npos)
      return false;
    out = static_cast<std::uint32_t>(std::stoul(std::string(digits)));
    return out > 0;
  };
  if (rest.empty()) {
    parsed.dims = {1};
  } else if (rest[0] == '[') {
    const std::size_t comma = rest.find(", ");
    if (comma == std::string_view::npos || rest.back() != ']') return false;
    std::uint32_t rows = 0, columns = 0;
    if (!read_number(rest.substr(1, comma - 1), rows) ||
        !read_number(rest.substr(comma + 2, rest.size() - comma - 3), columns))
      return false;
    parsed.dims = {rows, columns};
  } else {
    std::uint32_t n = 0;
    if (!read_number(rest, n)) return false;
    parsed.dims = {n};
  }
  if (!check_dims(parsed.dims.data(), static_cast<unsigned>(parsed.dims.size())).empty()) return false;
  type = *found;
  shape = std::move(parsed);
  return true;
}

namespace {

// Copies a value between row-major and column-major order (or just copies
// it when `transpose` is false or it has fewer than two dimensions).
void copy_layout(const void* from, void* to, ElementType type, const Shape& shape, bool transpose, bool to_row) {
  const std::size_t size = info(type).size;
  if (!transpose || shape.dims.size() != 2) {
    std::memcpy(to, from, shape.elements() * size);
    return;
  }
  const std::size_t rows = shape.dims[0], columns = shape.dims[1];
  const auto* in = static_cast<const std::uint8_t*>(from);
  auto* out = static_cast<std::uint8_t*>(to);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < columns; ++c) {
      const std::size_t row_major = (r * columns + c) * size, column_major = (c * rows + r) * size;
      std::memcpy(out + (to_row ? row_major : column_major), in + (to_row ? column_major : row_major), size);
    }
}

}  // namespace

void to_row_major(const void* from, void* to, ElementType type, const Shape& shape, bool from_row_major) {
  copy_layout(from, to, type, shape, !from_row_major, true);
}

void from_row_major(const void* from, void* to, ElementType type, const Shape& shape, bool to_row_major) {
  copy_layout(from, to, type, shape, !to_row_major, false);
}

// ---------------------------------------------------------------- elements

Scalar load_element(ElementType type, const void* p) {
  switch (type) {
    case ElementType::Double:
      return Scalar::of_float(read_as<double>(p));
    case ElementType::Single:
      return Scalar::of_float(read_as<float>(p));
    case ElementType::Int8:
      return Scalar::of_signed(read_as<std::int8_t>(p));
    case ElementType::UInt8:
      return Scalar::of_unsigned(read_as<std::uint8_t>(p));
    case ElementType::Int16:
      return Scalar::of_signed(read_as<std::int16_t>(p));
    case ElementType::UInt16:
      return Scalar::of_unsigned(read_as<std::uint16_t>(p));
    case ElementType::Int32:
      return Scalar::of_signed(read_as<std::int32_t>(p));
    case ElementType::UInt32:
      return Scalar::of_unsigned(read_as<std::uint32_t>(p));
    case ElementType::Boolean:
      return Scalar::of_unsigned(read_as<std::uint8_t>(p) != 0 ? 1 : 0);
    case ElementType::Int64:
      return Scalar::of_signed(read_as<std::int64_t>(p));
    case ElementType::UInt64:
      return Scalar::of_unsigned(read_as<std::uint64_t>(p));
  }
  return Scalar{};
}

std::string store_element(ElementType type, const Scalar& value, void* p) {
  const TypeInfo& t = info(type);
  if (t.kind == ElementKind::Floating) {
    const double v = value.kind == Scalar::Kind::Float    ? value.f
                     : value.kind == Scalar::Kind::Signed ? static_cast<double>(value.s)
                                                          : static_cast<double>(value.u);
    if (type == ElementType::Double) {
      write_as<double>(p, v);
      return "";
    }
    if (std::isfinite(v) && std::fabs(v) > FLT_MAX) return scalar_text(value) + " does not fit float";
    write_as<float>(p, static_cast<float>(v));
    return "";
  }
  if (t.kind == ElementKind::Boolean) {
    bool truth = false;
    switch (value.kind) {
      case Scalar::Kind::Float:
        if (std::isnan(value.f)) return "nan is not a bool";
        truth = std::trunc(value.f) != 0;
        break;
      case Scalar::Kind::Signed:
        truth = value.s != 0;
        break;
      case Scalar::Kind::Unsigned:
        truth = value.u != 0;
        break;
    }
    write_as<std::uint8_t>(p, truth ? 1 : 0);
    return "";
  }
  // Integers: as a signed or unsigned 64-bit value first, then the range.
  bool negative = false;
  std::uint64_t magnitude = 0;
  if (value.kind == Scalar::Kind::Float) {
    if (!std::isfinite(value.f)) return scalar_text(value) + " does not fit " + range_text(type);
    const double whole = std::trunc(value.f);
    if (whole >= 18446744073709551616.0 || whole < -9223372036854775808.0)
      return scalar_text(value) + " does not fit " + range_text(type);
    negative = whole < 0;
    magnitude = negative ? static_cast<std::uint64_t>(-(whole + 1)) + 1 : static_cast<std::uint64_t>(whole);
  } else if (value.kind == Scalar::Kind::Signed) {
    negative = value.s < 0;
    magnitude = negative ? static_cast<std::uint64_t>(-(value.s + 1)) + 1 : static_cast<std::uint64_t>(value.s);
  } else {
    magnitude = value.u;
  }
  const std::size_t size = t.size;
  if (t.kind == ElementKind::Unsigned) {
    if ((negative && magnitude != 0) || magnitude > unsigned_max(size))
      return scalar_text(value) + " does not fit " + range_text(type);
    write_integer(p, size, magnitude);
    return "";
  }
  const std::uint64_t limit =
      negative ? static_cast<std::uint64_t>(-(signed_min(size) + 1)) + 1 : static_cast<std::uint64_t>(signed_max(size));
  if (magnitude > limit) return scalar_text(value) + " does not fit " + range_text(type);
  const std::int64_t v =
      negative ? (magnitude == (std::uint64_t{1} << 63) ? INT64_MIN : -static_cast<std::int64_t>(magnitude))
               : static_cast<std::int64_t>(magnitude);
  write_integer(p, size, static_cast<std::uint64_t>(v));
  return "";
}

namespace {

std::string element_text(ElementType type, const void* p, bool display) {
  const Scalar v = load_element(type, p);
  if (type == ElementType::Boolean) return v.u != 0 ? "True" : "False";
  if (v.kind != Scalar::Kind::Float) return scalar_text(v);
  return float_text(v.f, type == ElementType::Single, display);
}

std::string value_text(ElementType type, const Shape& shape, const std::uint8_t* data, bool display) {
  const std::size_t size = info(type).size;
  if (shape.form() == Shape::Form::Scalar) return element_text(type, data, display);
  auto row_text = [&](std::size_t first, std::size_t count) {
    std::string text = "[";
    for (std::size_t i = 0; i < count; ++i) {
      if (i != 0) text += ", ";
      text += element_text(type, data + (first + i) * size, display);
    }
    return text + "]";
  };
  std::string text = "array(";
  if (shape.form() == Shape::Form::Matrix) {
    text += "[";
    for (std::size_t r = 0; r < shape.rows(); ++r) {
      if (r != 0) text += ", ";
      text += row_text(r * shape.columns(), shape.columns());
    }
    text += "]";
  } else {
    text += row_text(0, shape.elements());
  }
  if (display) text += std::string(", dtype=") + info(type).name;
  return text + ")";
}

}  // namespace

std::string format_element_for_display(ElementType type, const void* element) {
  return element_text(type, element, true);
}
std::string format_element_exact(ElementType type, const void* element) { return element_text(type, element, false); }

std::string format_value_for_display(ElementType type, const Shape& shape, const std::uint8_t* row_major) {
  return value_text(type, shape, row_major, true);
}
std::string format_value_for_override(ElementType type, const Shape& shape, const std::uint8_t* row_major) {
  return value_text(type, shape, row_major, false);
}

// ------------------------------------------------------------- overrides

std::string literal_to_value(const Literal& literal, ElementType type, const Shape& shape,
                             const std::string& parameter_name, std::vector<std::uint8_t>& row_major) {
  const std::size_t size = info(type).size;
  std::vector<std::uint8_t> out(shape.elements() * size);
  const std::string who = "parameter '" + parameter_name + "' (" + binary_type_string(type, shape) + ")";
  auto store = [&](const Literal& item, std::size_t index) -> std::string {
    Scalar v;
    std::string error = literal_scalar(item, v);
    if (error.empty()) error = store_element(type, v, out.data() + index * size);
    return error.empty() ? "" : who + ": " + error;
  };
  auto store_list = [&](const std::vector<Literal>& items, std::size_t first, const std::string& where) -> std::string {
    for (std::size_t i = 0; i < items.size(); ++i) {
      if (list_items(items[i]) != nullptr)
        return who + ": " + where + "element " + std::to_string(i) + " is a list, a number was expected";
      if (std::string error = store(items[i], first + i); !error.empty()) return error;
    }
    return "";
  };

  const std::vector<Literal>* items = list_items(literal);
  const Literal* scalar_literal = is_zero_dim_array(literal) ? &literal.items[0] : &literal;
  if (shape.form() == Shape::Form::Scalar) {
    if (items != nullptr) {
      // A one-element list for a one-element parameter is still that element.
      if (items->size() == 1 && list_items((*items)[0]) == nullptr)
        scalar_literal = &(*items)[0];
      else
        return who + " is a scalar, the value is a list of " + std::to_string(items->size());
    }
    if (std::string error = store(*scalar_literal, 0); !error.empty()) return error;
    row_major = std::move(out);
    return "";
  }
  if (items == nullptr) {
    return who + " takes " + (shape.form() == Shape::Form::Matrix ? "rows" : "a list") + " of " +
           std::to_string(shape.elements()) + " values, not a single value";
  }
  const bool nested = !items->empty() && list_items((*items)[0]) != nullptr;
  if (shape.form() == Shape::Form::List && !nested) {
    if (items->size() != shape.elements())
      return who + " takes " + std::to_string(shape.elements()) + " values, the list has " +
             std::to_string(items->size());
    if (std::string error = store_list(*items, 0, ""); !error.empty()) return error;
    row_major = std::move(out);
    return "";
  }
  // Rows: a matrix, or a list parameter registered with two dimensions
  // (1 x n) given as [[...]] (LN 2.9's C++ client sends that form).
  if (!nested)
    return who + " takes " + std::to_string(shape.rows()) + " rows of " + std::to_string(shape.columns()) +
           " values, the value is a flat list";
  if (shape.dims.size() != 2)
    return who + " takes a list of " + std::to_string(shape.elements()) + " values, the value is a list of rows";
  if (items->size() != shape.rows())
    return who + " takes " + std::to_string(shape.rows()) + " rows, the value has " + std::to_string(items->size());
  for (std::size_t r = 0; r < items->size(); ++r) {
    const std::vector<Literal>* row = list_items((*items)[r]);
    if (row == nullptr) return who + ": row " + std::to_string(r) + " is not a list";
    if (row->size() != shape.columns())
      return who + " takes " + std::to_string(shape.columns()) + " values per row, row " + std::to_string(r) + " has " +
             std::to_string(row->size());
    if (std::string error = store_list(*row, r * shape.columns(), "row " + std::to_string(r) + " "); !error.empty())
      return error;
  }
  row_major = std::move(out);
  return "";
}

}  // namespace ln::paramcore
