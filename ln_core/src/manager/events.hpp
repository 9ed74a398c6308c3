// The one event the manager provides itself, as LN 2.9's does:
// "ln.resource_event" (definition ln/resource_event). A client connects with
// four fnmatch patterns (event kind, resource name, definition, client name)
// and then hears of every service provider and topic publisher or
// subscriber that comes or goes and matches all four:
//   service_new_provider / service_del_provider   name = service, md = interface
//   topic_new_publisher / topic_del_publisher     name = topic, md = definition
//   topic_new_subscriber / topic_del_subscriber   (client = the subscriber)
// Right after connecting it hears of every provider and publisher that
// exists (the "initial sync", client by client: services, then topics),
// then "initial_sync_done" (which no pattern filters). Events travel in the
// flat form of the definition's call section (four strings); the client
// library hands them to the connection's handler service (see
// methods.hpp: connect_event, event).
#pragma once

#include <array>
#include <string>
#include <string_view>

namespace ln::manager {

inline constexpr std::string_view kResourceEventName = "ln.resource_event";
/// Both sections of ln/resource_event: four char* fields.
inline constexpr std::string_view kResourceEventSignature =
    "uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1,uint32_t 4 1,char* 1 1";
inline constexpr std::string_view kInitialSyncDone = "initial_sync_done";

/// Python's fnmatch.fnmatch (what LN 2.9's manager uses for event filters
/// and service logger patterns): *, ?, [seq], [!seq], case-sensitive, no
/// escapes.
bool glob_match(const std::string& pattern, const std::string& text);

/// event_pattern, name_pattern, md_pattern, client_pattern.
using ResourceFilter = std::array<std::string, 4>;

struct ResourceEvent {
  std::string_view event;  ///< e.g. "service_new_provider"
  std::string_view name;
  std::string_view md;
  std::string_view client;
};

/// The filter in the flat connect data; throws RequestError
/// (LNE_INVALID_PARAMETER) if it is not four well-formed strings.
ResourceFilter parse_resource_filter(std::string_view flat);
/// True if every pattern matches (Python's fnmatch: *, ?, [seq], [!seq],
/// case-sensitive, no escapes); initial_sync_done always passes.
bool filter_accepts(const ResourceFilter& filter, const ResourceEvent& event);
/// The flat call data of `event`.
std::string flatten_resource_event(const ResourceEvent& event);

}  // namespace ln::manager
