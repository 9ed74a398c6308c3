#include "bridge/rcl_api.hpp"

#include <dlfcn.h>

#include <stdexcept>

namespace msg_mapping::bridge {
namespace {

void* open_loaded(const char* name) {
  void* library = dlopen(name, RTLD_NOW | RTLD_NOLOAD);
  if (!library)
    throw std::runtime_error(std::string(name) + " is not loaded in this process: import rclpy (ROS 2 Jazzy) first");
  return library;
}

template <class F>
void resolve(void* library, const char* library_name, const char* symbol, F& target) {
  target = reinterpret_cast<F>(dlsym(library, symbol));
  if (!target) throw std::runtime_error(std::string(library_name) + " has no " + symbol);
}

RclApi load() {
  void* rcl = open_loaded("librcl.so");
  void* rmw = open_loaded("librmw.so");
  void* rcutils = open_loaded("librcutils.so");
  RclApi api;
  resolve(rcl, "librcl.so", "rcl_publish_serialized_message", api.publish_serialized);
  resolve(rcl, "librcl.so", "rcl_take_serialized_message", api.take_serialized);
  resolve(rcl, "librcl.so", "rcl_get_zero_initialized_subscription", api.zero_subscription);
  resolve(rcl, "librcl.so", "rcl_subscription_get_default_options", api.subscription_default_options);
  resolve(rcl, "librcl.so", "rcl_subscription_init", api.subscription_init);
  resolve(rcl, "librcl.so", "rcl_subscription_fini", api.subscription_fini);
  resolve(rcl, "librcl.so", "rcl_subscription_get_topic_name", api.subscription_topic_name);
  resolve(rcl, "librcl.so", "rcl_subscription_set_on_new_message_callback", api.set_on_new_message_callback);
  resolve(rcl, "librcl.so", "rcl_get_publishers_info_by_topic", api.publishers_info_by_topic);
  resolve(rmw, "librmw.so", "rmw_topic_endpoint_info_array_fini", api.endpoint_info_array_fini);
  resolve(rcutils, "librcutils.so", "rcutils_get_default_allocator", api.default_allocator);
  resolve(rcutils, "librcutils.so", "rcutils_uint8_array_init", api.uint8_array_init);
  resolve(rcutils, "librcutils.so", "rcutils_uint8_array_fini", api.uint8_array_fini);
  resolve(rcutils, "librcutils.so", "rcutils_get_error_string", api.get_error_string);
  resolve(rcutils, "librcutils.so", "rcutils_reset_error", api.reset_error);
  return api;
}

}  // namespace

const RclApi& RclApi::loaded() {
  static const RclApi api = load();  // a failure throws and is retried at the next call
  return api;
}

std::string RclApi::error(const std::string& what, int ret) const {
  const rcutils_error_string_t text = get_error_string();
  reset_error();
  return what + " (rcl " + std::to_string(ret) + "): " + text.str;
}

}  // namespace msg_mapping::bridge
