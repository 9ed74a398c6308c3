// The .lnc reader: lines, sections, directives, templates and list
// modifiers. Sections that describe objects (process, state, group) are
// collected as drafts of evaluated key values; config_objects.cpp turns the
// drafts into the checked model once every file is read.
#include "manager/config.hpp"

#include <dirent.h>
#include <fnmatch.h>
#include <limits.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>

#include "manager/config_drafts.hpp"
#include "manager/limits.hpp"
#include "manager/lnc_eval.hpp"
#include "md/files.hpp"

namespace ln::manager {
namespace {

using md::files::is_directory;
using md::files::is_regular_file;

constexpr int max_include_depth = 32;
constexpr int max_template_depth = 16;
constexpr int max_glob_depth = 32;
// The LN version whose language this reader implements (requires_version).
constexpr int implemented_version[3] = {2, 9, 0};

// Sections of LN 2.9 that describe what a single-host manager does not do.
const std::set<std::string, std::less<>> ignored_section_types = {"hosts",  "network",   "topic", "custom_start_tools",
                                                                  "plugin", "gui_plugin"};

const std::set<std::string, std::less<>> instance_keys_ignored = {"documentation",
                                                                  "groups_opened_default",
                                                                  "groups_sorted_default",
                                                                  "webui_auth_file",
                                                                  "webui_https_cert_file",
                                                                  "webui_https_key_file",
                                                                  "log_file",
                                                                  "log_file_size_limit",
                                                                  "log_file_keep_count",
                                                                  "manager_log_history_size",
                                                                  "daemon_log_history_size",
                                                                  "max_log_items",
                                                                  "pid_file",
                                                                  "daemon_start_script",
                                                                  "daemon_start_shell",
                                                                  "ssh_binary",
                                                                  "additional_ssh_arguments",
                                                                  "daemon_private_key_file",
                                                                  "daemon_public_key_file",
                                                                  "default_change_user_to",
                                                                  "default_expected_user",
                                                                  "default_notebook_path",
                                                                  "scope_process_template",
                                                                  "notebook_process_template",
                                                                  "vncserver_process_template",
                                                                  "allow_x11_tcp_connect",
                                                                  "check_all_states_after_daemon_connect",
                                                                  "flags",
                                                                  "default_resource_limits",
                                                                  "vte_font",
                                                                  "vte_color_style",
                                                                  "disable_all_vte"};

std::string strip(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return std::string(s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1));
}

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

std::string first_word(std::string_view line) { return std::string(line.substr(0, line.find_first_of(" \t"))); }

std::string after_first_word(std::string_view line) {
  const auto space = line.find_first_of(" \t");
  return space == std::string_view::npos ? std::string() : strip(line.substr(space));
}

// A single-line value as LN reads it: "quoted" keeps everything inside the
// quotes; otherwise an unquoted '#' (outside %( )) starts a comment.
std::string single_line_value(std::string_view raw) {
  const std::string text = strip(raw);
  if (!text.empty() && text.front() == '"') {
    std::string inner;
    std::size_t i = 1;
    for (; i < text.size() && text[i] != '"'; ++i) {
      if (text.compare(i, 2, "%(") == 0) {
        // a replacement may hold quoted arguments: %(subst "a", "b", "%(x)")
        const std::size_t close = replacement_end(text, i);
        if (close == std::string::npos) break;
        inner += text.substr(i, close + 1 - i);
        i = close;
        continue;
      }
      if (text[i] == '\\' && i + 1 < text.size() && (text[i + 1] == '"' || text[i + 1] == '\\')) ++i;
      inner += text[i];
    }
    if (i < text.size()) {
      const std::string rest = strip(std::string_view(text).substr(i + 1));
      if (rest.empty() || rest.front() == '#') return inner;
    }
  }
  int depth = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text.compare(i, 2, "%(") == 0) {
      ++depth;
      ++i;
    } else if (text[i] == ')' && depth > 0) {
      --depth;
    } else if (text[i] == '#' && depth == 0) {
      return strip(std::string_view(text).substr(0, i));
    }
  }
  return text;
}

std::string real_path(const std::string& path) {
  char resolved[PATH_MAX];
  return ::realpath(path.c_str(), resolved) ? std::string(resolved) : path;
}

std::string absolute_path(const std::string& path) {
  if (!path.empty() && path.front() == '/') return path;
  char cwd[PATH_MAX];
  return ::getcwd(cwd, sizeof cwd) ? std::string(cwd) + "/" + path : path;
}

std::string dirname_of(const std::string& path) {
  const auto slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::string expand_home(const std::string& path) {
  const char* home = std::getenv("HOME");
  if (home && (path == "~" || starts_with(path, "~/"))) return home + path.substr(1);
  return path;
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

std::vector<std::string> split_path(const std::string& path) {
  std::vector<std::string> parts;
  std::string part;
  for (char c : path) {
    if (c == '/') {
      if (!part.empty()) parts.push_back(part);
      part.clear();
    } else {
      part += c;
    }
  }
  if (!part.empty()) parts.push_back(part);
  return parts;
}

// Whether the components of `path` match `pattern` (fnmatch per component,
// "**" for any number of directories).
bool path_matches(const std::vector<std::string>& pattern, std::size_t p, const std::vector<std::string>& path,
                  std::size_t q) {
  if (p == pattern.size()) return q == path.size();
  if (pattern[p] == "**") {
    for (std::size_t skip = q; skip <= path.size(); ++skip)
      if (path_matches(pattern, p + 1, path, skip)) return true;
    return false;
  }
  return q < path.size() && ::fnmatch(pattern[p].c_str(), path[q].c_str(), FNM_PERIOD) == 0 &&
         path_matches(pattern, p + 1, path, q + 1);
}

bool has_wildcard(const std::string& part) { return part.find_first_of("*?[") != std::string::npos; }

void collect_files(const std::string& dir, int depth, std::set<std::string>& seen_dirs, std::vector<std::string>& out) {
  if (depth > max_glob_depth || !seen_dirs.insert(real_path(dir)).second) return;
  DIR* handle = ::opendir(dir.c_str());
  if (handle == nullptr) return;
  std::vector<std::string> names;
  while (const dirent* entry = ::readdir(handle)) {
    const std::string name = entry->d_name;
    if (name != "." && name != "..") names.push_back(name);
  }
  ::closedir(handle);
  for (const auto& name : names) {
    const std::string path = dir + "/" + name;
    if (is_directory(path))
      collect_files(path, depth + 1, seen_dirs, out);
    else if (is_regular_file(path))
      out.push_back(path);
  }
}

// Files below `base_dir` that match an include pattern and no exclude
// ("!pattern"), sorted; patterns are relative to `base_dir` unless absolute.
std::vector<std::string> glob_files(const std::string& base_dir, const std::vector<std::string>& patterns) {
  std::vector<std::vector<std::string>> includes, excludes;
  for (std::string pattern : patterns) {
    const bool exclude = starts_with(pattern, "!");
    if (exclude) pattern.erase(0, 1);
    if (pattern.empty()) continue;
    if (pattern.front() != '/') pattern = absolute_path(base_dir == "." ? "" : base_dir) + "/" + pattern;
    (exclude ? excludes : includes).push_back(split_path(pattern));
  }
  std::vector<std::string> found;
  std::set<std::string> roots;
  for (const auto& pattern : includes) {
    std::string root;
    for (const auto& part : pattern) {
      if (has_wildcard(part) || &part == &pattern.back()) break;
      root += "/" + part;
    }
    roots.insert(root.empty() ? "/" : root);
  }
  std::set<std::string> seen_dirs;
  std::vector<std::string> candidates;
  for (const auto& root : roots) collect_files(root, 0, seen_dirs, candidates);
  for (const auto& file : candidates) {
    const auto parts = split_path(file);
    auto matches = [&](const std::vector<std::vector<std::string>>& list) {
      return std::any_of(list.begin(), list.end(), [&](const auto& p) { return path_matches(p, 0, parts, 0); });
    };
    if (matches(includes) && !matches(excludes)) found.push_back(file);
  }
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  return found;
}

std::vector<int> version_numbers(const std::string& text) {
  std::vector<int> numbers;
  std::istringstream in(text);
  std::string part;
  while (std::getline(in, part, '.')) {
    const std::string digits = strip(part);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return {};
    numbers.push_back(std::stoi(digits));
  }
  return numbers;
}

class LncReader {
 public:
  LncReader(const LogFunction& log, LncContext context)
      : log_(log),
        context_(std::move(context)),
        evaluator_([this](const std::string& name) { return define(name); },
                   [this](const std::string& node) { return is_local(node); }) {}

  void read_text(const std::string& text, const std::string& path, int depth,
                 const std::vector<std::string>& prefixes) {
    if (depth > max_include_depth) throw ConfigError(path, 0, "includes are nested too deeply (an include loop?)");
    FileState saved = file_;
    file_ = FileState{path, 0, prefixes};
    drafts_.files.push_back(path);
    section_.reset();
    const std::vector<std::string> lines = split_lines(text);
    for (std::size_t index = 0; index < lines.size(); ++index) read_line(lines, index, depth);
    file_ = std::move(saved);
    section_.reset();  // a section never continues in the including file
  }

  LncSettings finish() {
    LncSettings settings = settings_;
    if (!context_.instance_name.empty()) settings.instance_name = context_.instance_name;
    settings.files = drafts_.files;
    DraftContext context{log_,
                         [this](Draft& draft, const std::string& use, const ConfigPlace& place) {
                           apply_template(draft, use, place, 0);
                         },
                         [this](const std::string& node) { return node_map_lookup(node); }};
    complete_model(drafts_, context, settings);
    return settings;
  }

 private:
  struct FileState {
    std::string path;
    int line = 0;
    std::vector<std::string> prefixes;
  };

  [[noreturn]] void fail(const std::string& reason) const { throw ConfigError(file_.path, file_.line, reason); }

  void log(LogLevel level, const std::string& text) const {
    if (log_) log_(level, file_.path + ":" + std::to_string(file_.line) + ": " + text);
  }

  void report_once(const std::string& what) {
    if (reported_.insert(what).second)
      log(LogLevel::Warning, what + " is not supported by ln_core's manager and is ignored (reported once)");
  }

  ConfigPlace here() const { return {file_.path, file_.line}; }

  std::vector<std::string> words(const std::string& text) const {
    try {
      return split_words(text);
    } catch (const EvaluationError& e) {
      fail(e.what());
    }
  }

  std::string evaluate(const std::string& text) {
    try {
      return evaluator_.evaluate(text);
    } catch (const EvaluationError& e) {
      fail(e.what());
    }
  }

  // ---------------------------------------------------------- defines

  std::optional<std::string> define(const std::string& name) const {
    // where the line being evaluated is used: a template line is evaluated
    // where the template is used (as LN 2.9 does)
    const std::string& current = using_file_.empty() ? file_.path : using_file_;
    if (name == "CURDIR") return dirname_of(real_path(current));
    if (name == "CURRENT") return real_path(current);
    if (name == "instance_name")
      return context_.instance_name.empty() ? settings_.instance_name : context_.instance_name;
    if (name == "manager" && settings_.manager_port)
      return (settings_.manager_host->empty() ? "127.0.0.1" : *settings_.manager_host) + ":" +
             std::to_string(*settings_.manager_port);
    if (const auto it = object_defines_.find(name); it != object_defines_.end()) return it->second;
    if (const auto it = defines_.find(name); it != defines_.end()) return it->second;
    if (const auto it = define_problems_.find(name); it != define_problems_.end())
      throw EvaluationError("define '" + name + "' is unusable: " + it->second);
    if (const auto it = node_map_.find(name); it != node_map_.end()) return it->second;
    if (name == "hostname") {
      char host[256] = "";
      ::gethostname(host, sizeof host - 1);
      return std::string(host);
    }
    if (name == "empty") return std::string();
    if (const auto it = context_.builtin_defines.find(name); it != context_.builtin_defines.end()) return it->second;
    return std::nullopt;
  }

  bool defined(const std::string& name) const {
    if (define_problems_.count(name)) return true;  // it has a value, just not a usable one
    const auto value = define(name);
    return value && !value->empty();
  }

  std::string node_map_lookup(const std::string& node) const {
    const auto it = node_map_.find(node);
    return it == node_map_.end() ? node : it->second;
  }

  bool is_local(const std::string& node) const { return is_local_node(node_map_lookup(node)); }

  // ------------------------------------------------------------ lines

  void read_line(const std::vector<std::string>& lines, std::size_t& index, int depth) {
    file_.line = static_cast<int>(index) + 1;
    std::string line = strip(lines[index]);
    if (line.empty() || line.front() == '#') return;

    bool skipped = false;
    for (std::string word = first_word(line); word == "ifdef" || word == "ifndef"; word = first_word(line)) {
      const std::string condition = after_first_word(line);
      const auto colon = condition.find(':');
      if (colon == std::string::npos) fail("expected '" + word + " DEFINE: line'");
      const std::string name = strip(std::string_view(condition).substr(0, colon));
      if (defined(name) != (word == "ifdef")) skipped = true;
      line = strip(std::string_view(condition).substr(colon + 1));
      if (line.empty()) return;
    }

    const std::string word = first_word(single_line_value(line));
    const std::string directive = word.size() > 1 && word.back() == ':' ? word.substr(0, word.size() - 1) : word;
    if (is_directive(directive, word)) {
      if (!skipped) run_directive(directive, argument_of(line), depth);
      return;
    }
    if (word == "instance" || word == "defines" || word == "node_map" || word == "process" || word == "state" ||
        word == "group" || word == "template" || word == "process_template" || ignored_section_types.count(word)) {
      if (!skipped) start_section(word, single_line_value(after_first_word(line)));
      return;
    }

    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      if (!section_)
        fail("expected a section (like 'instance', 'defines' or 'process NAME') or a directive, not '" + line + "'");
      if (section_->ignored) return;  // lines of sections we ignore need not make sense to us
      fail("expected 'key: value' in the " + section_->describe() + ", not '" + line + "'");
    }
    const std::string key = strip(std::string_view(line).substr(0, colon));
    const std::string raw_value = strip(std::string_view(line).substr(colon + 1));
    const ConfigPlace place = here();
    // The value as written, without its comment or quotes; evaluated later
    // (templates replace their parameters in it first).
    const std::string value = !raw_value.empty() && raw_value.front() == '['
                                  ? block_value(lines, index, raw_value, key == "description")
                                  : single_line_value(raw_value);
    if (skipped) return;
    if (!section_) fail("'" + key + ":' appears before any section");
    if (key == "undef") {
      define_problems_.erase(evaluate(value));
      defines_.erase(evaluate(value));
      return;
    }
    if (section_->ignored || starts_with(key, "ignore-")) return;
    section_value(key, value, place);
  }

  static bool is_directive(const std::string& directive, const std::string& word) {
    static const std::set<std::string, std::less<>> directives = {"include",
                                                                  "optional_include",
                                                                  "include_glob",
                                                                  "optional_include_glob",
                                                                  "pipe_include",
                                                                  "push_name_prefix",
                                                                  "pop_name_prefix",
                                                                  "add_message_definition_dir",
                                                                  "add_process_default_template",
                                                                  "requires_version"};
    return directives.count(directive) > 0 || word == "warning:";
  }

  // The text after a directive word, with or without its ':'.
  static std::string argument_of(const std::string& line) {
    std::string rest = line.substr(first_word(line).size());
    if (!rest.empty() && rest.front() == ':') rest.erase(0, 1);
    return strip(rest);
  }

  // A `key: [ ... ]` value may span lines; they are joined with spaces
  // (newlines for description) and comment lines inside are dropped.
  std::string block_value(const std::vector<std::string>& lines, std::size_t& index, std::string_view first,
                          bool keep_newlines) {
    const int start_line = static_cast<int>(index) + 1;
    std::string joined;
    std::string_view part = first.substr(1);
    for (bool first_part = true;; first_part = false) {
      const std::string trimmed = strip(part);
      const bool last = !trimmed.empty() && trimmed.back() == ']';
      const std::string content = strip(last ? std::string_view(trimmed).substr(0, trimmed.size() - 1) : trimmed);
      if (!(!first_part && starts_with(content, "#")) && !content.empty())
        joined += (joined.empty() ? "" : keep_newlines ? "\n" : " ") + content;
      if (last) return joined;
      if (++index >= lines.size()) {
        file_.line = start_line;
        fail("the '[' block that starts here has no closing ']'");
      }
      part = lines[index];
    }
  }

  // ------------------------------------------------------- directives

  void run_directive(const std::string& directive, const std::string& argument, int depth) {
    if (directive == "warning") {
      log(LogLevel::Warning, evaluate(single_line_value(argument)));
    } else if (directive == "include" || directive == "optional_include") {
      include(directive == "optional_include", evaluate(single_line_value(argument)), depth);
    } else if (directive == "include_glob" || directive == "optional_include_glob") {
      include_glob(directive == "optional_include_glob", evaluate(single_line_value(argument)), depth);
    } else if (directive == "pipe_include") {
      pipe_include(evaluate(single_line_value(argument)), depth);
    } else if (directive == "push_name_prefix") {
      std::string prefix = evaluate(single_line_value(argument));
      while (!prefix.empty() && prefix.front() == '/') prefix.erase(0, 1);
      while (!prefix.empty() && prefix.back() == '/') prefix.pop_back();
      if (prefix.empty()) fail("push_name_prefix needs a prefix");
      file_.prefixes.push_back(prefix);
    } else if (directive == "pop_name_prefix") {
      if (file_.prefixes.empty())
        log(LogLevel::Warning, "pop_name_prefix: there is no name prefix to pop");
      else
        file_.prefixes.pop_back();
    } else if (directive == "add_message_definition_dir") {
      add_message_definition_dir(evaluate(single_line_value(argument)));
    } else if (directive == "add_process_default_template") {
      drafts_.default_templates.push_back({join_prefixes(file_.prefixes), single_line_value(argument), here()});
    } else if (directive == "requires_version") {
      requires_version(evaluate(single_line_value(argument)));
    }
  }

  std::string resolve_include(std::string name) const {
    name = expand_home(name);
    if (name.empty() || name.front() == '/') return name;
    const std::string local = dirname_of(file_.path) + "/" + name;
    if (name.front() == '.' || is_regular_file(local)) return local;
    for (const auto& dir : context_.include_dirs)
      if (is_regular_file(dir + "/" + name)) return dir + "/" + name;
    return local;
  }

  void include(bool optional, const std::string& name, int depth) {
    if (name.empty()) fail("include needs a file name");
    const std::string path = resolve_include(name);
    if (!is_regular_file(path)) {
      if (optional) {
        log(LogLevel::Debug, "optional include '" + path + "' does not exist");
        return;
      }
      fail("cannot include '" + path + "': no such file");
    }
    read_text(read_whole_file(path), path, depth + 1, file_.prefixes);
  }

  void include_glob(bool optional, const std::string& patterns, int depth) {
    const std::vector<std::string> files = glob_files(dirname_of(file_.path), words(patterns));
    if (files.empty()) {
      if (!optional) fail("include_glob: no file matches '" + patterns + "'");
      log(LogLevel::Warning, "optional_include_glob: no file matches '" + patterns + "'");
    }
    for (const auto& path : files) read_text(read_whole_file(path), path, depth + 1, file_.prefixes);
  }

  void pipe_include(const std::string& command, int depth) {
    ShellResult result;
    try {
      result = run_shell_command(command, 60);
    } catch (const EvaluationError& e) {
      fail("pipe_include '" + command + "': " + e.what());
    }
    if (result.timed_out) fail("pipe_include '" + command + "' did not finish within 60 s");
    if (result.status != 0)
      fail("pipe_include '" + command + "' failed" +
           (result.status > 0 ? " with exit status " + std::to_string(result.status) : std::string(" (killed)")) +
           (strip(result.errors).empty() ? "" : ": " + strip(result.errors)));
    read_text(result.output, command, depth + 1, file_.prefixes);
  }

  void add_message_definition_dir(const std::string& value) {
    const std::string dir = absolute_path(expand_home(value));
    if (!is_directory(dir)) log(LogLevel::Warning, "message-definition directory '" + dir + "' does not exist");
    auto& dirs = settings_.message_definition_dirs;
    if (std::find(dirs.begin(), dirs.end(), dir) == dirs.end()) dirs.push_back(dir);
  }

  void requires_version(const std::string& text) {
    const std::vector<int> wanted = version_numbers(text);
    if (wanted.empty()) fail("requires_version: '" + text + "' is not a version like 2.9.0");
    const std::vector<int> ours(std::begin(implemented_version), std::end(implemented_version));
    if (std::lexicographical_compare(ours.begin(), ours.end(), wanted.begin(), wanted.end()))
      fail("this config requires an ln_manager of version " + text +
           " or later; ln_core's manager implements the language of LN 2.9.0");
  }

  // --------------------------------------------------------- sections

  struct Section {
    std::string type;
    Draft* draft = nullptr;  ///< process, state, group, template
    bool ignored = false;
    std::string describe() const {
      return draft ? "'" + type + " " + draft->name + "' section" : "'" + type + "' section";
    }
  };

  static std::string join_prefixes(const std::vector<std::string>& prefixes) {
    std::string joined;
    for (const auto& prefix : prefixes) joined += (joined.empty() ? "" : "/") + prefix;
    return joined;
  }

  void start_section(const std::string& type, const std::string& raw_name) {
    section_ = Section{type, nullptr, ignored_section_types.count(type) > 0};
    if (section_->ignored) {
      report_once("the section type '" + type + "'");
      return;
    }
    const bool named =
        type == "process" || type == "state" || type == "group" || type == "template" || type == "process_template";
    if (!named) {
      if (!raw_name.empty() && type != "defines")
        log(LogLevel::Warning, "the '" + type + "' section has no name; '" + raw_name + "' is ignored");
      return;
    }
    std::string name = evaluate(raw_name);
    if (name.empty()) fail("a '" + type + "' section needs a name");
    const std::string display_name = name;
    if (type == "process") defines_["_PROCESS"] = display_name;
    if (!file_.prefixes.empty()) name = join_prefixes(file_.prefixes) + "/" + name;
    if (type == "process") defines_["_FULL_PROCESS"] = name;
    auto draft = std::make_unique<Draft>();
    draft->type = type == "process_template" ? "template" : type;
    draft->display_name = display_name;
    draft->prefixes = file_.prefixes;
    draft->place = here();
    if (draft->type == "template")
      parse_template_header(*draft, name);
    else
      draft->name = name;
    if (const Draft* existing = drafts_.find_any(draft->name))
      fail("'" + draft->name + "' is defined twice: already as " + existing->type + " at " + existing->place.text());
    section_->draft = draft.get();
    drafts_.add(std::move(draft));
  }

  // `NAME(a, b=default)`: the template's parameters with their defaults.
  void parse_template_header(Draft& draft, const std::string& header) {
    const auto open = header.find('(');
    draft.name = strip(header.substr(0, open));
    if (open == std::string::npos) return;
    const auto close = header.rfind(')');
    if (close == std::string::npos || close < open) fail("template '" + header + "': '(' without ')'");
    const std::string params = header.substr(open + 1, close - open - 1);
    for (std::size_t start = 0; start <= params.size();) {
      const std::size_t comma = std::min(params.find(',', start), params.size());
      const std::string param = strip(params.substr(start, comma - start));
      start = comma + 1;
      if (param.empty()) continue;
      const auto equals = param.find('=');
      if (equals == std::string::npos)
        draft.template_params.emplace_back(param, "");
      else
        draft.template_params.emplace_back(strip(param.substr(0, equals)), evaluate(strip(param.substr(equals + 1))));
    }
  }

  void section_value(const std::string& key, const std::string& raw_value, const ConfigPlace& place) {
    const std::string& type = section_->type;
    if (type == "defines") {
      const std::string name = evaluate(key);
      if (Evaluator::is_function_definition(raw_value)) {
        try {
          evaluator_.define_function(name, raw_value);
        } catch (const EvaluationError& e) {
          fail(e.what());
        }
      } else {
        // A define that cannot be evaluated (a missing tool, an unset
        // variable) only matters where it is used.
        try {
          defines_[name] = evaluate(raw_value);
          define_problems_.erase(name);
        } catch (const ConfigError& e) {
          defines_.erase(name);
          define_problems_[name] = e.what();
          log(LogLevel::Warning, "define '" + name + "' cannot be evaluated: " + e.what());
        }
      }
    } else if (type == "node_map") {
      node_map_[key] = evaluate(raw_value);
    } else if (type == "instance") {
      instance_key(key, raw_value);
    } else if (section_->draft->type == "template") {
      section_->draft->body.push_back({key, raw_value, place});
    } else {
      apply(*section_->draft, key, raw_value, place, 0);
    }
  }

  void instance_key(const std::string& key, const std::string& raw_value) {
    const std::string value = evaluate(raw_value);
    if (key == "name") {
      settings_.instance_name = value;
    } else if (key == "manager") {
      try {
        const auto [host, port] = split_host_port(value);
        settings_.manager_host = host;
        settings_.manager_port = port;
      } catch (const std::invalid_argument& e) {
        fail("manager: " + std::string(e.what()));
      }
    } else if (key == "gen_message_definition_path") {
      settings_.generated_definition_dir = absolute_path(expand_home(value));
    } else if (key == "enable_auto_groups") {
      drafts_.auto_groups = value == "1" || value == "true" || value == "True" || value == "yes" || value == "on";
    } else if (is_limit_key(key)) {
      try {
        set_limit(settings_.limits, key, value);
      } catch (const std::invalid_argument& e) {
        fail(e.what());
      }
    } else if (instance_keys_ignored.count(key)) {
      report_once("the instance key '" + key + "'");
    } else {
      fail("unknown key '" + key + "' in the instance section");
    }
  }

  // ------------------------------------------------ keys of objects

  // One `key: value` line of a process, state or group (or of a template
  // used by one), with LN's list modifiers.
  void apply(Draft& draft, const std::string& key, const std::string& raw_value, const ConfigPlace& place, int depth) {
    const FileState saved_file = file_;
    const auto saved_defines = object_defines_;
    file_.path = place.file;
    file_.line = place.line;
    object_defines_ = {{"this_name", draft.display_name}, {"this_real_name", draft.name}, {"this_class", draft.type}};
    try {
      apply_key(draft, key, raw_value, place, depth);
    } catch (...) {
      object_defines_ = saved_defines;
      file_ = saved_file;
      throw;
    }
    object_defines_ = saved_defines;
    file_ = saved_file;
  }

  void apply_key(Draft& draft, const std::string& key, const std::string& raw_value, const ConfigPlace& place,
                 int depth) {
    if (key == "use_template" || key == "derive_from") {
      apply_template(draft, evaluate(raw_value), place, depth);
      return;
    }
    const std::string value = evaluate(raw_value);
    const std::string word = first_word(key);
    if (word == "append" || word == "prepend" || word == "remove") {
      const std::vector<std::string> parts = words(after_first_word(key));
      if (parts.size() != 2) fail("expected '" + word + " LIST_KEY ITEM: text', not '" + key + ":'");
      draft.edit_item(word, parts[0], parts[1], value, place);
    } else if (word == "add" || word == "del" || word == "reset") {
      const std::string list = after_first_word(key);
      if (list.empty()) fail("expected '" + word + " KEY: value'");
      if (word == "add")
        draft.add_item(list, value, place);
      else if (word == "del")
        draft.delete_item(list, value, place);
      else
        draft.reset(list, place);
    } else if (word == "alt_command" && draft.type == "process") {
      const std::string name = evaluate(after_first_word(key));
      if (name.empty()) fail("alt_command needs a name: 'alt_command NAME: command'");
      if (name == "default") fail("alt_command: the name 'default' is the process's command itself");
      draft.set_alt_command(name, value);
    } else if (word == "add_io_script" || word == "add_io_script_file") {
      report_once("'" + word + "' (io scripts)");
    } else if (!key.empty() && key.back() == '+') {
      draft.append(strip(key.substr(0, key.size() - 1)), value, place);
    } else {
      draft.set(key, value, place);
    }
  }

  void apply_template(Draft& draft, const std::string& use, const ConfigPlace& place, int depth) {
    if (depth > max_template_depth) fail("templates use each other too deeply (a template that uses itself?)");
    const auto open = use.find('(');
    const std::string name = strip(use.substr(0, open));
    std::vector<std::string> args;
    if (open != std::string::npos) {
      const auto close = use.rfind(')');
      if (close == std::string::npos || close < open) fail("use_template: '(' without ')' in '" + use + "'");
      args = template_arguments(use.substr(open + 1, close - open - 1));
    }
    const Draft* found = nullptr;
    for (std::size_t keep = draft.prefixes.size() + 1; keep-- > 0 && !found;) {
      const std::vector<std::string> scope(draft.prefixes.begin(), draft.prefixes.begin() + static_cast<long>(keep));
      const std::string full = scope.empty() ? name : join_prefixes(scope) + "/" + name;
      found = drafts_.find(full, "template");
    }
    if (!found) {
      if (drafts_.find_any(name))
        fail("use_template: '" + name + "' is a " + drafts_.find_any(name)->type + ", not a template");
      fail("use_template: there is no template '" + name + "'");
    }
    if (args.size() > found->template_params.size())
      fail("use_template: template '" + name + "' takes " + std::to_string(found->template_params.size()) +
           " argument(s), got " + std::to_string(args.size()));
    const std::string saved_using = using_file_;
    if (using_file_.empty()) using_file_ = place.file;
    struct Restore {
      std::string& target;
      std::string value;
      ~Restore() { target = value; }
    } restore{using_file_, saved_using};
    std::vector<std::pair<std::string, std::string>> bound;
    for (std::size_t i = 0; i < found->template_params.size(); ++i)
      bound.emplace_back(found->template_params[i].first, i < args.size() ? args[i] : found->template_params[i].second);
    for (const auto& line : found->body) {
      std::string value = line.value;
      for (const auto& [parameter, argument] : bound) {
        const std::string marker = "%(" + parameter + ")";
        for (auto at = value.find(marker); at != std::string::npos; at = value.find(marker, at + argument.size()))
          value.replace(at, marker.size(), argument);
      }
      try {
        apply(draft, line.key, value, line.place, depth + 1);
      } catch (const ConfigError& e) {
        throw ConfigError(place.file, place.line, std::string(e.what()) + " (in template '" + name + "' used here)");
      }
    }
  }

  // `"a", 'b', 3`: Python-like literals, as LN 2.9 evaluates them.
  std::vector<std::string> template_arguments(const std::string& text) {
    std::vector<std::string> args;
    std::size_t i = 0;
    auto skip_space = [&] {
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    };
    skip_space();
    while (i < text.size()) {
      std::string arg;
      if (text[i] == '"' || text[i] == '\'') {
        const char quote = text[i++];
        for (; i < text.size() && text[i] != quote; ++i) {
          if (text[i] == '\\' && i + 1 < text.size()) ++i;
          arg += text[i];
        }
        if (i >= text.size()) fail("use_template: an argument in '" + text + "' has no closing " + quote);
        ++i;
      } else {
        const auto comma = std::min(text.find(',', i), text.size());
        arg = strip(text.substr(i, comma - i));
        i = comma;
      }
      args.push_back(arg);
      skip_space();
      if (i < text.size() && text[i] != ',') fail("use_template: expected ',' between the arguments in '" + text + "'");
      ++i;
      skip_space();
    }
    return args;
  }

  const LogFunction& log_;
  LncContext context_;
  Evaluator evaluator_;
  FileState file_;
  std::optional<Section> section_;
  std::map<std::string, std::string> defines_;
  std::map<std::string, std::string> define_problems_;  ///< define -> why it has no value
  std::map<std::string, std::string> object_defines_;
  std::string using_file_;  ///< while a template is replayed: the file that uses it
  std::map<std::string, std::string> node_map_;
  std::set<std::string> reported_;
  LncSettings settings_;
  Drafts drafts_;
};

}  // namespace

ConfigError::ConfigError(const std::string& file, int line, const std::string& reason)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + reason),
      file_(file),
      line_(line) {}

std::pair<std::string, std::uint16_t> split_host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw std::invalid_argument("'" + text + "' is not [HOST]:PORT");
  const std::string host = strip(std::string_view(text).substr(0, colon));
  const std::string port = strip(std::string_view(text).substr(colon + 1));
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoul(port) > 65535)
    throw std::invalid_argument("'" + port + "' in '" + text + "' is not a port number (0..65535)");
  return {host, static_cast<std::uint16_t>(std::stoul(port))};
}

LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const LncContext& context) {
  LncReader reader(log, context);
  reader.read_text(text, path, 0, {});
  return reader.finish();
}

LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const LncContext& context) {
  if (!is_regular_file(path)) throw ConfigError(path, 0, "no such configuration file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path, 0, "cannot read the configuration file");
  return read_lnc_text(read_whole_file(path), path, log, context);
}

LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const std::string& instance_name) {
  LncContext context;
  context.instance_name = instance_name;
  return read_lnc_file(path, log, context);
}

LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const std::string& instance_name) {
  LncContext context;
  context.instance_name = instance_name;
  return read_lnc_text(text, path, log, context);
}

}  // namespace ln::manager
