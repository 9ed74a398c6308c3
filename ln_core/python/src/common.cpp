// links_and_nodes._ln: LN errors (see common.hpp).
#include "common.hpp"

#include <exception>
#include <string>

#include "model.hpp"

namespace lnpy {
namespace {

PyObject* LNError = nullptr;

// LN 2.9's Python raises plain Exceptions whose text names the error
// ("...: LNE_SVC_TIMEOUT - ..."), so programs match that text: every
// LNError's text names its LNE_* code too.
std::string naming_the_code(std::string message, int code) {
  if (message.find("LNE_") != std::string::npos) return message;
  const std::string formatted = ln_format_error(-code);
  return message + " (" + formatted.substr(0, formatted.find(' ')) + ")";
}

}  // namespace

[[noreturn]] void fail(int ret, const std::string& what, ln_client clnt) {
  std::string message = what + ": " + ln_format_error(ret);
  if (clnt != nullptr) {
    const char* detail = ln_get_error_message(clnt);
    if (detail != nullptr && *detail != '\0') message += ": " + std::string(detail);
  }
  throw Failure{ret < 0 ? -ret : ret, message};
}

// Names and texts go to the C API as C strings, where a NUL byte would cut
// them: "a.b\0x" would silently publish "a.b".
void require_no_nul(const std::string& value, const char* what) {
  if (value.find('\0') != std::string::npos)
    throw nb::value_error((std::string(what) + " must not contain NUL bytes: " +
                           std::string(nb::repr(nb::str(value.data(), value.size())).c_str()))
                              .c_str());
}
void require_no_nul(const std::optional<std::string>& value, const char* what) {
  if (value) require_no_nul(*value, what);
}

[[noreturn]] void throw_closed() { throw Failure{LNE_CLIENT_NOT_INITIALIZED, "the client was closed"}; }

void register_errors(nb::module_& m) {
  LNError = PyErr_NewExceptionWithDoc("links_and_nodes._ln.LNError",
                                      "An LN operation failed. args: (message, code, user_code): code is the LNE_* "
                                      "number; user_code the provider's own error code (LNE_USER_DEFINED_ERROR).",
                                      PyExc_Exception, nullptr);
  m.attr("LNError") = nb::handle(LNError);
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const Failure& f) {
      PyObject* args = Py_BuildValue("(sii)", naming_the_code(f.message, f.code).c_str(), f.code, f.user_code);
      PyErr_SetObject(LNError, args);
      Py_XDECREF(args);
    } catch (const ln::md::Error& e) {
      PyObject* args = Py_BuildValue("(sii)", naming_the_code(e.what(), LNE_INVALID_PARAMETER).c_str(),
                                     static_cast<int>(LNE_INVALID_PARAMETER), 0);
      PyErr_SetObject(LNError, args);
      Py_XDECREF(args);
    }
  });
}

}  // namespace lnpy
