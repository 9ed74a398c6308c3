// The client side of parameters (ln/parameters_c.h): finding which client
// provides a parameter, reading it and overriding it, over the services
// every LN 2.9 and ln_core provider offers.
//
// A parameter is found by asking every ln/parameters/query_dict service for
// its exact name (which also yields its description); the provider is then
// remembered per client and name, and read through ln/parameters/query
// (binary, so values arrive exactly). When the remembered provider fails or
// no longer has the parameter, the look-up is repeated once.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ln/parameters_c.h"
#include "parameters/values.hpp"

namespace ln::paramcore {

struct RemoteValue {
  std::string name;
  std::string description;
  std::string data_type;
  ElementType type = ElementType::Double;
  Shape shape;  // as data_type says; a scalar has dims {1}
  bool override_enabled = false;
  std::vector<std::uint8_t> input;   // row-major
  std::vector<std::uint8_t> output;  // row-major

  /// The C/C++ view: 0 for a scalar, else the number of dimensions.
  unsigned rank() const {
    return shape.dims.size() == 1 && shape.dims[0] == 1 ? 0 : static_cast<unsigned>(shape.dims.size());
  }
};

/// All three throw clientlib::Failure. `flags`: LN_PARAMETER_* of parameters_c.h.
RemoteValue get_parameter(ln_client clnt, const std::string& name, int flags);
/// `text` empty ends the override.
void override_parameter_text(ln_client clnt, const std::string& name, const std::string& text, int flags);
void override_parameter_data(ln_client clnt, const std::string& name, ElementType type, unsigned n_dims,
                             const std::uint32_t* dims, const void* data, int flags);

/// Converts the input or output of `value` into `n_elements` of `type`.
/// Returns "" or what does not fit.
std::string read_value(const RemoteValue& value, bool output, ElementType type, void* data, std::size_t n_elements,
                       bool strict_types);

/// ln_deinit() hook (via provider.hpp's client_closing()).
void forget_remote_state(ln_client clnt);

}  // namespace ln::paramcore
