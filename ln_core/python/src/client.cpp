// links_and_nodes._ln: the client (see client.hpp).
#include "client.hpp"

#include <cstdlib>

using namespace nb::literals;

namespace lnpy {

std::optional<std::string> take_string(char* text) {
  if (text == nullptr) return std::nullopt;
  std::string out(text);
  std::free(text);
  return out;
}

void availability_trampoline(ln_client, const char* name, int available, void* user) {
  if (_Py_IsFinalizing()) return;
  nb::gil_scoped_acquire acquire;
  try {
    static_cast<AvailabilityHandler*>(user)->callback(std::string(name), available != 0);
  } catch (nb::python_error& error) {
    error.discard_as_unraisable("links_and_nodes availability handler");
  }
}

void register_client(nb::module_& m) {
  nb::class_<Client>(m, "Client")
      .def(nb::init<const std::string&, std::optional<std::string>, std::optional<std::vector<std::string>>>(),
           "name"_a, "manager"_a = nb::none(), "argv"_a = nb::none())
      .def("close", &Client::close)
      .def_prop_ro("closed", &Client::closed)
      // The C API's ln_client, for compiled code in this process that uses the
      // same connection (ln_ros2_bridge's data path); 0 once closed.
      .def_prop_ro("handle", [](const Client& c) { return reinterpret_cast<std::uintptr_t>(c.handle()); })
      .def_prop_ro("name", &Client::name)
      .def("get_remaining_args", &Client::remaining_args)
      .def("ping", &Client::ping, "timeout"_a = -1.0)
      .def("get_message_definition", &Client::get_message_definition)
      .def("get_message_definition_for_topic", &Client::get_message_definition_for_topic)
      .def("describe_message_definition", &Client::describe_message_definition)
      .def("put_message_definition", &Client::put_message_definition)
      .def("locate_member", &Client::locate_member)
      .def("model", &Client::model, "name"_a, "text"_a = nb::none())
      .def("get_service_signature", &Client::get_service_signature)
      .def("get_service_signature_for_service", &Client::get_service_signature_for_service)
      .def("find_services_with_interface", &Client::find_services_with_interface)
      .def("needs_provider", &Client::needs_provider, "name"_a, "timeout"_a = -1.0)
      .def("wait_for_service", &Client::wait_for_service, "name"_a, "timeout"_a = -1.0)
      .def("wait_and_handle_service_group_requests", &Client::wait_and_handle_service_group_requests,
           "group_name"_a = nb::none(), "timeout"_a = -1.0)
      .def("handle_service_group_in_thread_pool", &Client::handle_service_group_in_thread_pool)
      .def("remove_service_group_from_thread_pool", &Client::remove_service_group_from_thread_pool)
      .def("unblock_service_group", &Client::unblock_service_group)
      .def("set_max_threads", &Client::set_max_threads)
      .def("thread_pool_setschedparam", &Client::thread_pool_setschedparam)
      .def("set_thread_safe", &Client::set_thread_safe)
      .def("set_float_parameter", &Client::set_float_parameter)
      .def("register_as_service_logger", &Client::register_as_service_logger)
      .def("set_availability_handler", &Client::set_availability_handler, "service"_a, "name"_a, "callback"_a.none());
}

}  // namespace lnpy
