// The parts of the rcl C API the data path uses, resolved in the librcl that
// rclpy loaded (the PyPI ros-jazzy-rcl wheel). Resolving at run time keeps
// msg_mapping importable without ROS and guarantees one rcl per process:
// entities made by rclpy (node, publishers) and by the data path
// (subscriptions) live in the same context.
#pragma once

#include <string>

#include "rcl/error_handling.h"
#include "rcl/graph.h"
#include "rcl/publisher.h"
#include "rcl/subscription.h"
#include "rcutils/types/uint8_array.h"
#include "rmw/topic_endpoint_info_array.h"

namespace msg_mapping::bridge {

struct RclApi {
  decltype(&rcl_publish_serialized_message) publish_serialized = nullptr;
  decltype(&rcl_take_serialized_message) take_serialized = nullptr;
  decltype(&rcl_get_zero_initialized_subscription) zero_subscription = nullptr;
  decltype(&rcl_subscription_get_default_options) subscription_default_options = nullptr;
  decltype(&rcl_subscription_init) subscription_init = nullptr;
  decltype(&rcl_subscription_fini) subscription_fini = nullptr;
  decltype(&rcl_subscription_get_topic_name) subscription_topic_name = nullptr;
  decltype(&rcl_subscription_set_on_new_message_callback) set_on_new_message_callback = nullptr;
  decltype(&rcl_get_publishers_info_by_topic) publishers_info_by_topic = nullptr;
  decltype(&rmw_topic_endpoint_info_array_fini) endpoint_info_array_fini = nullptr;
  decltype(&rcutils_get_default_allocator) default_allocator = nullptr;
  decltype(&rcutils_uint8_array_init) uint8_array_init = nullptr;
  decltype(&rcutils_uint8_array_fini) uint8_array_fini = nullptr;
  decltype(&rcutils_get_error_string) get_error_string = nullptr;
  decltype(&rcutils_reset_error) reset_error = nullptr;

  /// The API of the librcl loaded in this process. Throws std::runtime_error
  /// when it is not loaded (import rclpy first) or lacks a function.
  static const RclApi& loaded();

  /// "what: rcl's error text", and resets rcl's error state.
  std::string error(const std::string& what, int ret) const;
};

}  // namespace msg_mapping::bridge
