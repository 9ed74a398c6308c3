/// @file ln/parameter_client_impl.h
/// @brief Inline definitions of ln/parameter_client.h (include that header).
#ifndef LN_PARAMETER_CLIENT_IMPL_H
#define LN_PARAMETER_CLIENT_IMPL_H

// <cmath>, <exception>, <iomanip>, <limits>, <sstream>: LN 2.9's version brings them in.
#include <array>
#include <cmath>
#include <cstring>
#include <exception>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "ln.h"
#include "parameter_client.h"
#include "parameters_c.h"

namespace ln {
namespace parameters {
namespace detail {

/// The element type id of an arithmetic C++ type (uint32_t(-1) otherwise).
template <typename T>
uint32_t element_type_id() {
  typedef typename std::remove_cv<T>::type clean_t;
  if (std::is_same<clean_t, bool>::value) return LN_BOOLEAN;
  if (std::is_floating_point<clean_t>::value) return sizeof(clean_t) == sizeof(float) ? LN_SINGLE : LN_DOUBLE;
  if (!std::is_integral<clean_t>::value) return static_cast<uint32_t>(-1);
  const bool is_signed = std::is_signed<clean_t>::value;
  switch (sizeof(clean_t)) {
    case 1:
      return is_signed ? LN_INT8 : LN_UINT8;
    case 2:
      return is_signed ? LN_INT16 : LN_UINT16;
    case 4:
      return is_signed ? LN_INT32 : LN_UINT32;
    default:
      return is_signed ? LN_INT64 : LN_UINT64;
  }
}

/// How elements of T travel: as themselves, bool as one byte, long double
/// as double.
template <typename T>
struct element {
  typedef
      typename std::conditional<std::is_same<T, bool>::value, uint8_t,
                                typename std::conditional<std::is_same<T, long double>::value, double, T>::type>::type
          storage;
  static uint32_t type() { return element_type_id<T>(); }
};

inline std::size_t element_size(uint32_t type) {
  static const std::size_t sizes[] = {8, 4, 1, 1, 2, 2, 4, 4, 1, 8, 8};
  return type < sizeof sizes / sizeof sizes[0] ? sizes[type] : 0;
}

inline std::string shape_text(unsigned rank, const uint32_t* dims) {
  if (rank == 0) return "scalar";
  std::string text = "[" + std::to_string(dims[0]);
  if (rank == 2) text += ", " + std::to_string(dims[1]);
  return text + "]";
}

[[noreturn]] inline void fail(ln_client clnt, int ret, const std::string& fallback) {
  const char* detail = clnt != nullptr ? ln_get_error_message(clnt) : nullptr;
  throw std::runtime_error(detail != nullptr && detail[0] != '\0' ? std::string(detail)
                                                                  : fallback + ": " + ln_format_error(ret));
}

/// A value read from its provider (owns what ln_parameter_get() allocated).
struct fetched {
  ln_client clnt = nullptr;
  ln_parameter_value value{};
  fetched() = default;
  fetched(const fetched&) = delete;
  fetched& operator=(const fetched&) = delete;
  fetched(fetched&& other) noexcept : clnt(other.clnt), value(other.value) {
    std::memset(&other.value, 0, sizeof other.value);
  }
  ~fetched() { ln_parameter_value_free(&value); }

  void require_shape(unsigned rank, const uint32_t* dims) const {
    bool same = value.n_dims == rank;
    for (unsigned i = 0; same && dims != nullptr && i < rank; ++i) same = value.dims[i] == dims[i];
    if (!same)
      throw std::runtime_error("parameter '" + std::string(value.name) + "' has shape " +
                               shape_text(value.n_dims, value.dims) + ", the C++ value has " +
                               (dims != nullptr ? "shape " + shape_text(rank, dims) : "rank " + std::to_string(rank)));
  }
  std::size_t elements() const {
    std::size_t n = 1;
    for (unsigned i = 0; i < value.n_dims; ++i) n *= value.dims[i];
    return n;
  }
  /// All elements (row-major) converted to C++ type T, stored as `S`.
  template <typename T, typename S = typename element<T>::storage>
  std::vector<S> read(bool output, bool strict) const {
    std::vector<S> out(elements());
    const int ret = ln_parameter_value_read(clnt, &value, output ? 1 : 0, element<T>::type(), out.data(), out.size(),
                                            strict ? LN_PARAMETER_STRICT_TYPES : 0);
    if (ret != 0) fail(clnt, ret, std::string("reading parameter '") + value.name + "'");
    return out;
  }
};

/// A C++ value flattened for ln_parameter_override().
template <typename S>
struct flat {
  uint32_t type = 0;  // element type id of the C++ elements
  unsigned rank = 0;
  uint32_t dims[2] = {1, 1};
  std::vector<S> data;
};

/// Reading (from_value) and writing (to_flat) of each supported C++ type.
template <typename T, typename Enable = void>
struct value_io {
  static_assert(sizeof(T) == 0,
                "LN parameters hold arithmetic scalars, std::vector/std::array of them, "
                "and nested ones for matrices");
};

template <typename T>
struct value_io<T, typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static T from_value(const fetched& v, bool output, bool strict) {
    v.require_shape(0, nullptr);
    return static_cast<T>(v.read<T>(output, strict)[0]);
  }
  static flat<storage> to_flat(const T& value) {
    flat<storage> f;
    f.type = element<T>::type();
    f.data.push_back(static_cast<storage>(value));
    return f;
  }
};

template <typename T>
struct value_io<std::vector<T>, typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static std::vector<T> from_value(const fetched& v, bool output, bool strict) {
    v.require_shape(1, nullptr);
    const std::vector<storage> elements = v.read<T>(output, strict);
    return std::vector<T>(elements.begin(), elements.end());
  }
  static flat<storage> to_flat(const std::vector<T>& value) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 1;
    f.dims[0] = static_cast<uint32_t>(value.size());
    f.data.assign(value.begin(), value.end());
    return f;
  }
};

template <typename T, std::size_t N>
struct value_io<std::array<T, N>, typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static std::array<T, N> from_value(const fetched& v, bool output, bool strict) {
    const uint32_t dims[1] = {static_cast<uint32_t>(N)};
    v.require_shape(1, dims);
    const std::vector<storage> elements = v.read<T>(output, strict);
    std::array<T, N> out{};
    for (std::size_t i = 0; i < N; ++i) out[i] = static_cast<T>(elements[i]);
    return out;
  }
  static flat<storage> to_flat(const std::array<T, N>& value) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 1;
    f.dims[0] = static_cast<uint32_t>(N);
    f.data.assign(value.begin(), value.end());
    return f;
  }
};

template <typename T, std::size_t N>
struct value_io<T[N], typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static flat<storage> to_flat(const T (&value)[N]) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 1;
    f.dims[0] = static_cast<uint32_t>(N);
    f.data.assign(value, value + N);
    return f;
  }
};

template <typename T>
struct value_io<std::vector<std::vector<T>>, typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static std::vector<std::vector<T>> from_value(const fetched& v, bool output, bool strict) {
    v.require_shape(2, nullptr);
    const std::vector<storage> elements = v.read<T>(output, strict);
    std::vector<std::vector<T>> out(v.value.dims[0]);
    for (std::size_t r = 0; r < out.size(); ++r)
      out[r].assign(elements.begin() + r * v.value.dims[1], elements.begin() + (r + 1) * v.value.dims[1]);
    return out;
  }
  static flat<storage> to_flat(const std::vector<std::vector<T>>& value) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 2;
    f.dims[0] = static_cast<uint32_t>(value.size());
    f.dims[1] = static_cast<uint32_t>(value.empty() ? 0 : value[0].size());
    for (std::size_t r = 0; r < value.size(); ++r) {
      if (value[r].size() != f.dims[1])
        throw std::runtime_error("the C++ matrix is not rectangular: row " + std::to_string(r) + " has " +
                                 std::to_string(value[r].size()) + " values, row 0 has " + std::to_string(f.dims[1]));
      f.data.insert(f.data.end(), value[r].begin(), value[r].end());
    }
    return f;
  }
};

template <typename T, std::size_t R, std::size_t C>
struct value_io<std::array<std::array<T, C>, R>, typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static std::array<std::array<T, C>, R> from_value(const fetched& v, bool output, bool strict) {
    const uint32_t dims[2] = {static_cast<uint32_t>(R), static_cast<uint32_t>(C)};
    v.require_shape(2, dims);
    const std::vector<storage> elements = v.read<T>(output, strict);
    std::array<std::array<T, C>, R> out{};
    for (std::size_t r = 0; r < R; ++r)
      for (std::size_t c = 0; c < C; ++c) out[r][c] = static_cast<T>(elements[r * C + c]);
    return out;
  }
  static flat<storage> to_flat(const std::array<std::array<T, C>, R>& value) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 2;
    f.dims[0] = static_cast<uint32_t>(R);
    f.dims[1] = static_cast<uint32_t>(C);
    for (const auto& row : value) f.data.insert(f.data.end(), row.begin(), row.end());
    return f;
  }
};

template <typename T, std::size_t R, std::size_t C>
struct value_io<T[R][C], typename std::enable_if<std::is_arithmetic<T>::value>::type> {
  typedef typename element<T>::storage storage;
  static flat<storage> to_flat(const T(&value)[R][C]) {
    flat<storage> f;
    f.type = element<T>::type();
    f.rank = 2;
    f.dims[0] = static_cast<uint32_t>(R);
    f.dims[1] = static_cast<uint32_t>(C);
    for (std::size_t r = 0; r < R; ++r) f.data.insert(f.data.end(), value[r], value[r] + C);
    return f;
  }
};

/// Packs a matrix given in `layout` with `stride` bytes between rows
/// (row-major) or columns (column-major) into row-major order.
inline std::vector<uint8_t> pack_matrix(const void* data, std::size_t element_bytes, std::size_t rows, std::size_t cols,
                                        MatrixLayout layout, std::size_t stride) {
  const std::size_t dense = element_bytes * (layout == MatrixLayout::row_major ? cols : rows);
  if (stride == 0) stride = dense;
  if (stride < dense)
    throw std::runtime_error("major_stride_bytes " + std::to_string(stride) + " is smaller than one " +
                             (layout == MatrixLayout::row_major ? "row" : "column") + " (" + std::to_string(dense) +
                             " bytes)");
  std::vector<uint8_t> out(rows * cols * element_bytes);
  const uint8_t* in = static_cast<const uint8_t*>(data);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < cols; ++c) {
      const std::size_t from =
          layout == MatrixLayout::row_major ? r * stride + c * element_bytes : c * stride + r * element_bytes;
      std::memcpy(out.data() + (r * cols + c) * element_bytes, in + from, element_bytes);
    }
  return out;
}

}  // namespace detail

struct parameter_proxy::raw_value : detail::fetched {
  raw_value() = default;
  raw_value(raw_value&&) = default;
};

// ----------------------------------------------------------------- proxy

inline parameter_proxy::parameter_proxy() : _clnt(nullptr), _strict_type_checks(false) {}

inline parameter_proxy::parameter_proxy(ln::client* clnt, std::string group_prefix, bool strict_type_checks)
    : _clnt(clnt), _group_prefix(std::move(group_prefix)), _strict_type_checks(strict_type_checks) {}

inline parameter_proxy parameter_proxy::get_parameters(std::string group_name) const {
  return parameter_proxy(_clnt, _full_signal_name(group_name), _strict_type_checks);
}

inline bool parameter_proxy::strict_type_checks() const { return _strict_type_checks; }
inline void parameter_proxy::set_strict_type_checks(bool strict_type_checks) {
  _strict_type_checks = strict_type_checks;
}

inline std::string parameter_proxy::_full_signal_name(const std::string& signal_name) const {
  return _group_prefix.empty() ? signal_name : _group_prefix + "." + signal_name;
}

inline parameter_proxy::raw_value parameter_proxy::_fetch(const std::string& signal_name) const {
  if (_clnt == nullptr) throw std::runtime_error("ln::parameters::parameter_proxy is not bound to a client");
  raw_value v;
  v.clnt = _clnt->clnt;
  const std::string name = _full_signal_name(signal_name);
  const int ret = ln_parameter_get(v.clnt, name.c_str(), 0, &v.value);
  if (ret != 0) detail::fail(v.clnt, ret, "reading parameter '" + name + "'");
  return v;
}

inline void parameter_proxy::_override(const std::string& signal_name, DataType data_type, unsigned n_dims,
                                       const uint32_t* dims, const void* data, bool wait_step) const {
  if (_clnt == nullptr) throw std::runtime_error("ln::parameters::parameter_proxy is not bound to a client");
  const std::string name = _full_signal_name(signal_name);
  const int flags = (wait_step ? LN_PARAMETER_WAIT_STEP : 0) | (_strict_type_checks ? LN_PARAMETER_STRICT_TYPES : 0);
  const int ret = ln_parameter_override(_clnt->clnt, name.c_str(), data_type, n_dims, dims, data, flags);
  if (ret != 0) detail::fail(_clnt->clnt, ret, "overriding parameter '" + name + "'");
}

template <typename T>
T parameter_proxy::_read(const std::string& signal_name, bool output) const {
  return detail::value_io<T>::from_value(_fetch(signal_name), output, _strict_type_checks);
}

template <typename T>
T parameter_proxy::get_input(const std::string& signal_name) const {
  return _read<T>(signal_name, false);
}

template <typename T>
T parameter_proxy::get_output(const std::string& signal_name) const {
  return _read<T>(signal_name, true);
}

template <typename T>
void parameter_proxy::set_override(const std::string& signal_name, const T& value, bool wait_step) const {
  const auto f = detail::value_io<T>::to_flat(value);
  _override(signal_name, static_cast<DataType>(f.type), f.rank, f.dims, f.data.data(), wait_step);
}

inline std::string parameter_proxy::get_description(const std::string& signal_name) const {
  return _fetch(signal_name).value.description;
}

inline void parameter_proxy::set_override_from_data_scalar(const std::string& signal_name, DataType data_type,
                                                           const void* data, bool wait_step) const {
  _override(signal_name, data_type, 0, nullptr, data, wait_step);
}

inline void parameter_proxy::set_override_from_data_vector(const std::string& signal_name, DataType data_type,
                                                           std::size_t n_elements, const void* data,
                                                           bool wait_step) const {
  const uint32_t dims[1] = {static_cast<uint32_t>(n_elements)};
  _override(signal_name, data_type, 1, dims, data, wait_step);
}

inline void parameter_proxy::set_override_from_data_matrix(const std::string& signal_name, DataType data_type,
                                                           std::size_t rows, std::size_t cols, const void* data,
                                                           MatrixLayout layout, std::size_t major_stride_bytes,
                                                           bool wait_step) const {
  const std::size_t bytes = detail::element_size(data_type);
  if (bytes == 0 || data == nullptr)
    throw std::runtime_error("parameter '" + _full_signal_name(signal_name) + "': invalid data type or null data");
  const std::vector<uint8_t> packed = detail::pack_matrix(data, bytes, rows, cols, layout, major_stride_bytes);
  const uint32_t dims[2] = {static_cast<uint32_t>(rows), static_cast<uint32_t>(cols)};
  _override(signal_name, data_type, 2, dims, packed.data(), wait_step);
}

inline void parameter_proxy::get_into_data_scalar(const std::string& signal_name, DataType data_type,
                                                  ValueSource value_source, void* data) const {
  get_into_data_vector(signal_name, data_type, value_source, 1, data);
}

inline void parameter_proxy::get_into_data_vector(const std::string& signal_name, DataType data_type,
                                                  ValueSource value_source, std::size_t n_elements, void* data) const {
  const raw_value v = _fetch(signal_name);
  if (data == nullptr) throw std::runtime_error("parameter '" + _full_signal_name(signal_name) + "': null data");
  if (v.elements() != n_elements)
    throw std::runtime_error("parameter '" + _full_signal_name(signal_name) + "' has shape " +
                             detail::shape_text(v.value.n_dims, v.value.dims) + ", the data has " +
                             std::to_string(n_elements) + " elements");
  const int ret = ln_parameter_value_read(v.clnt, &v.value, value_source == ValueSource::output ? 1 : 0, data_type,
                                          data, n_elements, _strict_type_checks ? LN_PARAMETER_STRICT_TYPES : 0);
  if (ret != 0) detail::fail(v.clnt, ret, "reading parameter '" + _full_signal_name(signal_name) + "'");
}

inline void parameter_proxy::get_into_data_matrix(const std::string& signal_name, DataType data_type,
                                                  ValueSource value_source, std::size_t rows, std::size_t cols,
                                                  void* data, MatrixLayout layout,
                                                  std::size_t major_stride_bytes) const {
  const std::size_t bytes = detail::element_size(data_type);
  if (bytes == 0 || data == nullptr)
    throw std::runtime_error("parameter '" + _full_signal_name(signal_name) + "': invalid data type or null data");
  const raw_value v = _fetch(signal_name);
  const uint32_t dims[2] = {static_cast<uint32_t>(rows), static_cast<uint32_t>(cols)};
  v.require_shape(2, dims);
  std::vector<uint8_t> row_major(rows * cols * bytes);
  const int ret =
      ln_parameter_value_read(v.clnt, &v.value, value_source == ValueSource::output ? 1 : 0, data_type,
                              row_major.data(), rows * cols, _strict_type_checks ? LN_PARAMETER_STRICT_TYPES : 0);
  if (ret != 0) detail::fail(v.clnt, ret, "reading parameter '" + _full_signal_name(signal_name) + "'");
  const std::size_t dense = bytes * (layout == MatrixLayout::row_major ? cols : rows);
  const std::size_t stride = major_stride_bytes == 0 ? dense : major_stride_bytes;
  if (stride < dense)
    throw std::runtime_error("major_stride_bytes " + std::to_string(stride) + " is smaller than one dense " +
                             (layout == MatrixLayout::row_major ? "row" : "column"));
  uint8_t* out = static_cast<uint8_t*>(data);
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t c = 0; c < cols; ++c)
      std::memcpy(out + (layout == MatrixLayout::row_major ? r * stride + c * bytes : c * stride + r * bytes),
                  row_major.data() + (r * cols + c) * bytes, bytes);
}

inline void parameter_proxy::reset_override(const std::string& signal_name, bool wait_step) const {
  if (_clnt == nullptr) throw std::runtime_error("ln::parameters::parameter_proxy is not bound to a client");
  const std::string name = _full_signal_name(signal_name);
  const int ret =
      ln_parameter_override_text(_clnt->clnt, name.c_str(), nullptr, wait_step ? LN_PARAMETER_WAIT_STEP : 0);
  if (ret != 0) detail::fail(_clnt->clnt, ret, "ending the override of parameter '" + name + "'");
}

inline parameter_value parameter_proxy::get_internal_value(const std::string& signal_name) const {
  const raw_value v = _fetch(signal_name);
  parameter_value out;
  out.full_name = v.value.name;
  out.description = v.value.description;
  out.data_type = v.value.data_type;
  out.element_data_type = static_cast<DataType>(v.value.type);
  out.scalar_size = detail::element_size(v.value.type);
  for (unsigned i = 0; i < v.value.n_dims; ++i) out.shape.push_back(v.value.dims[i]);
  out.override_enabled = v.value.override_enabled != 0;
  switch (v.value.type) {
    case LN_DOUBLE:
    case LN_SINGLE:
      out.scalar_kind = ScalarKind::floating;
      break;
    case LN_BOOLEAN:
      out.scalar_kind = ScalarKind::boolean;
      break;
    case LN_UINT8:
    case LN_UINT16:
    case LN_UINT32:
    case LN_UINT64:
      out.scalar_kind = ScalarKind::unsigned_integer;
      break;
    default:
      out.scalar_kind = ScalarKind::signed_integer;
  }
  if (out.scalar_kind == ScalarKind::floating) {
    out.input_float = v.read<double>(false, false);
    out.output_float = v.read<double>(true, false);
  } else if (out.scalar_kind == ScalarKind::signed_integer) {
    for (const int64_t x : v.read<int64_t>(false, false)) out.input_integer.push_back(static_cast<uint64_t>(x));
    for (const int64_t x : v.read<int64_t>(true, false)) out.output_integer.push_back(static_cast<uint64_t>(x));
  } else {
    out.input_integer = v.read<uint64_t>(false, false);
    out.output_integer = v.read<uint64_t>(true, false);
  }
  return out;
}

// ----------------------------------------------------------- signal_proxy

template <typename T>
typename parameter_proxy::template signal_proxy<T> parameter_proxy::get_signal(const std::string& signal_name) const {
  return signal_proxy<T>(*this, signal_name);
}

template <typename T>
parameter_proxy::signal_proxy<T>::signal_proxy(parameter_proxy parameters, std::string signal_name)
    : _parameters(std::move(parameters)), _signal_name(std::move(signal_name)) {}

template <typename T>
T parameter_proxy::signal_proxy<T>::get_input() const {
  return _parameters.template get_input<T>(_signal_name);
}

template <typename T>
T parameter_proxy::signal_proxy<T>::get_output() const {
  return _parameters.template get_output<T>(_signal_name);
}

template <typename T>
void parameter_proxy::signal_proxy<T>::set_override(const T& value, bool wait_step) const {
  _parameters.set_override(_signal_name, value, wait_step);
}

template <typename T>
void parameter_proxy::signal_proxy<T>::reset_override(bool wait_step) const {
  _parameters.reset_override(_signal_name, wait_step);
}

template <typename T>
std::string parameter_proxy::signal_proxy<T>::get_description() const {
  return _parameters.get_description(_signal_name);
}

template <typename T>
parameter_value parameter_proxy::signal_proxy<T>::get_internal_value() const {
  return _parameters.get_internal_value(_signal_name);
}

}  // namespace parameters

inline parameters::parameter_proxy client::get_parameters(std::string group_prefix, bool strict_type_checks) {
  return parameters::parameter_proxy(this, std::move(group_prefix), strict_type_checks);
}

}  // namespace ln

#endif  // LN_PARAMETER_CLIENT_IMPL_H
