// LN_PARAMETER_DEBUG: when set (and not "0"), providers and clients of
// parameters report registrations, overrides and look-ups on stderr, one
// line each ("ln_parameters <client>: ..."). Like LN_DEBUG, a documented
// switch; without it the library prints nothing.
#pragma once

#include "ln/ln.h"

namespace ln::paramcore {

bool debugging_parameters();
void debug_log(ln_client clnt, const char* format, ...) __attribute__((format(printf, 2, 3)));

}  // namespace ln::paramcore
