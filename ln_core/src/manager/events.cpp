#include "manager/events.hpp"

#include <fnmatch.h>

#include <cstdint>

#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

// Patterns are short; a filter beyond this is not a filter.
constexpr std::size_t kMaxPatternSize = 4096;

void put_string(std::string& out, std::string_view text) {
  const auto size = static_cast<std::uint32_t>(text.size());
  for (int shift = 0; shift < 32; shift += 8) out += static_cast<char>((size >> shift) & 0xff);  // little endian
  out += text;
}

}  // namespace

ResourceFilter parse_resource_filter(std::string_view flat) {
  static const char* const names[] = {"event_pattern", "name_pattern", "md_pattern", "client_pattern"};
  ResourceFilter filter;
  for (std::size_t i = 0; i < filter.size(); ++i) {
    if (flat.size() < 4)
      throw RequestError(LNE_INVALID_PARAMETER,
                         std::string("connect data of ln.resource_event ends before ") + names[i]);
    std::uint32_t size = 0;
    for (int byte = 3; byte >= 0; --byte) size = size << 8 | static_cast<std::uint8_t>(flat[byte]);
    flat.remove_prefix(4);
    if (size > flat.size() || size > kMaxPatternSize)
      throw RequestError(LNE_INVALID_PARAMETER, std::string("connect data of ln.resource_event: ") + names[i] +
                                                    " is longer than the data (or 4 KiB)");
    filter[i] = std::string(flat.substr(0, size));
    flat.remove_prefix(size);
  }
  if (!flat.empty())
    throw RequestError(LNE_INVALID_PARAMETER,
                       "connect data of ln.resource_event has " + std::to_string(flat.size()) + " bytes too many");
  return filter;
}

bool glob_match(const std::string& pattern, const std::string& text) {
  return ::fnmatch(pattern.c_str(), text.c_str(), FNM_NOESCAPE) == 0;
}

bool filter_accepts(const ResourceFilter& filter, const ResourceEvent& event) {
  if (event.event == kInitialSyncDone) return true;
  const std::string_view values[] = {event.event, event.name, event.md, event.client};
  for (std::size_t i = 0; i < filter.size(); ++i)
    if (!glob_match(filter[i], std::string(values[i]))) return false;
  return true;
}

std::string flatten_resource_event(const ResourceEvent& event) {
  std::string flat;
  for (std::string_view text : {event.event, event.name, event.md, event.client}) put_string(flat, text);
  return flat;
}

}  // namespace ln::manager
