#include "manager/names.hpp"

#include "ln/md/message_definition.hpp"

namespace ln::manager {
namespace {

bool is_allowed_port_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
         c == ':' || c == '-' || c == ' ';
}

std::string quoted(std::string_view name) {
  // Names in error texts may come straight from a client: show them, but
  // never let control characters through into a terminal.
  std::string out = "'";
  for (char c : name.substr(0, 200)) out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) ? '?' : c;
  if (name.size() > 200) out += "...";
  return out + "'";
}

std::optional<std::string> port_name_problem(std::string_view kind, std::string_view name) {
  const std::string what = std::string(kind) + " name " + quoted(name);
  if (name.empty()) return std::string(kind) + " name must not be empty";
  if (name.size() > max_port_name_size)
    return what + " is " + std::to_string(name.size()) + " bytes long; the limit is " +
           std::to_string(max_port_name_size);
  for (char c : name) {
    if (c == '/') return what + " contains '/', which " + std::string(kind) + " names must not contain";
    if (!is_allowed_port_name_char(c))
      return what + " contains a character other than letters, digits, '_', '.', ':', '-' and space";
  }
  if (name.front() == '.' || name.back() == '.') return what + " must not start or end with '.'";
  if (name.front() == ' ' || name.back() == ' ') return what + " must not start or end with a space";
  if (name.find("..") != std::string_view::npos) return what + " contains an empty namespace ('..')";
  return std::nullopt;
}

}  // namespace

std::optional<std::string> topic_name_problem(std::string_view name) { return port_name_problem("topic", name); }

std::optional<std::string> service_name_problem(std::string_view name) { return port_name_problem("service", name); }

std::optional<std::string> client_name_problem(std::string_view name) {
  if (name.empty()) return std::string("client name must not be empty");
  if (name.size() > max_client_name_size)
    return "client name is " + std::to_string(name.size()) + " bytes long; the limit is " +
           std::to_string(max_client_name_size);
  for (char c : name)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      return "client name " + quoted(name) + " contains control characters";
  return std::nullopt;
}

std::optional<std::string> definition_name_problem(std::string_view name) {
  constexpr std::size_t max_size = 1024;
  if (name.empty()) return std::string("message-definition name must not be empty");
  if (name.size() > max_size) return "message-definition name is longer than " + std::to_string(max_size) + " bytes";
  for (char c : name)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      return "message-definition name " + quoted(name) + " contains control characters";
  if (!md::is_valid_definition_name(name))
    return "message-definition name " + quoted(name) +
           " is not valid (a relative, '/'-separated name without empty, '.' or '..' parts)";
  return std::nullopt;
}

std::string unique_client_name(const std::string& requested, const std::function<bool(const std::string&)>& is_taken) {
  if (!is_taken(requested)) return requested;
  for (unsigned long counter = 1;; ++counter) {
    std::string candidate = requested + " " + std::to_string(counter);
    if (!is_taken(candidate)) return candidate;
  }
}

std::pair<std::string, std::string> split_name_and_hash(std::string_view name_with_hash) {
  const auto bar = name_with_hash.find('|');
  if (bar == std::string_view::npos) return {std::string(name_with_hash), ""};
  return {std::string(name_with_hash.substr(0, bar)), std::string(name_with_hash.substr(bar + 1))};
}

}  // namespace ln::manager
