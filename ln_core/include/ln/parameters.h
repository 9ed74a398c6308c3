/// @file ln/parameters.h
/// @brief Parameter providers in C++ (LN 2.9's API): a program exposes
///        values that other clients read and override while it runs.
///
/// @code
///   double gain = 1.5, gain_in_effect;
///   double limits[2][3] = {...}, limits_in_effect[2][3];
///   ln::parameters::parameter_block block(&clnt, "controller");
///   block.register_parameters(
///       ln::parameters::port_description<double>("gain", "P gain", &gain, &gain_in_effect),
///       ln::parameters::port_description<double[2][3]>("limits", "", &limits, &limits_in_effect));
///   for (;;) { block.update(); ... use gain_in_effect ... }
/// @endcode
///
/// Every update() reads the inputs and writes the outputs: the input, or
/// the value another client overrides it with ("controller.gain" from
/// ln::parameters::parameter_proxy, Python's client.get_parameters(), LN
/// 2.9's manager or `ln param set`). A before_update callback may refuse an
/// override (it runs in the thread that handles the request); after_update
/// runs in update() once an override takes effect. Types: the arithmetic
/// types and C arrays (row-major) of up to two dimensions of them. See
/// ln/parameters_c.h for the services, threads and LN_PARAMETER_* variables.
#ifndef LN_PARAMETERS_H
#define LN_PARAMETERS_H

// The standard headers LN 2.9's version brings in, for programs that rely on them.
#include <cassert>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "ln.h"
#include "parameter_client.h"
#include "parameters_c.h"

namespace ln {
namespace parameters {

using LnParameterTypes = DataType;

/// One parameter for parameter_block::register_parameters(): what
/// port_description<T> produces. `input` is the program's value, `output`
/// (may be null) where update() writes the value in effect; `dims` has
/// `num_dims` entries, `width` is their product.
struct port_description_void2 {
  const char* signal_name;
  const char* signal_description;
  uint32_t width, type_id, num_dims;
  uint32_t* dims;
  void *input, *output;
  std::function<bool(void*)> before_update_callback;
  std::function<void(void*)> after_update_callback;
  bool row_major;
};

/// Without description; kept for LN 2.9 programs that still use it.
struct port_description_void {
  const char* signal_name;
  uint32_t width, type_id, num_dims;
  uint32_t* dims;
  void *input, *output;
  std::function<bool(void*)> before_update_callback;
  std::function<void(void*)> after_update_callback;
  bool row_major;
};

/// The DataType of an arithmetic type (uint32_t(-1) for others).
template <typename T>
uint32_t _get_param_typeid() {
  return detail::element_type_id<T>();
}

/// Describes one parameter of type T; specialised for arithmetic types and
/// C arrays of them; ln/parameters_eigen.h adds Eigen matrices (programs may
/// add their own specialisations).
template <typename T, typename T2 = T>
struct port_description;

namespace detail {

/// What every port_description has (LN 2.9's members); `Value` is the
/// type the program's callbacks take.
template <typename Value>
struct port_description_fields {
  std::string signal_name;
  std::string signal_description;
  uint32_t width, type_id, num_dims;
  uint32_t* dims;
  void *input, *output;
  bool row_major;
  std::function<bool(void*)> before_update_callback;
  std::function<void(void*)> after_update_callback;

  port_description_fields(std::string name, std::string description, uint32_t width_, uint32_t type, uint32_t n_dims,
                          void* input_, void* output_, bool row_major_,
                          const std::function<bool(Value&)>& before_update,
                          const std::function<void(Value&)>& after_update)
      : signal_name(std::move(name)),
        signal_description(std::move(description)),
        width(width_),
        type_id(type),
        num_dims(n_dims),
        dims(nullptr),
        input(input_),
        output(output_),
        row_major(row_major_) {
    if (before_update)
      before_update_callback = [before_update](void* v) { return before_update(*static_cast<Value*>(v)); };
    if (after_update) after_update_callback = [after_update](void* v) { after_update(*static_cast<Value*>(v)); };
  }
};

/// A port_description that owns its shape (what `dims` points to), so that
/// copies point to their own.
template <typename Value>
struct port_description_shaped : port_description_fields<Value> {
  port_description_shaped(std::string name, std::string description, uint32_t type, std::vector<uint32_t> extents,
                          void* input_, void* output_, bool row_major_,
                          const std::function<bool(Value&)>& before_update,
                          const std::function<void(Value&)>& after_update)
      : port_description_fields<Value>(std::move(name), std::move(description), product(extents), type,
                                       static_cast<uint32_t>(extents.size()), input_, output_, row_major_,
                                       before_update, after_update),
        extents_(std::move(extents)) {
    this->dims = extents_.data();
  }
  port_description_shaped(const port_description_shaped& other)
      : port_description_fields<Value>(other), extents_(other.extents_) {
    this->dims = extents_.data();
  }
  port_description_shaped& operator=(const port_description_shaped& other) {
    port_description_fields<Value>::operator=(other);
    extents_ = other.extents_;
    this->dims = extents_.data();
    return *this;
  }

 private:
  static uint32_t product(const std::vector<uint32_t>& extents) {
    uint32_t n = 1;
    for (uint32_t extent : extents) n *= extent;
    return n;
  }
  std::vector<uint32_t> extents_;
};

}  // namespace detail

template <typename T>
struct port_description<T, typename std::enable_if<std::is_arithmetic<T>::value, T>::type>
    : detail::port_description_fields<T> {
  port_description(std::string signal_name_, std::string signal_description_, T* input_, T* output_,
                   std::function<bool(T&)> before_update = std::function<bool(T&)>(),
                   std::function<void(T&)> after_update = std::function<void(T&)>())
      : detail::port_description_fields<T>(std::move(signal_name_), std::move(signal_description_), 1,
                                           _get_param_typeid<T>(), 1, input_, output_, false, before_update,
                                           after_update) {}
};

/// C arrays of up to two dimensions, stored row-major.
template <typename T>
struct port_description<
    T, typename std::enable_if<
           std::is_array<T>::value && std::is_arithmetic<typename std::remove_all_extents<T>::type>::value, T>::type>
    : detail::port_description_shaped<T> {
  typedef typename std::remove_all_extents<T>::type scalar_type;

  port_description(std::string signal_name_, std::string signal_description_, T* input_, T* output_,
                   std::function<bool(T&)> before_update = std::function<bool(T&)>(),
                   std::function<void(T&)> after_update = std::function<void(T&)>())
      : detail::port_description_shaped<T>(std::move(signal_name_), std::move(signal_description_),
                                           _get_param_typeid<scalar_type>(), extents(), input_, output_, true,
                                           before_update, after_update) {}

 private:
  static std::vector<uint32_t> extents() {
    std::vector<uint32_t> all{static_cast<uint32_t>(std::extent<T, 0>::value),
                              static_cast<uint32_t>(std::extent<T, 1>::value),
                              static_cast<uint32_t>(std::extent<T, 2>::value)};
    all.resize(std::rank<T>::value);  // more than two dimensions: refused when registered
    return all;
  }
};

/// A group of parameters named "<LN_PARAMETER_PREFIX><group>.<signal>".
class parameter_block {
 public:
  /// @param always_publish, topic_name see ln_parameter_block_init().
  /// Throws ln::exception if the client's parameter services cannot be set up.
  parameter_block(ln::client* clnt_, std::string parameter_group_name_, bool always_publish_ = false,
                  std::string topic_name_ = "");
  ~parameter_block();
  parameter_block(const parameter_block&) = delete;
  parameter_block& operator=(const parameter_block&) = delete;

  /// Registers the parameters (once per block). @return false, with the
  /// reason in error_message(), if a name is empty or already provided by
  /// this client, a type or shape is invalid, or an input is null.
  bool register_parameters(std::vector<port_description_void2>& port_descriptions);
  [[deprecated("Please register_parameters with a signal description")]] bool register_parameters(
      std::vector<port_description_void>& port_descriptions);
  template <typename... Types>
  bool register_parameters(port_description<Types>... port_descriptions) {
    std::vector<port_description_void2> flat{_flatten(port_descriptions)...};
    return register_parameters(flat);
  }

  /// One step with the registered pointers: reads every input, applies
  /// overrides, writes every output. Throws ln::exception on failure (not
  /// registered, client gone).
  void update();
  /// One step with other pointers, one per parameter in registration order
  /// (an output may be null); only_inputs: write no output.
  void update(const void** input_signals, void** output_signals, bool only_inputs);
  [[deprecated("Please pass input_signals as const void **")]] void update(void** input_signals, void** output_signals,
                                                                           bool only_inputs);

  /// ln_core: why the last register_parameters() returned false.
  const std::string& error_message() const { return error_message_; }
  /// ln_core: the block's full name (with LN_PARAMETER_PREFIX).
  std::string name() const { return ln_parameter_block_get_name(block_); }

 private:
  template <typename T>
  static port_description_void2 _flatten(port_description<T>& d) {
    return port_description_void2{d.signal_name.c_str(),
                                  d.signal_description.c_str(),
                                  d.width,
                                  d.type_id,
                                  d.num_dims,
                                  d.dims,
                                  d.input,
                                  d.output,
                                  d.before_update_callback,
                                  d.after_update_callback,
                                  d.row_major};
  }
  void run_update(const void* const* inputs, void* const* outputs, bool only_inputs);

  struct callbacks {
    std::function<bool(void*)> before;
    std::function<void(void*)> after;
  };
  ln::client* clnt;
  ln_parameter_block block_;
  std::vector<std::unique_ptr<callbacks>> callbacks_;
  std::string error_message_;
};

// ------------------------------------------------------------------ inline

namespace detail {

// The C callbacks of a parameter: user_data is its parameter_block::callbacks.
template <typename Callbacks>
int before_update_trampoline(void* value, void* user_data) {
  try {
    return static_cast<Callbacks*>(user_data)->before(value) ? 1 : 0;
  } catch (...) {
    return 0;  // a check that throws refuses the value
  }
}

template <typename Callbacks>
void after_update_trampoline(void* value, void* user_data) {
  try {
    static_cast<Callbacks*>(user_data)->after(value);
  } catch (...) {
    // the program's notification failed; the override stays in effect
  }
}

}  // namespace detail

inline parameter_block::parameter_block(ln::client* clnt_, std::string parameter_group_name_, bool always_publish_,
                                        std::string topic_name_)
    : clnt(clnt_), block_(nullptr) {
  if (clnt == nullptr) throw exception("ln::parameters::parameter_block: the client is null", LNE_INVALID_PARAMETER);
  const int ret = ln_parameter_block_init(clnt->clnt, &block_, parameter_group_name_.c_str(), always_publish_ ? 1 : 0,
                                          topic_name_.c_str());
  if (ret != 0) clnt->throw_error(ret, "ln::parameters::parameter_block('" + parameter_group_name_ + "')");
}

inline parameter_block::~parameter_block() {
  if (block_ != nullptr) ln_parameter_block_deinit(&block_);
}

inline bool parameter_block::register_parameters(std::vector<port_description_void2>& port_descriptions) {
  static const uint32_t scalar_dims[1] = {1};
  std::vector<ln_parameter_signal> signals;
  std::vector<std::unique_ptr<callbacks>> kept;
  for (const port_description_void2& d : port_descriptions) {
    kept.emplace_back(new callbacks{d.before_update_callback, d.after_update_callback});
    ln_parameter_signal s{};
    s.name = d.signal_name;
    s.description = d.signal_description;
    s.type = d.type_id;
    s.n_dims = d.num_dims;
    // Scalars come without dims (port_description<arithmetic>).
    s.dims = d.dims != nullptr ? d.dims : (d.num_dims == 1 && d.width == 1 ? scalar_dims : nullptr);
    s.row_major = d.row_major ? 1 : 0;
    s.input = d.input;
    s.output = d.output;
    if (kept.back()->before) s.before_update = &detail::before_update_trampoline<callbacks>;
    if (kept.back()->after) s.after_update = &detail::after_update_trampoline<callbacks>;
    s.user_data = kept.back().get();
    signals.push_back(s);
  }
  const int ret = ln_parameter_block_register(block_, signals.data(), static_cast<unsigned>(signals.size()));
  if (ret != 0) {
    const char* detail = ln_get_error_message(clnt->clnt);
    error_message_ = detail != nullptr && detail[0] != '\0' ? detail : ln_format_error(ret);
    return false;
  }
  error_message_.clear();
  callbacks_ = std::move(kept);
  return true;
}

inline bool parameter_block::register_parameters(std::vector<port_description_void>& port_descriptions) {
  std::vector<port_description_void2> described;
  for (const port_description_void& d : port_descriptions)
    described.push_back(port_description_void2{d.signal_name, "", d.width, d.type_id, d.num_dims, d.dims, d.input,
                                               d.output, d.before_update_callback, d.after_update_callback,
                                               d.row_major});
  return register_parameters(described);
}

inline void parameter_block::run_update(const void* const* inputs, void* const* outputs, bool only_inputs) {
  const int ret = ln_parameter_block_update(block_, inputs, outputs, only_inputs ? 1 : 0);
  if (ret != 0) clnt->throw_error(ret, "ln::parameters::parameter_block::update()");
}

inline void parameter_block::update() { run_update(nullptr, nullptr, false); }

inline void parameter_block::update(const void** input_signals, void** output_signals, bool only_inputs) {
  run_update(input_signals, output_signals, only_inputs);
}

inline void parameter_block::update(void** input_signals, void** output_signals, bool only_inputs) {
  run_update(const_cast<const void**>(input_signals), output_signals, only_inputs);
}

}  // namespace parameters
}  // namespace ln

#endif  // LN_PARAMETERS_H
