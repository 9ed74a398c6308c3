// The dispatcher's requests about processes, states and groups
// (methods.hpp: process_list, process_control, process_output,
// needs_provider), over ProcessControl.
#include <cmath>
#include <limits>

#include "manager/dispatch.hpp"
#include "manager/process_control.hpp"
#include "manager/request_error.hpp"
#include "protocol/methods.hpp"

namespace ln::manager {
namespace {

using protocol::Message;
using protocol::StringList;

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ",") + item;
  return out;
}

}  // namespace

Message Dispatcher::process_list(Session&, const Message& request, Outbox&) {
  StringList names, kinds, states, requested, pids, uptimes, restarts, ready, last_exits, errors, commands, depends,
      members;
  if (process_control_ != nullptr) {
    for (const ObjectStatus& row : process_control_->status()) {
      names.push_back(row.name);
      kinds.push_back(row.kind);
      states.push_back(row.state);
      requested.push_back(row.requested);
      pids.push_back(std::to_string(row.pid));
      uptimes.push_back(shortest_text(std::round(row.uptime * 1000) / 1000));
      restarts.push_back(std::to_string(row.restarts));
      ready.push_back(row.ready ? "1" : "0");
      last_exits.push_back(row.last_exit);
      errors.push_back(row.error);
      commands.push_back(row.command);
      depends.push_back(joined(row.depends_on));
      members.push_back(joined(row.members));
    }
  }
  return Message::response_to(request)
      .set("names", std::move(names))
      .set("kinds", std::move(kinds))
      .set("states", std::move(states))
      .set("requested", std::move(requested))
      .set("pids", std::move(pids))
      .set("uptimes", std::move(uptimes))
      .set("restarts", std::move(restarts))
      .set("ready", std::move(ready))
      .set("last_exits", std::move(last_exits))
      .set("errors", std::move(errors))
      .set("commands", std::move(commands))
      .set("depends_on", std::move(depends))
      .set("members", std::move(members));
}

Message Dispatcher::process_control(Session&, const Message& request, Outbox&) {
  const std::string name = request.get_string("name");
  const std::string action = request.get_string("action");
  if (process_control_ == nullptr)
    throw RequestError(LNE_INVALID_PARAMETER, "there is no process, state or group '" + name +
                                                  "' (this manager was started without a config that has any)");
  process_control_->request(name, action, request.get_string_or("alt_command", ""));
  return Message::response_to(request);
}

Message Dispatcher::process_output(Session&, const Message& request, Outbox&) {
  const std::string name = request.get_string("name");
  const auto after = request.get_int("after", 0, std::numeric_limits<std::int64_t>::max());
  const auto max_lines = request.get_int_or("max_lines", 0);
  if (max_lines < 0) throw RequestError(LNE_INVALID_PARAMETER, "max_lines must not be negative");
  if (process_control_ == nullptr)
    throw RequestError(LNE_INVALID_PARAMETER, "there is no process or state '" + name + "'");
  OutputRing::Slice slice =
      process_control_->output(name, static_cast<std::uint64_t>(after), static_cast<std::size_t>(max_lines));
  return Message::response_to(request)
      .set("lines", std::move(slice.lines))
      .set("first", static_cast<std::int64_t>(slice.first))
      .set("last", static_cast<std::int64_t>(slice.last))
      .set("dropped", static_cast<std::int64_t>(slice.dropped));
}

Message Dispatcher::needs_provider(Session&, const Message& request, Outbox&) {
  const std::string name = request.get_string("name");
  for (const auto& entry : registry_.services())
    if (entry.second.name == name) return Message::response_to(request).set("provider", "");
  for (const auto& entry : registry_.topics())
    if (entry.second.name == name && entry.second.publisher) return Message::response_to(request).set("provider", "");
  if (process_control_ == nullptr)
    throw RequestError(LNE_NO_PROVIDER_FOUND,
                       "nothing provides '" + name + "': no client offers it and this manager runs no processes");
  return Message::response_to(request).set("provider", process_control_->start_provider(name));
}

}  // namespace ln::manager
