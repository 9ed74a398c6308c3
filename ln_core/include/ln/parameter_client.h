/// @file ln/parameter_client.h
/// @brief Reading and overriding other clients' parameters in C++ (LN 2.9's
///        API; what ln::client::get_parameters() returns).
///
/// @code
///   ln::parameters::parameter_proxy controller = clnt.get_parameters("controller");
///   double gain = controller.get_output<double>("gain");       // "controller.gain"
///   controller.set_override("gain", 2.5);                        // waits for the provider's next step
///   auto limits = controller.get_input<std::vector<std::vector<double>>>("limits");
///   controller.reset_override("gain");
/// @endcode
///
/// Names are relative to the proxy's group ("" = full names). Values:
/// arithmetic types (scalars), std::vector / std::array of them (vectors),
/// and nested vectors / arrays (matrices); set_override also takes C arrays.
/// The shape must be the parameter's: a scalar, [n] or [rows, cols] as its
/// provider registered it. Values convert between element types when they
/// fit (an out-of-range value is an error, a fraction is truncated toward
/// zero); with strict_type_checks, floating and integer values do not
/// convert into each other. Every failure - unknown parameter, wrong shape
/// or type, a value that does not fit, an override the provider refused -
/// throws std::runtime_error naming the parameter.
///
/// Every call asks the provider (get_* reads the current value); the client
/// that provides a name is looked up once and remembered (per client).
/// Unlike Python's get_parameters(), LN_PARAMETER_PREFIX is not applied.
#ifndef LN_PARAMETER_CLIENT_H
#define LN_PARAMETER_CLIENT_H

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace ln {

class client;

namespace parameters {

/// Element types; the values are LN's type ids (LN_PARAM_* in C).
enum DataType {
  LN_DOUBLE,
  LN_SINGLE,
  LN_INT8,
  LN_UINT8,
  LN_INT16,
  LN_UINT16,
  LN_INT32,
  LN_UINT32,
  LN_BOOLEAN,
  LN_INT64,
  LN_UINT64
};

enum class ScalarKind { unknown, floating, signed_integer, unsigned_integer, boolean };

/// Which value to read: the provider's own (input) or the one in effect
/// (output: the input, or the override).
enum class ValueSource { input, output };

enum class MatrixLayout { row_major, column_major };

/// A parameter as its provider reported it (get_internal_value()).
struct parameter_value {
  std::string full_name;
  std::string description;
  std::string data_type;  ///< "double", "float3", "int16[2, 3]"
  DataType element_data_type = LN_DOUBLE;
  std::size_t scalar_size = 0;     ///< bytes per element
  std::vector<std::size_t> shape;  ///< {} scalar, {n}, {rows, cols}
  ScalarKind scalar_kind = ScalarKind::unknown;
  bool override_enabled = false;

  /// Row-major elements: floating types in *_float, integers and bools in
  /// *_integer (signed values as their two's-complement bits).
  std::vector<double> input_float;
  std::vector<uint64_t> input_integer;
  std::vector<double> output_float;
  std::vector<uint64_t> output_integer;
};

class parameter_proxy {
 public:
  /// Not bound to a client: every access throws.
  parameter_proxy();
  /// The parameters "<group_prefix>.<name>" (just "<name>" for "").
  parameter_proxy(ln::client* clnt, std::string group_prefix, bool strict_type_checks = false);

  /// The subgroup "<group_prefix>.<group_name>".
  parameter_proxy get_parameters(std::string group_name) const;

  bool strict_type_checks() const;
  void set_strict_type_checks(bool strict_type_checks);

  std::string get_description(const std::string& signal_name) const;

  /// The provider's own value.
  template <typename T>
  T get_input(const std::string& signal_name) const;
  /// The value in effect (the override while there is one).
  template <typename T>
  T get_output(const std::string& signal_name) const;
  /// Overrides the parameter; with wait_step, returns once the provider's
  /// next update has applied it (or fails after 10 s without update).
  template <typename T>
  void set_override(const std::string& signal_name, const T& value, bool wait_step = true) const;

  /// set_override() with raw data of `data_type` (a scalar, n elements, or
  /// a matrix in `layout`, rows/columns `major_stride_bytes` apart; 0 =
  /// packed).
  void set_override_from_data_scalar(const std::string& signal_name, DataType data_type, const void* data,
                                     bool wait_step = true) const;
  void set_override_from_data_vector(const std::string& signal_name, DataType data_type, std::size_t n_elements,
                                     const void* data, bool wait_step = true) const;
  void set_override_from_data_matrix(const std::string& signal_name, DataType data_type, std::size_t rows,
                                     std::size_t cols, const void* data, MatrixLayout layout = MatrixLayout::row_major,
                                     std::size_t major_stride_bytes = 0, bool wait_step = true) const;

  /// get_input()/get_output() into raw memory of `data_type`.
  void get_into_data_scalar(const std::string& signal_name, DataType data_type, ValueSource value_source,
                            void* data) const;
  void get_into_data_vector(const std::string& signal_name, DataType data_type, ValueSource value_source,
                            std::size_t n_elements, void* data) const;
  void get_into_data_matrix(const std::string& signal_name, DataType data_type, ValueSource value_source,
                            std::size_t rows, std::size_t cols, void* data,
                            MatrixLayout layout = MatrixLayout::row_major, std::size_t major_stride_bytes = 0) const;

  /// Ends the override: the output follows the input again.
  void reset_override(const std::string& signal_name, bool wait_step = true) const;

  /// One parameter bound to a name and a C++ type.
  template <typename T>
  class signal_proxy;

  template <typename T>
  signal_proxy<T> get_signal(const std::string& signal_name) const;

  parameter_value get_internal_value(const std::string& signal_name) const;

 private:
  struct raw_value;
  ln::client* _clnt;
  std::string _group_prefix;
  bool _strict_type_checks;

  std::string _full_signal_name(const std::string& signal_name) const;
  raw_value _fetch(const std::string& signal_name) const;
  void _override(const std::string& signal_name, DataType data_type, unsigned n_dims, const uint32_t* dims,
                 const void* data, bool wait_step) const;
  template <typename T>
  T _read(const std::string& signal_name, bool output) const;
};

template <typename T>
class parameter_proxy::signal_proxy {
 public:
  signal_proxy(parameter_proxy parameters, std::string signal_name);

  T get_input() const;
  T get_output() const;
  void set_override(const T& value, bool wait_step = true) const;
  void reset_override(bool wait_step = true) const;
  std::string get_description() const;
  parameter_value get_internal_value() const;

 private:
  parameter_proxy _parameters;
  std::string _signal_name;
};

}  // namespace parameters
}  // namespace ln

#include "parameter_client_impl.h"

#endif  // LN_PARAMETER_CLIENT_H
