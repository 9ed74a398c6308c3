// links_and_nodes._ln: the thin native layer of the Python package over
// libln's C API (ln/ln.h) and the md model. Everything friendly lives in the
// pure-Python package; this layer only moves bytes and handles, releases the
// GIL while waiting and turns LN error codes into LNError.
//
// Waiting calls (read, multi-waiter wait, service calls, group handling) run
// in slices of at most kSlice seconds with the GIL released and check for
// Python signals between slices, so Ctrl-C interrupts them.
//
// One file per wrapped object (client.cpp, ports.cpp, multi_waiter.cpp,
// services.cpp, events.cpp, ...; shared helpers in common.hpp); this file
// makes the module from their parts.
#include <nanobind/nanobind.h>

#include <functional>

#include "client.hpp"
#include "introspection.hpp"
#include "loggers.hpp"
#include "parameters.hpp"

using namespace lnpy;

NB_MODULE(_ln, m) {
  m.doc() = "Native layer of links_and_nodes on ln_core's libln (thin; use the links_and_nodes package).";

  register_errors(m);
  register_functions(m);
  register_client(m);
  register_events(m);
  register_ports(m);
  register_multi_waiter(m);
  register_services(m);

  const WithClient with_client = [](nb::handle client, const std::function<void(ln_client)>& body) {
    Client& native = nb::cast<Client&>(client);
    Use use(*native.state());
    body(native.handle());
  };
  register_introspection(m, with_client);
  register_loggers(m, with_client);
  register_parameters(m, with_client);
}
