// links_and_nodes._ln: constants and module-level functions (errors, time,
// DSA signatures, the md model from sources or directories).
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "common.hpp"
#include "model.hpp"

using namespace nb::literals;

namespace lnpy {

void register_functions(nb::module_& m) {
  m.attr("LN_LIBRARY_VERSION") = LN_LIBRARY_VERSION;
  m.attr("RATE_AS_PUBLISHED") = RATE_AS_PUBLISHED;
  m.attr("RATE_ON_REQUEST_LAST") = RATE_ON_REQUEST_LAST;
  m.def("format_error", [](int code) { return std::string(ln_format_error(code)); });
  m.def("get_time", &ln_get_time);
  m.def("get_monotonic_time", &ln_get_monotonic_time);
  m.def("library_version", &ln_get_library_version);

  // DSA helpers (LN 2.9's Python has these two): a failure names the file
  // and, for file errors, errno's reason.
  auto check_dsa = [](int ret, const std::string& what) {
    if (ret == -LNE_CHECK_ERRNO) fail(ret, what + " (" + std::strerror(errno) + ")");
    if (ret < 0) fail(ret, what);
  };
  m.def(
      "dsa_dss1_sign_message",
      [check_dsa](const std::string& key_file, nb::handle message) {
        if (!PyBytes_Check(message.ptr()))
          throw nb::value_error("dsa_dss1_sign_message: message is not a bytes object");
        uint8_t* signature = nullptr;
        unsigned int length = 0;
        check_dsa(ln_dsa_dss1_sign_message(
                      key_file.c_str(), reinterpret_cast<const uint8_t*>(PyBytes_AS_STRING(message.ptr())),
                      static_cast<unsigned int>(PyBytes_GET_SIZE(message.ptr())), &signature, &length),
                  "dsa_dss1_sign_message('" + key_file + "')");
        nb::bytes out(reinterpret_cast<const char*>(signature), length);
        std::free(signature);
        return out;
      },
      "pem_private_key_file"_a, "message"_a, "The DSA/SHA-1 signature (DER) of `message` (bytes).");
  m.def(
      "dsa_dss1_generate_key_pair",
      [check_dsa](const std::string& private_file, const std::string& public_file) {
        check_dsa(ln_dsa_dss1_generate_key_pair(private_file.c_str(), public_file.c_str()),
                  "dsa_dss1_generate_key_pair('" + private_file + "', '" + public_file + "')");
      },
      "pem_private_key_file"_a, "openssh_public_key_file"_a,
      "Writes a new DSA key pair: PEM private key (mode 0600), OpenSSH public key.");

  m.def(
      "model_from_sources",
      [](const std::string& name, const std::map<std::string, std::string>& sources) {
        return build_model(name, std::nullopt, [&](const std::string& wanted) -> std::optional<std::string> {
          auto it = sources.find(wanted);
          if (it == sources.end()) return std::nullopt;
          return it->second;
        });
      },
      "name"_a, "sources"_a, "The model of definition `name` built from {name: text}.");
  m.def(
      "model_from_dirs",
      [](const std::string& name, const std::vector<std::string>& dirs) {
        ln::md::Library library(ln::md::SearchPath::exactly(dirs));
        return definition_to_python(library.load(name));
      },
      "name"_a, "dirs"_a, "The model of definition `name` found in `dirs`.");
}

}  // namespace lnpy
