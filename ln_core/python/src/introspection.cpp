#include "introspection.hpp"
#include "common.hpp"

#include <nanobind/stl/string.h>

#include <cstdint>
#include <memory>
#include <string>

namespace nb = nanobind;
using namespace nb::literals;

namespace lnpy {
namespace {

struct FreeList {
  void operator()(void* list) const { ln_free_list(list); }
};

nb::list names(const char* const* array) {
  nb::list out;
  for (; array != nullptr && *array != nullptr; ++array) out.append(nb::str(*array));
  return out;
}

nb::dict as_dict(const ln_topic_info& topic) {
  nb::dict d;
  d["name"] = topic.name;
  d["message_definition"] = topic.message_definition;
  d["hash"] = topic.hash;
  d["message_size"] = topic.message_size;
  d["publisher"] = topic.publisher;
  d["subscribers"] = topic.subscribers;
  d["packets"] = topic.packets;
  d["rate"] = topic.rate;
  return d;
}

nb::dict as_dict(const ln_client_info& client) {
  nb::dict d;
  d["name"] = client.name;
  d["id"] = client.id;
  d["pid"] = client.pid;
  d["host"] = client.host;
  d["host_id"] = client.host_id;
  d["published"] = names(client.published);
  d["subscribed"] = names(client.subscribed);
  d["services"] = names(client.services);
  return d;
}

nb::dict as_dict(const ln_service_info& service) {
  nb::dict d;
  d["name"] = service.name;
  d["interface"] = service.interface;
  d["signature"] = service.signature;
  d["provider"] = service.provider;
  d["group"] = service.group;
  return d;
}

nb::dict as_dict(const ln_manager_status& status) {
  nb::dict d;
  d["version"] = status.version;
  d["pid"] = status.pid;
  d["address"] = status.address;
  d["uptime"] = status.uptime;
  d["clients"] = status.clients;
  d["topics"] = status.topics;
  d["services"] = status.services;
  d["message_definition_dirs"] = names(status.message_definition_dirs);
  return d;
}

nb::dict as_dict(const ln_process_info& info) {
  nb::dict d;
  d["name"] = info.name;
  d["kind"] = info.kind;
  d["state"] = info.state;
  d["requested"] = info.requested;
  d["pid"] = info.pid;
  d["uptime"] = info.uptime;
  d["restarts"] = info.restarts;
  d["ready"] = info.ready != 0;
  d["last_exit"] = info.last_exit;
  d["error"] = info.error;
  d["command"] = info.command;
  d["depends_on"] = names(info.depends_on);
  d["members"] = names(info.members);
  return d;
}

}  // namespace

// Raises links_and_nodes.LNError as the rest of the module does: (message, code, 0).
[[noreturn]] void raise_ln_error(nb::handle ln_error, int ret, const std::string& what, ln_client handle) {
  std::string message = what + ": " + ln_format_error(ret);
  const char* detail = ln_get_error_message(handle);
  if (detail != nullptr && *detail != '\0') message += ": " + std::string(detail);
  PyObject* args = Py_BuildValue("(sii)", message.c_str(), ret < 0 ? -ret : ret, 0);
  PyErr_SetObject(ln_error.ptr(), args);
  Py_XDECREF(args);
  throw nb::python_error();
}

namespace {

// One ln_list_* call with the GIL released, its rows as dicts.
template <typename Row>
nb::list list_of(WithClient with_client, nb::handle ln_error, nb::handle client, const char* what,
                 int (*list)(ln_client, Row**, unsigned int*)) {
  nb::list out;
  with_client(client, [&](ln_client handle) {
    Row* rows = nullptr;
    unsigned int count = 0;
    const int ret = without_gil([&] { return list(handle, &rows, &count); });
    if (ret < 0) raise_ln_error(ln_error, ret, what, handle);
    const std::unique_ptr<Row, FreeList> owned(rows);
    for (unsigned int i = 0; i < count; ++i) out.append(as_dict(rows[i]));
  });
  return out;
}

}  // namespace

void register_introspection(nb::module_& module, WithClient with_client) {
  nb::object ln_error = module.attr("LNError");
  module.def(
      "list_topics",
      [with_client, ln_error](nb::handle client) {
        return list_of(with_client, ln_error, client, "list_topics", ln_list_topics);
      },
      "client"_a, "The topics the manager knows, as dicts (see links_and_nodes.topic_info).");
  module.def(
      "list_clients",
      [with_client, ln_error](nb::handle client) {
        return list_of(with_client, ln_error, client, "list_clients", ln_list_clients);
      },
      "client"_a, "The registered clients, as dicts (see links_and_nodes.client_info).");
  module.def(
      "list_services",
      [with_client, ln_error](nb::handle client) {
        return list_of(with_client, ln_error, client, "list_services", ln_list_services);
      },
      "client"_a, "The registered services, as dicts (see links_and_nodes.service_info).");
  module.def(
      "manager_status",
      [with_client, ln_error](nb::handle client) {
        nb::dict out;
        with_client(client, [&](ln_client handle) {
          ln_manager_status* status = nullptr;
          const int ret = without_gil([&] { return ln_get_manager_status(handle, &status); });
          if (ret < 0) raise_ln_error(ln_error, ret, "get_manager_status", handle);
          const std::unique_ptr<ln_manager_status, FreeList> owned(status);
          out = as_dict(*status);
        });
        return out;
      },
      "client"_a, "The manager's status as a dict (see links_and_nodes.manager_status).");
  module.def(
      "list_processes",
      [with_client, ln_error](nb::handle client) {
        return list_of(with_client, ln_error, client, "list_processes", ln_list_processes);
      },
      "client"_a, "The manager's processes, states and groups, as dicts (see links_and_nodes.process_info).");
  module.def(
      "control_process",
      [with_client, ln_error](nb::handle client, const std::string& name, const std::string& action,
                              const std::string& alt_command) {
        with_client(client, [&](ln_client handle) {
          const int ret = without_gil(
              [&] { return ln_control_process(handle, name.c_str(), action.c_str(), alt_command.c_str()); });
          if (ret < 0) raise_ln_error(ln_error, ret, "control_process('" + name + "', '" + action + "')", handle);
        });
      },
      "client"_a, "name"_a, "action"_a, "alt_command"_a = "",
      "Asks the manager to start/stop/restart a process or group, or up/down/check a state.");
  module.def(
      "process_output",
      [with_client, ln_error](nb::handle client, const std::string& name, std::uint64_t after) {
        nb::dict out;
        with_client(client, [&](ln_client handle) {
          ln_process_output* output = nullptr;
          const int ret = without_gil([&] { return ln_get_process_output(handle, name.c_str(), after, &output); });
          if (ret < 0) raise_ln_error(ln_error, ret, "get_process_output('" + name + "')", handle);
          const std::unique_ptr<ln_process_output, FreeList> owned(output);
          out["lines"] = names(output->lines);
          out["first"] = output->first;
          out["last"] = output->last;
          out["dropped"] = output->dropped;
        });
        return out;
      },
      "client"_a, "name"_a, "after"_a = 0,
      "Output lines of a process or state numbered after `after`, as a dict (see links_and_nodes.process_output).");
}

}  // namespace lnpy
