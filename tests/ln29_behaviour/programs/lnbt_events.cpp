// Event probe of the LN 2.9 behaviour tests (ln_event_*, the C++
// event_connection API and the generated ln::resource_event_base), written
// as for LN 2.9; compiled unchanged against LN 2.9 and ln_core, each run
// against its own system's manager.
//
// usage: lnbt_events PREFIX [LN options]
// One scenario; prints one line per observation:
//   "event <kind> <name> <md> <client> in <main|other> thread" for each
//   ln.resource_event (filtered to names PREFIX.*), first the initial sync
//   up to initial_sync_done, then what a second client of this program does;
//   "custom ..." for an event another client emits by calling the handler
//   service of a connection to PREFIX_custom; "<case> <LNE_NAME>" for the
//   error cases. On an unexpected exception: "error <LNE_NAME>" (exit 3).
#include <ln/ln.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "ln_messages.h"
#include "lnbt_errors.h"

namespace {

using lnbt::error_name;

pid_t main_thread = 0;
std::vector<std::string> lines;  // handlers run in this thread (the default group): no lock

std::string text(const char* data, uint32_t len) { return data != nullptr ? std::string(data, len) : std::string(); }

struct Watcher : ln::resource_event_base {
  Watcher(ln::client& clnt, const std::string& prefix) {
    name_pattern = prefix + ".*";
    ln::resource_event_connect_t filter;
    std::memset(&filter, 0, sizeof filter);
    filter.event_pattern = &any[0];
    filter.event_pattern_len = 1;
    filter.name_pattern = &name_pattern[0];
    filter.name_pattern_len = static_cast<uint32_t>(name_pattern.size());
    filter.md_pattern = &any[0];
    filter.md_pattern_len = 1;
    filter.client_pattern = &any[0];
    filter.client_pattern_len = 1;
    connect_to_resource_event(&clnt, "ln.resource_event", &filter);
  }
  void on_resource_event(ln::resource_event_call_t& ev) override {
    const bool in_main = static_cast<pid_t>(::syscall(SYS_gettid)) == main_thread;
    lines.push_back("event " + text(ev.event, ev.event_len) + " " + text(ev.name, ev.name_len) + " " +
                    text(ev.md, ev.md_len) + " " + text(ev.client, ev.client_len) + " in " +
                    (in_main ? "main" : "other") + " thread");
  }
  ln::event_connection* conn() { return connection; }
  std::string any = "*";
  std::string name_pattern;
};

// Handles the default group until `count` lines were collected (bounded).
void collect(ln::client& clnt, std::size_t count, double seconds = 8) {
  const double deadline = ln_get_monotonic_time() + seconds;
  while (lines.size() < count && ln_get_monotonic_time() < deadline)
    clnt.wait_and_handle_service_group_requests(nullptr, 0.05);
}

void flush() {
  for (const std::string& line : lines) std::printf("%s\n", line.c_str());
  lines.clear();
  std::fflush(stdout);
}

void on_custom(ln_client, ln_event_call call, void*) {
  void* data = nullptr;
  uint32_t len = 0;
  const int buffer = ln_event_call_get_buffer(call, &data, &len);
  ln_resource_event_call_t ev;
  std::memset(&ev, 0, sizeof ev);
  const int wrong = ln_event_call_set_data(call, "ln/resource_event: uint32_t 4 1", &ev);
  const int right = ln_event_call_set_data(call, ln_resource_event_call_signature, &ev);
  std::string line = "custom get_buffer " + error_name(buffer) + " len " + std::to_string(len) +
                     " set_data(wrong signature) " + error_name(wrong) + " set_data " + error_name(right);
  if (right == 0) line += " event '" + text(ev.event, ev.event_len) + "' name '" + text(ev.name, ev.name_len) + "'";
  lines.push_back(line);
}

// Another client emits PREFIX_custom to the watcher: it calls the handler
// service with {data, signature}.
void emit_custom(ln::client& clnt, ln::client& emitter, const std::string& prefix, const std::string& data) {
  ln::service* handler = emitter.get_service(prefix + "_custom." + clnt.name, "ln/event/call", ln_event_call_signature);
  ln_event_call_t call;
  std::memset(&call, 0, sizeof call);
  call.req.data = reinterpret_cast<uint8_t*>(const_cast<char*>(data.data()));
  call.req.data_len = static_cast<uint32_t>(data.size());
  std::string signature = ln_resource_event_call_signature;
  call.req.signature = &signature[0];
  call.req.signature_len = static_cast<uint32_t>(signature.size());
  ln_service_request request = nullptr;
  if (ln_service_call_async(handler->svc, &call, &request) != 0) {
    lines.push_back("custom call failed");
    return;
  }
  int result = -1;
  const double deadline = ln_get_monotonic_time() + 8;
  while (ln_service_request_finished(request, &result) == 0 && ln_get_monotonic_time() < deadline)
    clnt.wait_and_handle_service_group_requests(nullptr, 0.05);
  lines.push_back("custom call returned " + error_name(result));
  emitter.release_service(handler);
}

std::string flat_strings(const std::vector<std::string>& texts) {
  std::string flat;
  for (const std::string& t : texts) {
    const uint32_t n = static_cast<uint32_t>(t.size());
    flat.append(reinterpret_cast<const char*>(&n), 4);
    flat += t;
  }
  return flat;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: lnbt_events PREFIX [LN options]\n");
    return 2;
  }
  main_thread = static_cast<pid_t>(::syscall(SYS_gettid));
  const std::string prefix = argv[1];
  try {
    ln::client clnt("lnbt_ev_watcher", argc, argv);
    ln::client other("lnbt_ev_other", argc, argv);
    ln::outport* early = other.publish(prefix + ".early", "lnbt/counter");

    Watcher watcher(clnt, prefix);
    std::printf("connected id %u\n", watcher.conn()->id);
    collect(clnt, 2);
    flush();

    ln::outport* port = other.publish(prefix + ".topic", "lnbt/counter");
    ln::inport* inport = other.subscribe(prefix + ".topic", "lnbt/counter");
    other.unsubscribe(inport);
    other.unpublish(port);
    other.unpublish(early);
    collect(clnt, 5);
    flush();

    // Events that are not the manager's.
    ln_event_connection custom = nullptr;
    ln_resource_event_connect_t nothing;
    std::memset(&nothing, 0, sizeof nothing);
    std::printf("connect custom %s\n",
                error_name(ln_event_connect(clnt.clnt, &custom, (prefix + "_custom").c_str(),
                                            ln_resource_event_connect_signature, &nothing, on_custom, nullptr))
                    .c_str());
    emit_custom(clnt, other, prefix, flat_strings({"hello", "world", "", "me"}));
    emit_custom(clnt, other, prefix, std::string("\5\0\0", 3));
    flush();
    std::printf("deinit custom %s\n", error_name(ln_event_connection_deinit(&custom)).c_str());

    ln_event_connection bad = nullptr;
    std::printf("unknown_internal_event %s\n",
                error_name(ln_event_connect(clnt.clnt, &bad, "ln.unknown", ln_resource_event_connect_signature,
                                            &nothing, on_custom, nullptr))
                    .c_str());
    std::printf("signature_without_definition %s\n",
                error_name(ln_event_connect(clnt.clnt, &bad, (prefix + ".x").c_str(), "uint32_t 4 1,char* 1 1",
                                            &nothing, on_custom, nullptr))
                    .c_str());
    std::printf("connected_twice %s\n",
                error_name(ln_event_connect(clnt.clnt, &bad, "ln.resource_event", ln_resource_event_connect_signature,
                                            &nothing, on_custom, nullptr))
                    .c_str());
  } catch (const ln::exception& e) {
    std::printf("error %s\n", error_name(e.error).c_str());
    std::fprintf(stderr, "lnbt_events: %s\n", e.what());
    return 3;
  }
  std::fflush(stdout);
  return 0;
}
