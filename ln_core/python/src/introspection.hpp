// links_and_nodes._ln: introspection -- what the manager knows -- over ln.h's
// ln_list_topics(), ln_list_clients(), ln_list_services() and
// ln_get_manager_status(). module.cpp owns the client objects and lends
// their handles through a WithClient function.
#pragma once

#include <functional>
#include <string>

#include <nanobind/nanobind.h>

#include "ln/ln.h"

namespace lnpy {

/// Runs `body` with the ln_client of `client` (a links_and_nodes._ln.Client)
/// while a concurrent close() waits; raises LNError if it is closed.
using WithClient = void (*)(nanobind::handle client, const std::function<void(ln_client)>& body);

/// Raises `ln_error` (links_and_nodes.LNError) as the module does: (message,
/// code, 0), the message naming `what`, the code and the client's detail
/// (ln_get_error_message(handle); handle NULL: the detail of this thread's
/// last failed call without client).
[[noreturn]] void raise_ln_error(nanobind::handle ln_error, int ret, const std::string& what, ln_client handle);

/// Adds list_topics(client), list_clients(client), list_services(client),
/// list_processes(client) (lists of dicts), manager_status(client) and
/// process_output(client, name, after) (dicts), control_process(client,
/// name, action, alt_command) to `module`, whose LNError must exist
/// already. The dict keys are the field names of links_and_nodes.topic_info,
/// client_info, service_info, manager_status, process_info and
/// process_output.
void register_introspection(nanobind::module_& module, WithClient with_client);

}  // namespace lnpy
