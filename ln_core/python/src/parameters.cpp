#include "parameters.hpp"
#include "common.hpp"

#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "ln/parameters_c.h"

namespace nb = nanobind;
using namespace nb::literals;

namespace lnpy {
namespace {

std::size_t element_size(unsigned type) {
  static const std::size_t sizes[] = {8, 4, 1, 1, 2, 2, 4, 4, 1, 8, 8};
  return type < sizeof sizes / sizeof sizes[0] ? sizes[type] : 0;
}

class ParameterBlockBridge {
 public:
  ParameterBlockBridge(nb::object client, const std::string& name, bool always_publish, const std::string& topic_name,
                       WithClient with_client, nb::object ln_error)
      : client_(std::move(client)), with_client_(with_client), ln_error_(std::move(ln_error)) {
    with_client_(client_, [&](ln_client handle) {
      handle_ = handle;
      const int ret = without_gil([&] {
        return ln_parameter_block_init(handle, &block_, name.c_str(), always_publish ? 1 : 0, topic_name.c_str());
      });
      if (ret < 0) raise_ln_error(ln_error_, ret, "parameter_block('" + name + "')", handle);
    });
  }

  ~ParameterBlockBridge() {
    if (block_ == nullptr) return;
    // Ending the block may wait for request handlers, which need the GIL.
    nb::gil_scoped_release release;
    ln_parameter_block_deinit(&block_);
  }

  int add_signal(const std::string& name, const std::string& description, unsigned type,
                 const std::vector<std::uint32_t>& dims, nb::object before_update, nb::object after_update,
                 bool has_output) {
    if (registered_) throw std::logic_error("parameters cannot be added after register()");
    if (element_size(type) == 0) throw std::invalid_argument("unknown parameter type id " + std::to_string(type));
    if (dims.empty() || dims.size() > 2) throw std::invalid_argument("a parameter has 1 or 2 dimensions");
    std::size_t n = 1;
    for (const std::uint32_t d : dims) {
      if (d == 0) throw std::invalid_argument("parameter dimensions must be positive");
      n *= d;
    }
    auto signal = std::make_unique<Signal>();
    signal->name = name;
    signal->description = description;
    signal->type = type;
    signal->dims = dims;
    signal->input.assign(n * element_size(type), 0);
    signal->output = signal->input;
    signal->has_output = has_output;
    if (!before_update.is_none()) signal->before_update = std::move(before_update);
    if (!after_update.is_none()) signal->after_update = std::move(after_update);
    signals_.push_back(std::move(signal));
    return static_cast<int>(signals_.size()) - 1;
  }

  void set_input(int index, nb::bytes data) {
    Signal& s = at(index);
    if (data.size() != s.input.size())
      throw std::invalid_argument("parameter '" + s.name + "' takes " + std::to_string(s.input.size()) +
                                  " bytes, not " + std::to_string(data.size()));
    const std::string copy(data.c_str(), data.size());
    nb::gil_scoped_release release;  // update() holds mutex_ and may wait for the GIL
    std::lock_guard<std::mutex> lock(mutex_);
    std::memcpy(s.input.data(), copy.data(), copy.size());
  }

  nb::bytes output(int index) {
    Signal& s = at(index);
    std::string copy;
    {
      nb::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      copy.assign(reinterpret_cast<const char*>(s.output.data()), s.output.size());
    }
    return nb::bytes(copy.data(), copy.size());
  }

  void register_block() {
    if (registered_) throw std::logic_error("the parameter block is registered already");
    if (signals_.empty()) throw std::logic_error("a parameter block needs at least one parameter");
    std::vector<ln_parameter_signal> described;
    for (const auto& s : signals_) {
      ln_parameter_signal d{};
      d.name = s->name.c_str();
      d.description = s->description.c_str();
      d.type = s->type;
      d.n_dims = static_cast<unsigned>(s->dims.size());
      d.dims = s->dims.data();
      d.row_major = 1;
      d.input = s->input.data();
      d.output = s->has_output ? s->output.data() : nullptr;
      d.before_update = s->before_update.is_valid() ? &Signal::check : nullptr;
      d.after_update = s->after_update.is_valid() ? &Signal::applied : nullptr;
      // (cleared later by the garbage collector: check() refuses, applied() skips)
      d.user_data = s.get();
      described.push_back(d);
    }
    with_client_(client_, [&](ln_client handle) {
      const int ret = without_gil([&] {
        return ln_parameter_block_register(block_, described.data(), static_cast<unsigned>(described.size()));
      });
      if (ret < 0) raise_ln_error(ln_error_, ret, "ParameterBlock.register()", handle);
    });
    registered_ = true;
  }

  void update() {
    if (!registered_) throw std::logic_error("the parameter block is not registered");
    with_client_(client_, [&](ln_client handle) {
      int ret;
      {
        nb::gil_scoped_release release;
        std::lock_guard<std::mutex> lock(mutex_);
        ret = ln_parameter_block_update(block_, nullptr, nullptr, 0);
        // Without an output the program sees its own value, as in LN 2.9.
        for (const auto& s : signals_)
          if (!s->has_output) s->output = s->input;
      }
      if (ret < 0) raise_ln_error(ln_error_, ret, "ParameterBlock.update()", handle);
    });
  }

  bool registered() const { return registered_; }

  // Garbage collection: the callbacks often refer back to the block (a
  // lambda's globals, a bound method), which Python can only see through
  // these two.
  int traverse(visitproc visit, void* arg) {
    Py_VISIT(client_.ptr());
    for (const auto& s : signals_) {
      Py_VISIT(s->before_update.ptr());
      Py_VISIT(s->after_update.ptr());
    }
    return 0;
  }
  void clear() {
    for (const auto& s : signals_) {
      s->before_update = nb::object();  // a request handler then refuses
      s->after_update = nb::object();
    }
  }

 private:
  struct Signal {
    std::string name, description;
    unsigned type = 0;
    std::vector<std::uint32_t> dims;
    std::vector<std::uint8_t> input, output;
    bool has_output = true;
    nb::object before_update, after_update;  // called with the value as bytes

    nb::bytes as_bytes(const void* value) const { return nb::bytes(static_cast<const char*>(value), input.size()); }
    // Runs in the thread that handles the override request.
    static int check(void* value, void* user_data) {
      auto* self = static_cast<Signal*>(user_data);
      nb::gil_scoped_acquire acquire;
      if (!self->before_update.is_valid()) return 0;
      try {
        return nb::cast<bool>(self->before_update(self->as_bytes(value))) ? 1 : 0;
      } catch (nb::python_error& e) {
        e.discard_as_unraisable("links_and_nodes parameter before_update");
        return 0;  // refused
      } catch (const std::exception&) {
        return 0;
      }
    }
    // Runs inside update(), which holds no GIL then.
    static void applied(void* value, void* user_data) {
      auto* self = static_cast<Signal*>(user_data);
      nb::gil_scoped_acquire acquire;
      if (!self->after_update.is_valid()) return;
      try {
        self->after_update(self->as_bytes(value));
      } catch (nb::python_error& e) {
        e.discard_as_unraisable("links_and_nodes parameter after_update");
      } catch (const std::exception&) {
      }
    }
  };

  Signal& at(int index) {
    if (index < 0 || static_cast<std::size_t>(index) >= signals_.size())
      throw std::out_of_range("no parameter with index " + std::to_string(index));
    return *signals_[static_cast<std::size_t>(index)];
  }

  nb::object client_;  // keeps the native client alive
  WithClient with_client_;
  nb::object ln_error_;
  ln_client handle_ = nullptr;
  ln_parameter_block block_ = nullptr;
  std::vector<std::unique_ptr<Signal>> signals_;
  std::mutex mutex_;  // the signals' buffers against update()
  bool registered_ = false;
};

int bridge_traverse(PyObject* self, visitproc visit, void* arg) {
  Py_VISIT(Py_TYPE(self));
  if (!nb::inst_ready(self)) return 0;
  return nb::inst_ptr<ParameterBlockBridge>(self)->traverse(visit, arg);
}

int bridge_clear(PyObject* self) {
  if (nb::inst_ready(self)) nb::inst_ptr<ParameterBlockBridge>(self)->clear();
  return 0;
}

PyType_Slot bridge_slots[] = {{Py_tp_traverse, reinterpret_cast<void*>(bridge_traverse)},
                              {Py_tp_clear, reinterpret_cast<void*>(bridge_clear)},
                              {0, nullptr}};

}  // namespace

void register_parameters(nb::module_& module, WithClient with_client) {
  nb::object ln_error = module.attr("LNError");
  nb::class_<ParameterBlockBridge>(module, "ParameterBlockBridge", nb::type_slots(bridge_slots))
      .def(
          "__init__",
          [with_client, ln_error](ParameterBlockBridge* self, nb::object client, const std::string& name,
                                  bool always_publish, const std::string& topic_name) {
            new (self) ParameterBlockBridge(std::move(client), name, always_publish, topic_name, with_client, ln_error);
          },
          "client"_a, "name"_a, "always_publish"_a = false, "topic_name"_a = "")
      .def("add_signal", &ParameterBlockBridge::add_signal, "name"_a, "description"_a, "type"_a, "dims"_a,
           "before_update"_a.none(), "after_update"_a.none(), "has_output"_a)
      .def("set_input", &ParameterBlockBridge::set_input)
      .def("output", &ParameterBlockBridge::output)
      .def("register", &ParameterBlockBridge::register_block)
      .def("update", &ParameterBlockBridge::update)
      .def("registered", &ParameterBlockBridge::registered);
  for (const auto& [name, id] : {std::pair<const char*, int>{"LN_PARAM_DOUBLE", LN_PARAM_DOUBLE},
                                 {"LN_PARAM_SINGLE", LN_PARAM_SINGLE},
                                 {"LN_PARAM_INT8", LN_PARAM_INT8},
                                 {"LN_PARAM_UINT8", LN_PARAM_UINT8},
                                 {"LN_PARAM_INT16", LN_PARAM_INT16},
                                 {"LN_PARAM_UINT16", LN_PARAM_UINT16},
                                 {"LN_PARAM_INT32", LN_PARAM_INT32},
                                 {"LN_PARAM_UINT32", LN_PARAM_UINT32},
                                 {"LN_PARAM_BOOLEAN", LN_PARAM_BOOLEAN},
                                 {"LN_PARAM_INT64", LN_PARAM_INT64},
                                 {"LN_PARAM_UINT64", LN_PARAM_UINT64}})
    module.attr(name) = id;
}

}  // namespace lnpy
