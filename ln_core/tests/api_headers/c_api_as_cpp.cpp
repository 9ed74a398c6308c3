// The C API alone, seen from C++: <ln/ln.h> with NO_CPP_WRAPPER must not
// pull in the wrapper, and every C declaration must be valid C++ too.
#define NO_CPP_WRAPPER
#include "c_api_compiles.c"

#ifdef LN_CPPWRAPPER_H
#error "NO_CPP_WRAPPER must keep ln/cppwrapper.h out"
#endif
