// links_and_nodes._ln: topic loggers over ln.h's ln_client_get_logger(),
// ln_logger_* and ln_logger_data_*. module.cpp owns the client objects and
// lends their handles (WithClient); the friendly LN 2.9 API
// (client.get_logger(), logger_data_wrapper, topic_cursor_wrapper) is
// links_and_nodes/_loggers.py.
#pragma once

#include <nanobind/nanobind.h>

#include "introspection.hpp"

namespace lnpy {

/// Adds get_logger(client, name) -> Logger and the classes Logger and
/// LoggerData (LoggerData.load(filename)) to `module`, whose LNError must
/// exist already.
void register_loggers(nanobind::module_& module, WithClient with_client);

}  // namespace lnpy
