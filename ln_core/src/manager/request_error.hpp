// The one way a request handler refuses: an LNE_* code for programs and a
// text for people. The manager turns it into an error response.
#pragma once

#include <stdexcept>
#include <string>

#ifndef NO_CPP_WRAPPER
#define NO_CPP_WRAPPER  // only the C declarations (the LNE_* codes) are needed
#endif
#include "ln/ln.h"

namespace ln::manager {

class RequestError : public std::runtime_error {
 public:
  RequestError(int code, const std::string& text) : std::runtime_error(text), code_(code) {}
  /// A positive LNE_* value.
  int code() const { return code_; }

 private:
  int code_;
};

}  // namespace ln::manager
