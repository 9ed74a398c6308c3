// The objects of a .lnc file: which keys a process, state or group takes,
// LN's list modifiers on them, and the step from drafts to the checked
// model (values parsed, names of dependencies, providers and group members
// resolved, dependency cycles refused).
#include <arpa/inet.h>
#include <fnmatch.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>

#include "manager/config_drafts.hpp"
#include "manager/line_regex.hpp"

namespace ln::manager {
namespace {

struct KeyTable {
  std::set<std::string, std::less<>> scalars, lists, accumulating, ignored;
};

const KeyTable& keys_of(const std::string& type) {
  static const KeyTable process{
      {"command",
       "node",
       "change_directory",
       "ready_regex",
       "ready_time",
       "term_signal",
       "term_timeout",
       "auto_restart_interval",
       "policy",
       "priority",
       "affinity",
       "nice",
       "output_logfile",
       "output_logfile_size_limit",
       "output_logfile_keep_count",
       "max_output_lines",
       "warning_regex",
       "warning_msg",
       "description",
       "documentation",
       "change_user_to"},
      {"environment", "pass_environment", "flags", "depends_on", "depends_on_restart", "start_before", "start_on_ready",
       "start_on_successful_stop", "provides", "set_resource_limits"},
      {"map_topic", "map_service"},
      {"max_last_output_lines", "output_buffer_size", "output_encoding", "arch", "start_tool",
       "max_queued_output_bytes", "vte_color_style", "line_highlight_fg_color", "line_highlight_bg_color",
       "bugtracker_url", "mantis_project_id", "vnc_session", "vnc_port", "vnc_display", "forward_x11_to_vnc",
       "stack_size", "notebook", "max_output_frequency", "line_highlight_regexes"}};
  static const KeyTable state{
      {"check", "up", "down", "min_check_interval", "auto_check_interval", "tcp_tunnel_exit_node",
       "tcp_tunnel_exit_target", "tcp_tunnel_entry_port", "max_output_lines"},
      {"flags", "node", "depends_on", "depends_on_restart", "provides"},
      {},
      {"arch", "max_queued_output_bytes", "max_last_output_lines", "output_buffer_size", "output_encoding",
       "output_logfile", "output_logfile_size_limit", "output_logfile_keep_count", "description", "documentation"}};
  static const KeyTable group{{}, {"members", "flags"}, {}, {"description", "documentation"}};
  if (type == "process") return process;
  if (type == "state") return state;
  return group;
}

// Process flags ln_core acts on, and those of LN 2.9 it does not.
const std::set<std::string, std::less<>> process_flags = {"no_error_on_successful_stop",
                                                          "no_error_on_stop",
                                                          "start_in_shell",
                                                          "no_pty",
                                                          "use_execvpe",
                                                          "disable_stop",
                                                          "user_stop_is_successful_stop",
                                                          "no_default_templates",
                                                          "no_host_default_templates",
                                                          "dont_stop_dependent_procs",
                                                          "no_ln_ld_library_path",
                                                          "set_user_and_home"};
const std::set<std::string, std::less<>> process_flags_ignored = {"io_scripts_dont_enforce_blocking_output",
                                                                  "no_shmv3",
                                                                  "no_skip_display",
                                                                  "blocking_output",
                                                                  "disable_gdb_run",
                                                                  "disable_gdb_rerun",
                                                                  "no_vte",
                                                                  "dont_translate_backspace_to_delete",
                                                                  "remove_color_codes",
                                                                  "no_state_led",
                                                                  "no_warning_window",
                                                                  "use_vte",
                                                                  "forward_x11",
                                                                  "disable_forward_x11_to_gui_fallback",
                                                                  "forward_x11_to_gui"};
const std::set<std::string, std::less<>> state_flags = {"need_check_after_up", "autostart", "os_state"};
const std::set<std::string, std::less<>> group_flags = {"allow_empty", "show_opened", "show_closed", "sorted",
                                                        "unsorted"};

std::string strip(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

// LN's list values: comma-separated, items stripped.
std::vector<std::string> split_items(const std::string& value) {
  std::string text = value;
  while (!text.empty() && (text.back() == ',' || text.back() == ' ' || text.back() == '\\')) text.pop_back();
  while (!text.empty() && (text.front() == ',' || text.front() == ' ')) text.erase(0, 1);
  std::vector<std::string> items;
  if (text.empty()) return items;
  for (std::size_t start = 0; start <= text.size();) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    items.push_back(strip(text.substr(start, comma - start)));
    start = comma + 1;
  }
  return items;
}

bool fnmatches(const std::string& pattern, const std::string& name) {
  return ::fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
}

bool has_wildcard(const std::string& name) { return name.find_first_of("*?[") != std::string::npos; }

// Parses numbers in values, errors naming the key and where it was set.
class ValueReader {
 public:
  explicit ValueReader(const Draft& draft) : draft_(draft) {}

  [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
    const auto it = draft_.where.find(key);
    const ConfigPlace place = it != draft_.where.end() ? it->second : draft_.place;
    throw ConfigError(place.file, place.line, draft_.type + " '" + draft_.name + "': " + key + ": " + reason);
  }

  const std::string* text(const std::string& key) const {
    const auto it = draft_.scalars.find(key);
    return it == draft_.scalars.end() ? nullptr : &it->second;
  }
  std::string text_or(const std::string& key, const std::string& fallback = "") const {
    const std::string* value = text(key);
    return value ? *value : fallback;
  }

  std::optional<double> seconds(const std::string& key) const {
    const std::string* value = text(key);
    if (!value || strip(*value).empty()) return std::nullopt;
    char* end = nullptr;
    const double number = std::strtod(value->c_str(), &end);
    if (end == value->c_str() || !strip(end).empty() || !std::isfinite(number) || number < 0 || number > 1e7)
      fail(key, "'" + *value + "' is not a number of seconds");
    return number;
  }

  std::optional<long> integer(const std::string& key, long low, long high) const {
    const std::string* value = text(key);
    if (!value || strip(*value).empty()) return std::nullopt;
    char* end = nullptr;
    errno = 0;
    const long number = std::strtol(value->c_str(), &end, 0);
    if (end == value->c_str() || !strip(end).empty() || errno != 0 || number < low || number > high)
      fail(key, "'" + *value + "' is not an integer from " + std::to_string(low) + " to " + std::to_string(high));
    return number;
  }

  // "10MB", "512kb", "100b", "4096" (LN's interpret_filesize: powers of 1024)
  std::optional<std::uint64_t> size(const std::string& key) const {
    const std::string* value = text(key);
    if (!value || strip(*value).empty()) return std::nullopt;
    std::string lower = strip(*value);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
    std::uint64_t unit = 1;
    for (const auto& [suffix, factor] :
         {std::pair<const char*, std::uint64_t>{"gb", 1ull << 30}, {"mb", 1ull << 20}, {"kb", 1ull << 10}, {"b", 1}}) {
      const std::string s = suffix;
      if (lower.size() > s.size() && lower.compare(lower.size() - s.size(), s.size(), s) == 0) {
        lower.erase(lower.size() - s.size());
        unit = factor;
        break;
      }
    }
    if (lower.empty() || lower.find_first_not_of("0123456789") != std::string::npos || lower.size() > 12)
      fail(key, "'" + *value + "' is not a size like 10MB, 512kb or 4096");
    return std::stoull(lower) * unit;
  }

  void check_regex(const std::string& key) const {
    const std::string* value = text(key);
    if (!value || value->empty()) return;
    try {
      LineRegex regex(*value);
    } catch (const std::invalid_argument& e) {
      fail(key, "'" + *value + "' is not a regular expression ln_core can match: " + e.what());
    }
  }

 private:
  const Draft& draft_;
};

int parse_policy(const ValueReader& values) {
  const std::string* text = values.text("policy");
  if (!text || strip(*text).empty()) return -1;
  std::string name = strip(*text);
  if (name.find_first_not_of("0123456789") == std::string::npos) return std::stoi(name);
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::toupper(c); });
  if (name.rfind("SCHED_", 0) == 0) name.erase(0, 6);
  if (name == "OTHER" || name == "NORMAL") return SCHED_OTHER;
  if (name == "FIFO") return SCHED_FIFO;
  if (name == "RR") return SCHED_RR;
  if (name == "BATCH") return SCHED_BATCH;
  if (name == "IDLE") return SCHED_IDLE;
  values.fail(
      "policy",
      "'" + *text + "' is not a scheduling policy (SCHED_OTHER, SCHED_FIFO, SCHED_RR, SCHED_BATCH, SCHED_IDLE)");
}

// "0,2,3" or a mask "0x5"
std::vector<int> parse_affinity(const ValueReader& values) {
  const std::string* text = values.text("affinity");
  std::vector<int> cpus;
  if (!text || strip(*text).empty() || strip(*text) == "-1") return cpus;
  const std::string value = strip(*text);
  if (value.rfind("0x", 0) == 0) {
    char* end = nullptr;
    const unsigned long long mask = std::strtoull(value.c_str(), &end, 16);
    if (*end != '\0' || mask == 0) values.fail("affinity", "'" + value + "' is not a CPU mask");
    for (int cpu = 0; cpu < 64; ++cpu)
      if (mask & (1ull << cpu)) cpus.push_back(cpu);
    return cpus;
  }
  for (const auto& item : split_items(value)) {
    if (item.empty() || item.find_first_not_of("0123456789") != std::string::npos || item.size() > 4)
      values.fail("affinity", "'" + value + "' is not a list of CPU numbers (0,1,...) or a mask (0x3)");
    cpus.push_back(std::stoi(item));
  }
  return cpus;
}

std::vector<std::pair<std::string, std::string>> parse_mappings(const Draft& draft, const std::string& key) {
  std::vector<std::pair<std::string, std::string>> mappings;
  for (const auto& line : draft.list(key)) {
    const auto arrow = line.find("=>");
    if (arrow == std::string::npos) ValueReader(draft).fail(key, "expected 'SEARCH => REPLACE', not '" + line + "'");
    const std::string from = strip(line.substr(0, arrow)), to = strip(line.substr(arrow + 2));
    if (from != to) mappings.emplace_back(from, to);
  }
  return mappings;
}

// The ids of processes and states, in config order, for name lookups.
struct Names {
  std::vector<const Draft*> runnables;  ///< processes and states
  std::map<std::string, const Draft*> by_name;
  std::map<std::string, std::vector<std::pair<double, std::string>>> providers;  ///< what -> (priority, object)
};

class ModelBuilder {
 public:
  ModelBuilder(Drafts& drafts, const DraftContext& context, LncSettings& settings)
      : drafts_(drafts), context_(context), settings_(settings) {}

  void build() {
    for (auto& draft : drafts_.all) {
      if (draft->type == "process" && !draft->has_flag("no_default_templates"))
        for (const auto& default_template : drafts_.default_templates)
          context_.apply_template(*draft, default_template.use, default_template.place);
      if (draft->type == "process" || draft->type == "state") {
        names_.runnables.push_back(draft.get());
        names_.by_name[draft->name] = draft.get();
      }
      report_ignored(*draft);
    }
    collect_providers();
    for (const Draft* draft : names_.runnables) {
      if (draft->type == "process")
        settings_.processes.push_back(process(*draft));
      else
        settings_.states.push_back(state(*draft));
    }
    refuse_cycles();
    for (auto& draft : drafts_.all)
      if (draft->type == "group") settings_.groups.push_back(group(*draft));
    if (drafts_.auto_groups) add_auto_groups();
  }

 private:
  void warn(const ConfigPlace& place, const std::string& text) const {
    if (context_.log) context_.log(LogLevel::Warning, place.text() + ": " + text);
  }

  void report_ignored(const Draft& draft) {
    for (const auto& [key, place] : draft.ignored)
      if (reported_.insert(draft.type + " key " + key).second)
        warn(place, "the " + draft.type + " key '" + key +
                        "' is not supported by ln_core's manager and is ignored (reported once)");
  }

  void check_flags(const Draft& draft, const std::set<std::string, std::less<>>& supported,
                   const std::set<std::string, std::less<>>& ignored) {
    const auto it = draft.where.find("flags");
    const ConfigPlace place = it != draft.where.end() ? it->second : draft.place;
    for (const auto& flag : draft.list("flags")) {
      if (flag.empty() || supported.count(flag)) continue;
      if (ignored.count(flag)) {
        if (reported_.insert("flag " + flag).second)
          warn(place, "the flag '" + flag + "' is not supported by ln_core's manager and is ignored (reported once)");
      } else {
        warn(place, draft.type + " '" + draft.name + "': unknown flag '" + flag + "' (ignored)");
      }
    }
  }

  std::string remote_host_of(const std::string& node) const {
    if (node.empty()) return "";
    const std::string host = context_.map_node(node);
    return is_local_node(host) ? "" : host;
  }

  // ------------------------------------------------------ processes

  ProcessConfig process(const Draft& draft) {
    const ValueReader values(draft);
    ProcessConfig p;
    p.name = draft.name;
    p.display_name = draft.display_name;
    p.place = draft.place;
    p.command = values.text_or("command");
    p.alt_commands = draft.alt_commands;
    p.node = values.text_or("node");
    p.remote_host = remote_host_of(p.node);
    if (!p.remote_host.empty() && reported_.insert("host " + p.remote_host).second)
      warn(draft.place, "process '" + p.name + "' runs on node '" + p.node + "' (host '" + p.remote_host +
                            "'): ln_core's manager runs processes on its own host only, so it cannot start it");
    if (p.command.empty())
      warn(draft.place,
           "process '" + p.name + "' has no command (LN 2.9 asks a GUI user to start it); it cannot be started");
    if (const std::string* user = values.text("change_user_to"); user && !user->empty())
      values.fail("change_user_to", "is not supported by ln_core's manager (processes run as the manager's user)");
    for (const auto& entry : draft.list("environment")) {
      const auto equals = entry.find('=');
      if (equals == std::string::npos || equals == 0) values.fail("environment", "'" + entry + "' is not NAME=VALUE");
      const std::string name = entry.substr(0, equals), value = entry.substr(equals + 1);
      auto same =
          std::find_if(p.environment.begin(), p.environment.end(), [&](const auto& e) { return e.first == name; });
      if (same != p.environment.end())
        same->second = value;
      else
        p.environment.emplace_back(name, value);
    }
    for (const auto& name : draft.list("pass_environment"))
      if (!name.empty()) p.pass_environment.push_back(name);
    p.change_directory = values.text_or("change_directory");
    p.flags = draft.list("flags");
    check_flags(draft, process_flags, process_flags_ignored);
    values.check_regex("ready_regex");
    values.check_regex("warning_regex");
    p.ready_regex = values.text_or("ready_regex");
    p.ready_time = values.seconds("ready_time");
    if (p.ready_time && *p.ready_time == 0) p.ready_time.reset();
    if (const std::string* text = values.text("term_signal"); text && !strip(*text).empty()) {
      const auto signal = parse_signal(*text);
      if (!signal) values.fail("term_signal", "'" + *text + "' is not a signal (SIGTERM, INT, 9, ...)");
      p.term_signal = *signal;
    }
    p.term_timeout = values.seconds("term_timeout").value_or(2.0);
    p.auto_restart_interval = values.seconds("auto_restart_interval");
    p.policy = parse_policy(values);
    p.priority = static_cast<int>(values.integer("priority", 0, 99).value_or(0));
    p.affinity = parse_affinity(values);
    if (const auto nice = values.integer("nice", -20, 19)) p.nice = static_cast<int>(*nice);
    p.map_topics = parse_mappings(draft, "map_topic");
    p.map_services = parse_mappings(draft, "map_service");
    p.output_logfile = values.text_or("output_logfile");
    p.output_logfile_size_limit = values.size("output_logfile_size_limit").value_or(p.output_logfile_size_limit);
    p.output_logfile_keep_count =
        static_cast<unsigned>(values.integer("output_logfile_keep_count", 0, 1000).value_or(2));
    p.max_output_lines = static_cast<unsigned>(values.integer("max_output_lines", 1, 1000000).value_or(1000));
    p.warning_regex = values.text_or("warning_regex");
    p.warning_msg = values.text_or("warning_msg");
    p.description = values.text_or("description");
    p.documentation = values.text_or("documentation");
    for (const auto& limit : draft.list("set_resource_limits"))
      p.resource_limits.push_back(resource_limit(values, limit));
    p.depends_on = dependencies(draft, "depends_on", true);
    p.depends_on_restart = dependencies(draft, "depends_on_restart", true);
    for (const auto& dependency : dependencies(draft, "start_before", false))
      for (const auto& candidate : dependency.candidates) p.start_before.push_back(candidate);
    p.start_on_ready = dependencies(draft, "start_on_ready", true);
    p.start_on_successful_stop = dependencies(draft, "start_on_successful_stop", true);
    p.provides = provides_of(draft);
    return p;
  }

  ResourceLimit resource_limit(const ValueReader& values, const std::string& text) {
    const auto equals = text.find('=');
    if (equals == std::string::npos) values.fail("set_resource_limits", "'" + text + "' is not NAME=VALUE");
    const auto limit = parse_resource_limit(strip(text.substr(0, equals)));
    if (!limit)
      values.fail("set_resource_limits",
                  "'" + text.substr(0, equals) + "' is not a resource limit (RTPRIO, MEMLOCK, NOFILE, CORE, ...)");
    std::string value = strip(text.substr(equals + 1));
    std::string lower = value;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
    ResourceLimit result{*limit, -1};
    if (lower == "inf" || lower == "infinity" || lower == "rlim_infinity" || lower == "unlimited") return result;
    if (value.empty() || value.find_first_not_of("0123456789") != std::string::npos || value.size() > 18)
      values.fail("set_resource_limits", "'" + value + "' is not a number or 'inf'");
    result.value = std::stoll(value);
    return result;
  }

  // ---------------------------------------------------------- states

  StateConfig state(const Draft& draft) {
    const ValueReader values(draft);
    StateConfig s;
    s.name = draft.name;
    s.place = draft.place;
    s.check = values.text_or("check");
    s.up = values.text_or("up");
    s.down = values.text_or("down");
    s.min_check_interval = values.seconds("min_check_interval").value_or(30.0);
    s.auto_check_interval = values.seconds("auto_check_interval");
    if (s.auto_check_interval && *s.auto_check_interval < 0.1)
      values.fail("auto_check_interval", "must be at least 0.1 s");
    s.max_output_lines = static_cast<unsigned>(values.integer("max_output_lines", 1, 1000000).value_or(1000));
    s.flags = draft.list("flags");
    check_flags(draft, state_flags, {});
    for (const auto& node : draft.list("node"))
      if (s.remote_host.empty()) s.remote_host = remote_host_of(node);
    if (values.text("tcp_tunnel_exit_node") || values.text("tcp_tunnel_exit_target"))
      s.unsupported = "TCP tunnel states (tcp_tunnel_*) are not supported by ln_core's manager";
    else if (s.check.empty() && s.up.empty())
      warn(draft.place, "state '" + s.name + "' has neither a check nor an up command");
    s.depends_on = dependencies(draft, "depends_on", true);
    s.depends_on_restart = dependencies(draft, "depends_on_restart", true);
    s.provides = provides_of(draft);
    return s;
  }

  // ---------------------------------------------- names and providers

  static std::pair<std::string, double> split_provide(const std::string& entry) {
    const auto colon = entry.rfind(':');
    if (colon != std::string::npos) {
      char* end = nullptr;
      const std::string number = entry.substr(colon + 1);
      const double priority = std::strtod(number.c_str(), &end);
      if (end != number.c_str() && *end == '\0') return {entry.substr(0, colon), priority};
    }
    return {entry, std::nan("")};
  }

  // LN 2.9: a provider without an explicit priority gets one more than the
  // provider of the same name defined before it (0 for the first), so the
  // one defined last wins.
  void collect_providers() {
    for (const Draft* draft : names_.runnables) {
      for (const auto& entry : draft->list("provides")) {
        if (entry.empty()) continue;
        auto [what, priority] = split_provide(entry);
        auto& list = names_.providers[what];
        if (std::isnan(priority)) priority = list.empty() ? 0.0 : list.back().first + 1;
        list.emplace_back(priority, draft->name);
        provides_[draft->name].emplace_back(what, priority);
      }
    }
  }

  std::vector<std::pair<std::string, double>> provides_of(const Draft& draft) {
    const auto it = provides_.find(draft.name);
    return it == provides_.end() ? std::vector<std::pair<std::string, double>>{} : it->second;
  }

  // `name` as seen from an object with `prefixes`: "a/b/name", "a/name", "name".
  static std::vector<std::string> scoped(const std::vector<std::string>& prefixes, const std::string& name) {
    std::vector<std::string> out;
    for (std::size_t keep = prefixes.size(); keep > 0; --keep) {
      std::string scope;
      for (std::size_t i = 0; i < keep; ++i) scope += prefixes[i] + "/";
      out.push_back(scope + name);
    }
    out.push_back(name);
    return out;
  }

  // LN's lookup: an exact process or state name (in the object's name
  // scopes), else every process and state matching a glob, else what
  // processes and states `provide`.
  std::vector<Dependency> dependencies(const Draft& draft, const std::string& key, bool states_allowed) {
    const ValueReader values(draft);
    std::vector<Dependency> out;
    for (const auto& entry : draft.list(key)) {
      if (entry.empty()) continue;
      const bool down = entry.front() == '!';
      const std::string name = down ? entry.substr(1) : entry;
      std::vector<Dependency> found;
      for (const auto& candidate : scoped(draft.prefixes, name)) {
        if (const auto it = names_.by_name.find(candidate); it != names_.by_name.end()) {
          found.push_back({{candidate}, down});
          break;
        }
        if (has_wildcard(candidate)) {
          for (const Draft* other : names_.runnables)
            if (other != &draft && fnmatches(candidate, other->name)) found.push_back({{other->name}, down});
          if (!found.empty()) break;
        }
        Dependency providers{{}, down};
        std::vector<std::pair<double, std::string>> matches;
        for (const auto& [what, list] : names_.providers)
          if (fnmatches(candidate, what)) matches.insert(matches.end(), list.begin(), list.end());
        std::stable_sort(matches.begin(), matches.end(),
                         [](const auto& a, const auto& b) { return a.first > b.first; });
        for (const auto& match : matches)
          if (std::find(providers.candidates.begin(), providers.candidates.end(), match.second) ==
              providers.candidates.end())
            providers.candidates.push_back(match.second);
        if (!providers.candidates.empty()) {
          found.push_back(std::move(providers));
          break;
        }
      }
      if (found.empty()) values.fail(key, "there is no process, state or provider '" + name + "'");
      for (const auto& dependency : found) {
        for (const auto& candidate : dependency.candidates) {
          const Draft* target = names_.by_name.at(candidate);
          if (target == &draft) values.fail(key, "'" + name + "' is this " + draft.type + " itself");
          if (target->type == "state" && !states_allowed)
            values.fail(key, "'" + candidate + "' is a state, not a process");
          if (down && target->type != "state") values.fail(key, "'!" + name + "': only a state can be required DOWN");
        }
      }
      out.insert(out.end(), found.begin(), found.end());
    }
    return out;
  }

  // depends_on and depends_on_restart must not form a cycle: nothing in it
  // could ever start. (LN 2.9 ignores such edges at start time.)
  void refuse_cycles() {
    std::map<std::string, std::vector<std::string>> edges;
    std::map<std::string, ConfigPlace> places;
    auto add = [&](const std::string& from, const std::vector<Dependency>& list) {
      for (const auto& dependency : list)
        if (dependency.candidates.size() == 1) edges[from].push_back(dependency.candidates.front());
    };
    for (const auto& p : settings_.processes) {
      add(p.name, p.depends_on);
      add(p.name, p.depends_on_restart);
      places[p.name] = p.place;
    }
    for (const auto& s : settings_.states) {
      add(s.name, s.depends_on);
      add(s.name, s.depends_on_restart);
      places[s.name] = s.place;
    }
    std::map<std::string, int> mark;  // 1: on the path, 2: done
    std::vector<std::string> path;
    std::function<void(const std::string&)> visit = [&](const std::string& node) {
      mark[node] = 1;
      path.push_back(node);
      for (const auto& next : edges[node]) {
        if (mark[next] == 1) {
          std::string cycle;
          for (auto it = std::find(path.begin(), path.end(), next); it != path.end(); ++it) cycle += *it + " -> ";
          throw ConfigError(places[next].file, places[next].line,
                            "a dependency cycle (depends_on): " + cycle + next + "; none of them could ever start");
        }
        if (mark[next] == 0) visit(next);
      }
      path.pop_back();
      mark[node] = 2;
    };
    for (const auto& [node, unused] : places)
      if (mark[node] == 0) visit(node);
  }

  // ---------------------------------------------------------- groups

  GroupConfig group(const Draft& draft) {
    GroupConfig g;
    g.name = draft.name;
    g.place = draft.place;
    g.flags = draft.list("flags");
    check_flags(draft, group_flags, {});
    std::set<std::string> visiting;
    g.members = expand_group(draft, visiting);
    if (!draft.has_flag("unsorted")) std::sort(g.members.begin(), g.members.end());
    return g;
  }

  // The processes and states of a group: its members (names in its scopes,
  // globs, other groups, which nest; a group within itself adds nothing),
  // less its exclusions ("!pattern").
  std::vector<std::string> expand_group(const Draft& draft, std::set<std::string>& visiting) {
    const ValueReader values(draft);
    std::vector<std::string> members, excludes;
    visiting.insert(draft.name);
    for (const auto& entry : draft.list("members")) {
      if (entry.empty()) continue;
      if (entry.front() == '!') {
        excludes.push_back(entry.substr(1));
        continue;
      }
      bool matched = false;
      for (const auto& candidate : scoped(draft.prefixes, entry))
        if ((matched = members_named(candidate, visiting, members))) break;
      if (!matched && !draft.has_flag("allow_empty"))
        values.fail("members", "nothing matches '" + entry + "' (add the flag allow_empty to allow that)");
    }
    visiting.erase(draft.name);
    std::vector<std::string> out;
    for (const auto& name : members) {
      const bool excluded = std::any_of(excludes.begin(), excludes.end(),
                                        [&](const std::string& pattern) { return fnmatches(pattern, name); });
      if (!excluded && std::find(out.begin(), out.end(), name) == out.end()) out.push_back(name);
    }
    return out;
  }

  // Adds what `name` stands for: a process or state, a group's members, or
  // all that a glob matches. Whether anything had that name.
  bool members_named(const std::string& name, std::set<std::string>& visiting, std::vector<std::string>& out) {
    if (names_.by_name.count(name)) {
      out.push_back(name);
      return true;
    }
    if (const Draft* nested = drafts_.find(name, "group")) {
      if (!visiting.count(name)) {
        const auto members = expand_group(*nested, visiting);
        out.insert(out.end(), members.begin(), members.end());
      }
      return true;
    }
    if (!has_wildcard(name)) return false;
    bool matched = false;
    for (const Draft* draft : names_.runnables)
      if (fnmatches(name, draft->name)) {
        out.push_back(draft->name);
        matched = true;
      }
    for (const auto& draft : drafts_.all)
      if (draft->type == "group" && fnmatches(name, draft->name))
        matched = members_named(draft->name, visiting, out) || matched;
    return matched;
  }

  // enable_auto_groups: "a/b/x" is a member of the groups "a/b" and "a".
  void add_auto_groups() {
    std::map<std::string, std::vector<std::string>> auto_members;
    for (const Draft* draft : names_.runnables)
      for (auto slash = draft->name.find('/'); slash != std::string::npos; slash = draft->name.find('/', slash + 1))
        auto_members[draft->name.substr(0, slash)].push_back(draft->name);
    for (auto& [name, members] : auto_members) {
      auto existing = std::find_if(settings_.groups.begin(), settings_.groups.end(),
                                   [&](const GroupConfig& g) { return g.name == name; });
      if (existing == settings_.groups.end()) {
        GroupConfig g;
        g.name = name;
        g.place = names_.by_name.at(members.front())->place;
        settings_.groups.push_back(g);
        existing = settings_.groups.end() - 1;
      }
      for (const auto& member : members)
        if (std::find(existing->members.begin(), existing->members.end(), member) == existing->members.end())
          existing->members.push_back(member);
    }
  }

  Drafts& drafts_;
  const DraftContext& context_;
  LncSettings& settings_;
  Names names_;
  std::map<std::string, std::vector<std::pair<std::string, double>>> provides_;
  std::set<std::string> reported_;
};

}  // namespace

// ------------------------------------------------------------------ drafts

Draft::Kind Draft::kind_of(const std::string& key, const ConfigPlace& at) const {
  const KeyTable& table = keys_of(type);
  if (table.scalars.count(key)) return Kind::Scalar;
  if (table.lists.count(key)) return Kind::List;
  if (table.accumulating.count(key)) return Kind::Accumulating;
  if (table.ignored.count(key)) return Kind::Ignored;
  throw ConfigError(at.file, at.line, "unknown key '" + key + "' in " + type + " '" + name + "'");
}

// LN accepts `add flag:` for `flags`.
std::string Draft::list_key(const std::string& key, const std::string& operation, const ConfigPlace& at) const {
  const KeyTable& table = keys_of(type);
  if (table.lists.count(key) || table.accumulating.count(key)) return key;
  if (table.lists.count(key + "s")) return key + "s";
  if (table.ignored.count(key)) return key;
  throw ConfigError(
      at.file, at.line,
      "'" + operation + " " + key + "': only list keys take '" + operation + "' (in " + type + " '" + name + "')");
}

void Draft::set(const std::string& key, const std::string& value, const ConfigPlace& at) {
  switch (kind_of(key, at)) {
    case Kind::Ignored:
      ignored[key] = at;
      return;
    case Kind::Scalar:
      scalars[key] = value;
      break;
    case Kind::List:
      lists[key] = split_items(value);
      break;
    case Kind::Accumulating:
      lists[key].push_back(value);
      break;
  }
  where[key] = at;
}

void Draft::append(const std::string& key, const std::string& value, const ConfigPlace& at) {
  switch (kind_of(key, at)) {
    case Kind::Ignored:
      ignored[key] = at;
      return;
    case Kind::Scalar:
      scalars[key] += value;
      break;
    case Kind::List: {
      auto items = split_items(value);
      lists[key].insert(lists[key].end(), items.begin(), items.end());
      break;
    }
    case Kind::Accumulating:
      lists[key].push_back(value);
      break;
  }
  where[key] = at;
}

void Draft::add_item(const std::string& raw_key, const std::string& value, const ConfigPlace& at) {
  const std::string key = list_key(raw_key, "add", at);
  if (keys_of(type).ignored.count(key)) {
    ignored[key] = at;
    return;
  }
  auto& list = lists[key];
  where[key] = at;
  if (std::find(list.begin(), list.end(), value) != list.end()) return;
  if (key == "flags" && value.find(',') != std::string::npos) {
    for (const auto& flag : split_items(value))
      if (std::find(list.begin(), list.end(), flag) == list.end()) list.push_back(flag);
    return;
  }
  const auto equals = value.find('=');
  if (!list.empty() && list.front().find('=') != std::string::npos && equals != std::string::npos) {
    const std::string prefix = value.substr(0, equals + 1);
    list.erase(
        std::remove_if(list.begin(), list.end(), [&](const std::string& item) { return item.rfind(prefix, 0) == 0; }),
        list.end());
  }
  list.push_back(value);
}

void Draft::delete_item(const std::string& raw_key, const std::string& value, const ConfigPlace& at) {
  const std::string key = list_key(raw_key, "del", at);
  const std::vector<std::string> remove =
      key == "flags" && value.find(',') != std::string::npos ? split_items(value) : std::vector<std::string>{value};
  auto& list = lists[key];
  list.erase(std::remove_if(list.begin(), list.end(),
                            [&](const std::string& item) {
                              return std::find(remove.begin(), remove.end(), item) != remove.end();
                            }),
             list.end());
  where[key] = at;
}

void Draft::reset(const std::string& key, const ConfigPlace& at) {
  switch (kind_of(key, at)) {
    case Kind::Ignored:
      ignored.erase(key);
      return;
    case Kind::Scalar:
      scalars.erase(key);
      break;
    case Kind::List:
    case Kind::Accumulating:
      lists[key].clear();
      break;
  }
  where[key] = at;
}

void Draft::edit_item(const std::string& operation, const std::string& raw_key, const std::string& item,
                      const std::string& value, const ConfigPlace& at) {
  const std::string key = list_key(raw_key, operation, at);
  auto& list = lists[key];
  where[key] = at;
  const std::string prefix = item + "=";
  for (auto& entry : list) {
    if (entry.rfind(prefix, 0) != 0) continue;
    if (operation == "prepend") {
      entry = prefix + value + entry.substr(prefix.size());
    } else if (operation == "append") {
      entry += value;
    } else if (!value.empty()) {
      for (auto found = entry.find(value, prefix.size()); found != std::string::npos; found = entry.find(value, found))
        entry.erase(found, value.size());
    }
    return;
  }
  list.push_back(prefix + value);
}

void Draft::set_alt_command(const std::string& command_name, const std::string& command) {
  for (auto& entry : alt_commands)
    if (entry.first == command_name) {
      entry.second = command;
      return;
    }
  alt_commands.emplace_back(command_name, command);
}

const std::vector<std::string>& Draft::list(const std::string& key) const {
  static const std::vector<std::string> none;
  const auto it = lists.find(key);
  return it == lists.end() ? none : it->second;
}

bool Draft::has_flag(const std::string& flag) const {
  const auto& flags = list("flags");
  return std::find(flags.begin(), flags.end(), flag) != flags.end();
}

const Draft* Drafts::find(const std::string& name, const std::string& type) const {
  for (const auto& draft : all)
    if (draft->name == name && draft->type == type) return draft.get();
  return nullptr;
}

const Draft* Drafts::find_any(const std::string& name) const {
  for (const auto& draft : all)
    if (draft->name == name) return draft.get();
  return nullptr;
}

void complete_model(Drafts& drafts, const DraftContext& context, LncSettings& settings) {
  ModelBuilder(drafts, context, settings).build();
}

// ------------------------------------------------------------------ model

bool ProcessConfig::has_flag(const std::string& flag) const {
  return std::find(flags.begin(), flags.end(), flag) != flags.end();
}

bool StateConfig::has_flag(const std::string& flag) const {
  return std::find(flags.begin(), flags.end(), flag) != flags.end();
}

bool is_local_node(const std::string& node) {
  if (node.empty() || node == "localhost" || node == "localhost.localdomain" || node == "::1") return true;
  in_addr address{};
  if (::inet_pton(AF_INET, node.c_str(), &address) == 1) {
    if ((ntohl(address.s_addr) >> 24) == 127) return true;
    ifaddrs* list = nullptr;
    bool local = false;
    if (::getifaddrs(&list) == 0) {
      for (ifaddrs* entry = list; entry != nullptr; entry = entry->ifa_next)
        if (entry->ifa_addr && entry->ifa_addr->sa_family == AF_INET &&
            reinterpret_cast<sockaddr_in*>(entry->ifa_addr)->sin_addr.s_addr == address.s_addr)
          local = true;
      ::freeifaddrs(list);
    }
    return local;
  }
  char host[256] = "";
  ::gethostname(host, sizeof host - 1);
  const std::string name = host;
  return node == name || node == name.substr(0, name.find('.')) || name == node.substr(0, node.find('.'));
}

namespace {
const std::pair<const char*, int> signal_table[] = {
    {"SIGHUP", SIGHUP},   {"SIGINT", SIGINT},     {"SIGQUIT", SIGQUIT}, {"SIGILL", SIGILL},   {"SIGTRAP", SIGTRAP},
    {"SIGABRT", SIGABRT}, {"SIGBUS", SIGBUS},     {"SIGFPE", SIGFPE},   {"SIGKILL", SIGKILL}, {"SIGUSR1", SIGUSR1},
    {"SIGSEGV", SIGSEGV}, {"SIGUSR2", SIGUSR2},   {"SIGPIPE", SIGPIPE}, {"SIGALRM", SIGALRM}, {"SIGTERM", SIGTERM},
    {"SIGCHLD", SIGCHLD}, {"SIGCONT", SIGCONT},   {"SIGSTOP", SIGSTOP}, {"SIGTSTP", SIGTSTP}, {"SIGTTIN", SIGTTIN},
    {"SIGTTOU", SIGTTOU}, {"SIGURG", SIGURG},     {"SIGXCPU", SIGXCPU}, {"SIGXFSZ", SIGXFSZ}, {"SIGVTALRM", SIGVTALRM},
    {"SIGPROF", SIGPROF}, {"SIGWINCH", SIGWINCH}, {"SIGIO", SIGIO},     {"SIGPWR", SIGPWR},   {"SIGSYS", SIGSYS}};
}  // namespace

std::optional<int> parse_signal(const std::string& text) {
  std::string name = strip(text);
  if (!name.empty() && name.find_first_not_of("0123456789") == std::string::npos && name.size() < 4) {
    const int number = std::stoi(name);
    if (number >= 1 && number <= 64) return number;
    return std::nullopt;
  }
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::toupper(c); });
  if (name.rfind("SIG", 0) != 0) name = "SIG" + name;
  for (const auto& [signal_text, number] : signal_table)
    if (name == signal_text) return number;
  return std::nullopt;
}

std::optional<int> parse_resource_limit(const std::string& text) {
  static const std::pair<const char*, int> limits[] = {{"CORE", RLIMIT_CORE},
                                                       {"CORE FILE SIZE", RLIMIT_CORE},
                                                       {"DATA", RLIMIT_DATA},
                                                       {"DATA SEG SIZE", RLIMIT_DATA},
                                                       {"NICE", RLIMIT_NICE},
                                                       {"SCHEDULING PRIORITY", RLIMIT_NICE},
                                                       {"FSIZE", RLIMIT_FSIZE},
                                                       {"FILE SIZE", RLIMIT_FSIZE},
                                                       {"SIGPENDING", RLIMIT_SIGPENDING},
                                                       {"PENDING SIGNALS", RLIMIT_SIGPENDING},
                                                       {"MEMLOCK", RLIMIT_MEMLOCK},
                                                       {"MAX LOCKED MEMORY", RLIMIT_MEMLOCK},
                                                       {"RSS", RLIMIT_RSS},
                                                       {"MAX MEMORY SIZE", RLIMIT_RSS},
                                                       {"NOFILE", RLIMIT_NOFILE},
                                                       {"OPEN FILES", RLIMIT_NOFILE},
                                                       {"MSGQUEUE", RLIMIT_MSGQUEUE},
                                                       {"POSIX MESSAGE QUEUES", RLIMIT_MSGQUEUE},
                                                       {"RTPRIO", RLIMIT_RTPRIO},
                                                       {"REAL-TIME PRIORITY", RLIMIT_RTPRIO},
                                                       {"STACK", RLIMIT_STACK},
                                                       {"STACK SIZE", RLIMIT_STACK},
                                                       {"CPU", RLIMIT_CPU},
                                                       {"CPU TIME", RLIMIT_CPU},
                                                       {"NPROC", RLIMIT_NPROC},
                                                       {"MAX USER PROCESSES", RLIMIT_NPROC},
                                                       {"AS", RLIMIT_AS},
                                                       {"VIRTUAL MEMORY", RLIMIT_AS},
                                                       {"LOCKS", RLIMIT_LOCKS},
                                                       {"FILE LOCKS", RLIMIT_LOCKS}};
  std::string name = strip(text);
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::toupper(c); });
  if (name.rfind("RLIMIT_", 0) == 0) name.erase(0, 7);
  for (const auto& [limit_name, resource] : limits)
    if (name == limit_name) return resource;
  return std::nullopt;
}

std::string signal_name(int signal) {
  for (const auto& [signal_text, number] : signal_table)
    if (number == signal) return signal_text;
  return "signal " + std::to_string(signal);
}

}  // namespace ln::manager
