// links_and_nodes._ln: the native side of Python parameter providers
// (links_and_nodes.ParameterBlock) over ln/parameters_c.h. The block keeps
// each parameter's input and output as bytes in the parameter's element
// type (row-major); the Python side packs and unpacks them with numpy.
#pragma once

#include <nanobind/nanobind.h>

#include "introspection.hpp"

namespace lnpy {

/// Adds the class ParameterBlockBridge to `module` (whose LNError must exist).
void register_parameters(nanobind::module_& module, WithClient with_client);

}  // namespace lnpy
