// The C declarations of <ln/ln.h> (error codes, handle types) for the
// library's own code, without the C++ wrapper that ln.h pulls in otherwise.
#pragma once

#ifndef NO_CPP_WRAPPER
#define NO_CPP_WRAPPER
#endif
#include <ln/ln.h>
