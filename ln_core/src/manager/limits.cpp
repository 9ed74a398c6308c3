#include "manager/limits.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace ln::manager {
namespace {

enum class Unit { Bytes, Seconds, Count };

struct Entry {
  const char* key;
  Unit unit;
  const char* description;
  std::size_t ManagerLimits::*size_field = nullptr;
  std::uint64_t ManagerLimits::*u64_field = nullptr;
  double ManagerLimits::*seconds_field = nullptr;
};

const Entry entries[] = {
    {"max_clients", Unit::Count, "connections, registered or not", &ManagerLimits::max_clients},
    {"max_request_size", Unit::Bytes, "largest request", &ManagerLimits::max_request_size},
    {"max_output_queue", Unit::Bytes, "unsent messages of one client", &ManagerLimits::max_output_queue},
    {"max_total_input", Unit::Bytes, "partly received requests of all connections", &ManagerLimits::max_total_input},
    {"max_total_output", Unit::Bytes, "unsent messages of all clients", &ManagerLimits::max_total_output},
    {"handshake_timeout", Unit::Seconds, "time a new connection has to register (hello)", nullptr, nullptr,
     &ManagerLimits::handshake_timeout},
    {"pending_idle_timeout", Unit::Seconds, "silence allowed to an unregistered connection", nullptr, nullptr,
     &ManagerLimits::pending_idle_timeout},
    {"max_pending", Unit::Count, "unregistered connections", &ManagerLimits::max_pending},
    {"max_pending_per_peer", Unit::Count, "unregistered connections from one IP address",
     &ManagerLimits::max_pending_per_peer},
    {"max_ports_per_client", Unit::Count, "topics one client publishes, its subscriptions and services",
     &ManagerLimits::max_ports_per_client},
    {"max_topic_shm", Unit::Bytes, "shared memory of one topic (buffers x packet size)", nullptr,
     &ManagerLimits::max_topic_shm},
    {"max_client_shm", Unit::Bytes, "shared memory of all topics one client publishes", nullptr,
     &ManagerLimits::max_client_shm},
    {"max_stored_definitions", Unit::Count, "files in the generated-definitions directory",
     &ManagerLimits::max_stored_definitions},
    {"max_stored_definition_bytes", Unit::Bytes, "bytes in the generated-definitions directory", nullptr,
     &ManagerLimits::max_stored_definition_bytes},
    {"max_definitions_per_client", Unit::Count, "new definition texts one client may put",
     &ManagerLimits::max_definitions_per_client},
};

const Entry* find(std::string_view key) {
  for (const Entry& entry : entries)
    if (key == entry.key) return &entry;
  return nullptr;
}

const char* value_text(Unit unit) {
  switch (unit) {
    case Unit::Bytes:
      return "BYTES";
    case Unit::Seconds:
      return "SECONDS";
    case Unit::Count:
      return "COUNT";
  }
  return "?";
}

std::string number_text(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", value);
  return buffer;
}

// "256M" -> bytes; counts take no suffix.
std::uint64_t parse_unsigned(std::string_view key, std::string_view text, bool with_suffix) {
  std::uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  std::string_view rest(end, static_cast<std::size_t>(text.data() + text.size() - end));
  unsigned shift = 0;
  if (with_suffix && rest.size() == 1) {
    switch (rest.front()) {
      case 'K':
      case 'k':
        shift = 10;
        break;
      case 'M':
      case 'm':
        shift = 20;
        break;
      case 'G':
      case 'g':
        shift = 30;
        break;
      default:
        shift = 64;
    }
    if (shift != 64) rest.remove_prefix(1);
  }
  if (error != std::errc() || !rest.empty() || text.empty() || (shift != 0 && value > (~std::uint64_t{0} >> shift)))
    throw std::invalid_argument(
        std::string(key) + ": '" + std::string(text) + "' is not " +
        (with_suffix ? "a byte count (a whole number, optionally with K, M or G)" : "a whole number"));
  return value << shift;
}

std::string default_text(const Entry& entry) {
  const ManagerLimits defaults;
  if (entry.seconds_field) return number_text(defaults.*entry.seconds_field);
  const std::uint64_t value = entry.size_field ? defaults.*entry.size_field : defaults.*entry.u64_field;
  if (entry.unit == Unit::Bytes) {
    for (const auto& [shift, suffix] : {std::pair{30u, "G"}, {20u, "M"}, {10u, "K"}})
      if (value != 0 && value % (std::uint64_t{1} << shift) == 0) return std::to_string(value >> shift) + suffix;
  }
  return std::to_string(value);
}

}  // namespace

const std::vector<LimitInfo>& limit_table() {
  static const std::vector<LimitInfo> table = [] {
    std::vector<LimitInfo> out;
    for (const Entry& entry : entries)
      out.push_back({entry.key, value_text(entry.unit), entry.description, default_text(entry)});
    return out;
  }();
  return table;
}

bool is_limit_key(std::string_view key) { return find(key) != nullptr; }

void set_limit(ManagerLimits& limits, std::string_view key, std::string_view value) {
  const Entry* entry = find(key);
  if (!entry) throw std::invalid_argument("'" + std::string(key) + "' is not a limit of the manager");
  if (entry->seconds_field) {
    double seconds = 0;
    const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), seconds);
    if (error != std::errc() || end != value.data() + value.size() || !std::isfinite(seconds) || seconds <= 0)
      throw std::invalid_argument(std::string(key) + ": '" + std::string(value) +
                                  "' is not a positive number of seconds");
    limits.*entry->seconds_field = seconds;
    return;
  }
  const std::uint64_t number = parse_unsigned(key, value, entry->unit == Unit::Bytes);
  if (number == 0) throw std::invalid_argument(std::string(key) + ": must be at least 1");
  if (entry->size_field) {
    if (number > std::numeric_limits<std::size_t>::max())
      throw std::invalid_argument(std::string(key) + ": '" + std::string(value) + "' is too large");
    limits.*entry->size_field = static_cast<std::size_t>(number);
  } else {
    limits.*entry->u64_field = number;
  }
}

std::string byte_text(std::uint64_t bytes) {
  if (bytes < 1024) return std::to_string(bytes) + " bytes";
  const char* units[] = {"KiB", "MiB", "GiB", "TiB"};
  double value = static_cast<double>(bytes) / 1024;
  int unit = 0;
  while (value >= 1024 && unit < 3) {
    value /= 1024;
    ++unit;
  }
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, value < 10 && value != std::floor(value) ? "%.1f %s" : "%.0f %s", value,
                units[unit]);
  return buffer;
}

}  // namespace ln::manager
