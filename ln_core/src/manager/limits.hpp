// The manager's limits (ManagerLimits) by name: one table for the .lnc
// `instance` keys (max_topic_shm: 64M), the ln_manager options
// (--max-topic-shm 64M) and the help text, so all three always agree.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "manager/manager.hpp"

namespace ln::manager {

struct LimitInfo {
  std::string key;          ///< .lnc key; the option is "--" + key with '-' for '_'
  std::string value_text;   ///< what the value is: "BYTES", "SECONDS", "COUNT"
  std::string description;  ///< one line
  std::string default_text; ///< the default, as written in a config
};

/// Every limit, in the order of the help text.
const std::vector<LimitInfo>& limit_table();
bool is_limit_key(std::string_view key);
/// Sets the limit `key` of `limits` from `value`: a count, seconds (may
/// have a fraction), or bytes with an optional K, M or G suffix (powers of
/// 1024). Throws std::invalid_argument with a message that names the key
/// and says what is expected.
void set_limit(ManagerLimits& limits, std::string_view key, std::string_view value);
/// "4 KiB", "256 MiB", "1.5 GiB": a byte count for messages.
std::string byte_text(std::uint64_t bytes);

}  // namespace ln::manager
