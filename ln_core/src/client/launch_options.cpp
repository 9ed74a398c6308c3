#include "client/launch_options.hpp"

#include <cstring>

namespace ln::clientlib {
namespace {

// LN accepts each option in a GNU spelling and in its historical one.
bool is_option(const char* arg, const char* gnu, const char* legacy) {
  return std::strcmp(arg, gnu) == 0 || std::strcmp(arg, legacy) == 0;
}

}  // namespace

CommandLine parse_command_line(int argc, const char* const* argv, bool exact_name) {
  CommandLine parsed;
  if (argv == nullptr) return parsed;
  for (int i = 0; i < argc; ++i) {
    const char* arg = argv[i];
    if (arg == nullptr) break;
    const int values_left = argc - i - 1;
    if (i > 0 && values_left >= 1 && is_option(arg, "--ln-manager", "-ln_manager")) {
      parsed.manager_address = argv[++i];
    } else if (i > 0 && values_left >= 1 && !exact_name && is_option(arg, "--ln-program-name", "-ln_program_name")) {
      parsed.program_name = argv[++i];
    } else if (i > 0 && values_left >= 2 && is_option(arg, "--ln-map-topic", "-ln_map_topic")) {
      parsed.topic_mappings.push_back({argv[i + 1], argv[i + 2]});
      i += 2;
    } else if (i > 0 && values_left >= 2 && is_option(arg, "--ln-map-service", "-ln_map_service")) {
      parsed.service_mappings.push_back({argv[i + 1], argv[i + 2]});
      i += 2;
    } else {
      parsed.remaining.emplace_back(arg);
    }
  }
  return parsed;
}

std::optional<std::string> choose_manager_address(const std::optional<std::string>& explicit_address,
                                                  const char* ln_manager_env) {
  if (explicit_address && !explicit_address->empty()) return explicit_address;
  if (ln_manager_env != nullptr && ln_manager_env[0] != '\0') return std::string(ln_manager_env);
  return std::nullopt;
}

RequestedName choose_client_name(const char* name_in_code, const char* program_name_env,
                                 const std::optional<std::string>& program_name_argument, const std::string& fallback) {
  static constexpr char kExact[] = "exact:";
  const std::string in_code = name_in_code != nullptr ? name_in_code : "";
  if (in_code.compare(0, sizeof kExact - 1, kExact) == 0) {
    RequestedName exact{in_code.substr(sizeof kExact - 1), true};
    if (exact.name.empty()) exact.name = fallback;
    return exact;
  }
  RequestedName chosen{in_code, false};
  if (program_name_env != nullptr && program_name_env[0] != '\0') chosen.name = program_name_env;
  if (program_name_argument && !program_name_argument->empty()) chosen.name = *program_name_argument;
  if (chosen.name.empty()) chosen.name = fallback;
  return chosen;
}

}  // namespace ln::clientlib
