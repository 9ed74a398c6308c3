// ln/parameters_c.h: parameter blocks (provider side) and reading and
// overriding other clients' parameters (client side).
#include <cstdlib>
#include <cstring>

#include "capi/capi_support.hpp"
#include "ln/parameters_c.h"
#include "parameters/provider.hpp"
#include "parameters/remote.hpp"

using ln::capi::client_from;
using ln::capi::guarded;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::Failure;
using ln::paramcore::Block;

namespace {

struct BlockHandle {
  ln_client clnt;
  Block block;
};

BlockHandle* handle_of(ln_parameter_block block) { return static_cast<BlockHandle*>(block); }

// The client of a block, for the error text, or nullptr once it is gone.
Client* client_of(BlockHandle* handle) { return handle != nullptr ? client_from(handle->clnt) : nullptr; }

ln::paramcore::ElementType type_of(unsigned type) {
  const auto parsed = ln::paramcore::element_type_from_id(type);
  if (!parsed) throw Failure(LNE_INVALID_PARAMETER, "unknown parameter type id " + std::to_string(type) + " (0..10)");
  return *parsed;
}

}  // namespace

extern "C" {

int ln_parameter_block_init(ln_client clnt, ln_parameter_block* block, const char* group_name, int always_publish,
                            const char* topic_name) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(block != nullptr, "block");
    *block = nullptr;
    require(group_name != nullptr, "group_name");
    *block = new BlockHandle{clnt, Block(clnt, group_name, always_publish != 0, topic_name)};
    return 0;
  });
}

int ln_parameter_block_register(ln_parameter_block block, const ln_parameter_signal* signals, unsigned int n_signals) {
  if (block == nullptr) return -LNE_INVALID_PARAMETER;
  return guarded(client_of(handle_of(block)), [&] {
    handle_of(block)->block.register_signals(signals, n_signals);
    return 0;
  });
}

int ln_parameter_block_update(ln_parameter_block block, const void* const* inputs, void* const* outputs,
                              int only_inputs) {
  if (block == nullptr) return -LNE_INVALID_PARAMETER;
  return guarded(client_of(handle_of(block)), [&] {
    handle_of(block)->block.update(inputs, outputs, only_inputs != 0);
    return 0;
  });
}

const char* ln_parameter_block_get_name(ln_parameter_block block) {
  return block != nullptr ? handle_of(block)->block.name().c_str() : nullptr;
}

int ln_parameter_block_deinit(ln_parameter_block* block) {
  if (block == nullptr || *block == nullptr) return -LNE_INVALID_PARAMETER;
  delete handle_of(*block);
  *block = nullptr;
  return 0;
}

int ln_parameter_get(ln_client clnt, const char* name, int flags, ln_parameter_value* value) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "name");
    require(value != nullptr, "value");
    std::memset(value, 0, sizeof *value);
    const ln::paramcore::RemoteValue got = ln::paramcore::get_parameter(clnt, name, flags);
    ln_parameter_value out{};
    try {
      out.name = ln::capi::malloc_copy(got.name);
      out.description = ln::capi::malloc_copy(got.description);
      out.data_type = ln::capi::malloc_copy(got.data_type);
      out.type = static_cast<unsigned>(got.type);
      out.n_dims = got.rank();
      for (unsigned i = 0; i < out.n_dims; ++i) out.dims[i] = got.shape.dims[i];
      out.override_enabled = got.override_enabled ? 1 : 0;
      out.size = static_cast<std::uint32_t>(got.input.size());
      out.input = std::malloc(got.input.size() + 1);
      out.output = std::malloc(got.output.size() + 1);
      if (out.input == nullptr || out.output == nullptr) throw std::bad_alloc();
      std::memcpy(out.input, got.input.data(), got.input.size());
      std::memcpy(out.output, got.output.data(), got.output.size());
    } catch (...) {
      ln_parameter_value_free(&out);
      throw;
    }
    *value = out;
    return 0;
  });
}

void ln_parameter_value_free(ln_parameter_value* value) {
  if (value == nullptr) return;
  std::free(value->name);
  std::free(value->description);
  std::free(value->data_type);
  std::free(value->input);
  std::free(value->output);
  std::memset(value, 0, sizeof *value);
}

int ln_parameter_value_read(ln_client clnt, const ln_parameter_value* value, int output, unsigned int type, void* data,
                            size_t n_elements, int flags) {
  return guarded(client_from(clnt), [&] {
    require(value != nullptr, "value");
    require(data != nullptr || n_elements == 0, "data");
    ln::paramcore::RemoteValue view;
    view.name = value->name != nullptr ? value->name : "";
    view.data_type = value->data_type != nullptr ? value->data_type : "";
    view.type = type_of(value->type);
    if (value->n_dims == 0)
      view.shape.dims = {1};
    else
      view.shape.dims.assign(value->dims, value->dims + std::min(value->n_dims, 2u));
    const std::size_t bytes = view.shape.elements() * ln::paramcore::element_size(view.type);
    if (bytes != value->size || (output ? value->output : value->input) == nullptr)
      throw Failure(LNE_INVALID_PARAMETER, "the ln_parameter_value is not one ln_parameter_get() filled");
    const auto* from = static_cast<const std::uint8_t*>(output ? value->output : value->input);
    (output ? view.output : view.input).assign(from, from + bytes);
    const std::string error = ln::paramcore::read_value(view, output != 0, type_of(type), data, n_elements,
                                                        (flags & LN_PARAMETER_STRICT_TYPES) != 0);
    if (!error.empty()) throw Failure(LNE_INVALID_PARAMETER, error);
    return 0;
  });
}

int ln_parameter_override(ln_client clnt, const char* name, unsigned int type, unsigned int n_dims,
                          const uint32_t* dims, const void* data, int flags) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "name");
    ln::paramcore::override_parameter_data(clnt, name, type_of(type), n_dims, dims, data, flags);
    return 0;
  });
}

int ln_parameter_override_text(ln_client clnt, const char* name, const char* text, int flags) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(name != nullptr, "name");
    ln::paramcore::override_parameter_text(clnt, name, text != nullptr ? text : "", flags);
    return 0;
  });
}

}  // extern "C"
