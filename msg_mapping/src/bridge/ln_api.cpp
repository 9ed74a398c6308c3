#include "bridge/ln_api.hpp"

#include <dlfcn.h>

#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

namespace msg_mapping::bridge {
namespace {

// Searched from the module's handle, dlsym finds the symbol in the module or
// in the libraries it links, in their load order: the module's own libln.
template <class F>
void resolve(void* module, const char* symbol, F& target, bool required, const std::string& module_file) {
  target = reinterpret_cast<F>(dlsym(module, symbol));
  if (!target && required) throw std::runtime_error(module_file + " does not link an LN library (no " + symbol + ")");
}

LnApi load(const std::string& module_file) {
  // The handle only names the loaded module; the module stays loaded as long
  // as the Python package does, so it is never closed.
  void* module = dlopen(module_file.c_str(), RTLD_NOW | RTLD_NOLOAD);
  if (!module) throw std::runtime_error("the LN Python module " + module_file + " is not loaded in this process");
  LnApi api;
  resolve(module, "ln_init_to_manager", api.init_to_manager, true, module_file);
  resolve(module, "ln_deinit", api.deinit, true, module_file);
  resolve(module, "ln_client_get_name", api.client_get_name, true, module_file);
  resolve(module, "ln_subscribe_with_buffers", api.subscribe, true, module_file);
  resolve(module, "ln_unsubscribe", api.unsubscribe, true, module_file);
  resolve(module, "ln_read_timeout", api.read_timeout, true, module_file);
  resolve(module, "ln_unblock", api.unblock, true, module_file);
  resolve(module, "ln_publish_with_buffers", api.publish, true, module_file);
  resolve(module, "ln_unpublish", api.unpublish, true, module_file);
  resolve(module, "ln_write", api.write, true, module_file);
  resolve(module, "ln_get_message_size", api.message_size, true, module_file);
  resolve(module, "ln_format_error", api.format_error, true, module_file);
  resolve(module, "ln_multi_waiter_init", api.multi_waiter_init, true, module_file);
  resolve(module, "ln_multi_waiter_deinit", api.multi_waiter_deinit, true, module_file);
  resolve(module, "ln_multi_waiter_add_port", api.multi_waiter_add, true, module_file);
  resolve(module, "ln_multi_waiter_remove_port", api.multi_waiter_remove, true, module_file);
  resolve(module, "ln_multi_waiter_wait", api.multi_waiter_wait, true, module_file);
  resolve(module, "ln_multi_waiter_can_read", api.multi_waiter_can_read, true, module_file);
  resolve(module, "ln_read_borrow", api.read_borrow, false, module_file);
  resolve(module, "ln_read_release", api.read_release, false, module_file);
  if (!api.read_release) api.read_borrow = nullptr;
  Dl_info where{};
  api.path =
      dladdr(reinterpret_cast<void*>(api.init_to_manager), &where) && where.dli_fname ? where.dli_fname : module_file;
  return api;
}

}  // namespace

const LnApi& LnApi::of_module(const std::string& module_file) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<LnApi>> apis;  // by module; entries live as long as the process
  std::lock_guard<std::mutex> lock(mutex);
  auto& api = apis[module_file];
  if (!api) api = std::make_unique<LnApi>(load(module_file));
  return *api;
}

std::string LnApi::error(const std::string& what, int ret) const {
  const char* text = format_error ? format_error(ret) : nullptr;
  return what + ": " + (text ? text : "LN error " + std::to_string(ret));
}

}  // namespace msg_mapping::bridge
