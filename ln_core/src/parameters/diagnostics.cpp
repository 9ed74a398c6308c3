#include "parameters/diagnostics.hpp"

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace ln::paramcore {

bool debugging_parameters() {
  static const bool enabled = [] {
    const char* value = std::getenv("LN_PARAMETER_DEBUG");
    return value != nullptr && value[0] != '\0' && std::strcmp(value, "0") != 0;
  }();
  return enabled;
}

void debug_log(ln_client clnt, const char* format, ...) {
  if (!debugging_parameters()) return;
  char text[1024];
  va_list args;
  va_start(args, format);
  std::vsnprintf(text, sizeof text, format, args);
  va_end(args);
  char* name = nullptr;
  if (clnt == nullptr || ln_client_get_name(clnt, &name) != 0 || name == nullptr) name = const_cast<char*>("?");
  // LN_PARAMETER_DEBUG output is documented library behaviour (ln/parameters_c.h).
  std::fprintf(stderr, "ln_parameters %s: %s\n", name, text);
}

}  // namespace ln::paramcore
