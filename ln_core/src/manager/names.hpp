// Name rules of the manager (ln_spec §5.3, §5.6).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>

namespace ln::manager {

/// Longest topic or service name; LN 2.9 clients parse names into 128-byte
/// buffers, so longer names could never be used by them.
constexpr std::size_t max_port_name_size = 127;
constexpr std::size_t max_client_name_size = 255;

/// Why `name` is not a valid topic name, or nullopt when it is. Topic names
/// are '.'-separated namespaces of [A-Za-z0-9_:-] and spaces (legacy).
std::optional<std::string> topic_name_problem(std::string_view name);
/// Same rules for service names (which never allow '/' either).
std::optional<std::string> service_name_problem(std::string_view name);
/// Client names are free text, but not empty, not huge and without control
/// characters (they appear in logs and introspection).
std::optional<std::string> client_name_problem(std::string_view name);
/// Message-definition names as given by clients (without "|hash"): the md
/// model's rules plus a size limit and printable characters, so no client
/// can make the manager read a file by path.
std::optional<std::string> definition_name_problem(std::string_view name);

/// `requested` if `is_taken` says it is free, else the first free
/// "requested 1", "requested 2", ... (LN's renaming rule).
std::string unique_client_name(const std::string& requested, const std::function<bool(const std::string&)>& is_taken);

/// Splits "name|hash" into name and hash ("" when there is none).
std::pair<std::string, std::string> split_name_and_hash(std::string_view name_with_hash);

}  // namespace ln::manager
