#include "manager/config.hpp"

#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "manager/limits.hpp"

namespace ln::manager {
namespace {

constexpr int max_include_depth = 32;
constexpr int max_evaluation_depth = 32;

// The section types of LN 2.9; only `instance` and `defines` mean anything here.
const std::set<std::string, std::less<>> known_section_types = {
    "instance", "defines", "hosts", "node_map", "custom_start_tools", "process", "network",
    "state", "template", "process_template", "group", "gui_plugin", "plugin", "topic"};

// Directives of LN 2.9 this manager does not carry out.
const std::set<std::string, std::less<>> unsupported_directives = {
    "include_glob", "optional_include_glob", "pipe_include", "push_name_prefix", "pop_name_prefix",
    "requires_version", "add_process_default_template"};

std::string_view strip(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

std::string first_word(std::string_view line) { return std::string(line.substr(0, line.find_first_of(" \t"))); }

std::string rest_after_first_word(std::string_view line) {
  const auto space = line.find_first_of(" \t");
  return space == std::string_view::npos ? std::string() : std::string(strip(line.substr(space)));
}

// A single-line value: "quoted" keeps everything inside the quotes,
// otherwise an unquoted '#' starts a comment (LN >= 2.8).
std::string single_line_value(std::string_view raw) {
  raw = strip(raw);
  if (!raw.empty() && raw.front() == '"') {
    const auto closing = raw.find('"', 1);
    if (closing != std::string_view::npos) return std::string(raw.substr(1, closing - 1));
  }
  return std::string(strip(raw.substr(0, raw.find('#'))));
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

std::string basename_of(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string expand_home(const std::string& path) {
  const char* home = std::getenv("HOME");
  if (home && (path == "~" || starts_with(path, "~/"))) return home + path.substr(1);
  return path;
}

bool is_directory(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool is_regular_file(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
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

class LncReader {
 public:
  LncReader(const LogFunction& log, std::string instance_name_override)
      : log_(log), instance_name_override_(std::move(instance_name_override)) {}

  void read_text(const std::string& text, const std::string& path, int depth) {
    if (depth > max_include_depth) throw ConfigError(path, 0, "includes are nested too deeply (an include loop?)");
    const std::string saved_file = file_;
    file_ = path;
    const std::vector<std::string> lines = split_lines(text);
    for (std::size_t index = 0; index < lines.size(); ++index) read_line(lines, index, depth);
    file_ = saved_file;
  }

  LncSettings settings() const {
    LncSettings result = settings_;
    if (!instance_name_override_.empty()) result.instance_name = instance_name_override_;
    return result;
  }

 private:
  struct Define {
    std::string value;
    std::string problem;  ///< why the value could not be evaluated ("" = fine)
  };

  [[noreturn]] void fail(int line, const std::string& reason) const { throw ConfigError(file_, line, reason); }

  void log(LogLevel level, int line, const std::string& text) const {
    if (log_) log_(level, file_ + ":" + std::to_string(line) + ": " + text);
  }

  void report_unsupported_once(const std::string& what, int line) {
    if (reported_.insert(what).second)
      log(LogLevel::Warning, line, what + " is not supported by ln_core's manager and is ignored (reported once)");
  }

  // ------------------------------------------------------------ lines

  void read_line(const std::vector<std::string>& lines, std::size_t& index, int depth) {
    const int line_number = static_cast<int>(index) + 1;
    std::string line(strip(lines[index]));
    if (line.empty() || line.front() == '#') return;

    bool skipped = false;
    for (std::string word = first_word(line); word == "ifdef" || word == "ifndef"; word = first_word(line)) {
      const std::string condition = rest_after_first_word(line);
      const auto colon = condition.find(':');
      if (colon == std::string::npos) fail(line_number, "expected '" + word + " DEFINE: line'");
      const std::string name(strip(std::string_view(condition).substr(0, colon)));
      const auto define = defines_.find(name);
      const bool defined = define != defines_.end() && !define->second.value.empty();
      if (defined != (word == "ifdef")) skipped = true;
      line = std::string(strip(std::string_view(condition).substr(colon + 1)));
      if (line.empty()) return;
    }

    const std::string word = first_word(single_line_value(line));
    const std::string directive = word.size() > 1 && word.back() == ':' ? word.substr(0, word.size() - 1) : word;
    if (directive == "include" || directive == "optional_include") {
      if (!skipped) include(directive == "optional_include", argument_of(line), line_number, depth);
      return;
    }
    if (directive == "add_message_definition_dir") {
      if (!skipped) add_message_definition_dir(argument_of(line), line_number);
      return;
    }
    if (word == "warning:") {
      if (!skipped) log(LogLevel::Warning, line_number, evaluate(argument_of(line), line_number));
      return;
    }
    if (unsupported_directives.count(directive)) {
      if (!skipped) report_unsupported_once("the directive '" + directive + "'", line_number);
      return;
    }
    if (known_section_types.count(word)) {
      if (!skipped) start_section(word, line_number);
      return;
    }

    const auto colon = line.find(':');
    if (colon == std::string::npos) {
      if (section_.empty())
        fail(line_number, "expected a section (like 'instance' or 'defines') or a directive, not '" + line + "'");
      if (!section_supported()) return;  // lines of sections we ignore need not make sense to us
      fail(line_number, "expected 'key: value' in the '" + section_ + "' section, not '" + line + "'");
    }
    const std::string key(strip(std::string_view(line).substr(0, colon)));
    const std::string_view raw = strip(std::string_view(line).substr(colon + 1));
    const std::string value = !raw.empty() && raw.front() == '[' ? block_value(lines, index, raw)
                                                                  : single_line_value(raw);
    if (skipped) return;
    if (section_.empty()) fail(line_number, "'" + key + ":' appears before any section");
    if (key == "undef") {
      defines_.erase(evaluate(value, line_number));
      return;
    }
    if (section_ == "defines") define(key, value, line_number);
    if (section_ == "instance") instance_key(key, value, line_number);
  }

  // The text after a directive word, with or without its ':'.
  std::string argument_of(const std::string& line) const {
    std::string rest = line.substr(first_word(line).size());
    if (!rest.empty() && rest.front() == ':') rest.erase(0, 1);
    return single_line_value(rest);
  }

  // A `key: [ ... ]` value may span lines; they are joined with spaces and
  // comment lines inside are dropped.
  std::string block_value(const std::vector<std::string>& lines, std::size_t& index, std::string_view first) {
    const int start_line = static_cast<int>(index) + 1;
    std::string joined;
    std::string_view part = first.substr(1);
    for (;;) {
      const std::string_view trimmed = strip(part);
      const bool last = !trimmed.empty() && trimmed.back() == ']';
      const std::string_view content = last ? trimmed.substr(0, trimmed.size() - 1) : trimmed;
      if (!content.empty() && content.front() != '#') joined += (joined.empty() ? "" : " ") + std::string(strip(content));
      if (last) return joined;
      if (++index >= lines.size()) fail(start_line, "the '[' block that starts here has no closing ']'");
      part = lines[index];
    }
  }

  bool section_supported() const { return section_ == "instance" || section_ == "defines"; }

  void start_section(const std::string& type, int line) {
    section_ = type;
    if (!section_supported()) report_unsupported_once("the section type '" + type + "'", line);
  }

  void define(const std::string& name, const std::string& raw_value, int line) {
    const std::string key = evaluate(name, line);
    Define& define = defines_[key];
    try {
      define = {evaluate(raw_value, line), ""};
    } catch (const ConfigError& e) {
      // Only fatal where it is used: the define may serve sections we ignore.
      define = {"", e.what()};
      log(LogLevel::Warning, line, "define '" + key + "' cannot be evaluated: " + e.what());
    }
  }

  void instance_key(const std::string& key, const std::string& raw_value, int line) {
    if (key == "name") {
      settings_.instance_name = evaluate(raw_value, line);
    } else if (key == "manager") {
      const std::string value = evaluate(raw_value, line);
      try {
        const auto [host, port] = split_host_port(value);
        settings_.manager_host = host;
        settings_.manager_port = port;
      } catch (const std::invalid_argument& e) {
        fail(line, "manager: " + std::string(e.what()));
      }
    } else if (key == "gen_message_definition_path") {
      settings_.generated_definition_dir = absolute_path(expand_home(evaluate(raw_value, line)));
    } else if (is_limit_key(key)) {
      try {
        set_limit(settings_.limits, key, evaluate(raw_value, line));
      } catch (const std::invalid_argument& e) {
        fail(line, e.what());
      }
    } else {
      report_unsupported_once("the instance key '" + key + "'", line);
    }
  }

  void include(bool optional, const std::string& argument, int line, int depth) {
    std::string path = evaluate(argument, line);
    if (path.empty()) fail(line, "include needs a file name");
    path = expand_home(path);
    if (path.front() != '/') path = dirname_of(file_) + "/" + path;
    if (!is_regular_file(path)) {
      if (optional) {
        log(LogLevel::Debug, line, "optional include '" + path + "' does not exist");
        return;
      }
      fail(line, "cannot include '" + path + "': no such file");
    }
    read_text(read_whole_file(path), path, depth + 1);
  }

  void add_message_definition_dir(const std::string& argument, int line) {
    const std::string dir = absolute_path(expand_home(evaluate(argument, line)));
    if (!is_directory(dir)) log(LogLevel::Warning, line, "message-definition directory '" + dir + "' does not exist");
    auto& dirs = settings_.message_definition_dirs;
    if (std::find(dirs.begin(), dirs.end(), dir) == dirs.end()) dirs.push_back(dir);
  }

  // -------------------------------------------------------- evaluation

  // Replaces every %( ... ) in `text`, innermost first.
  std::string evaluate(const std::string& text, int line, int depth = 0) const {
    if (depth > max_evaluation_depth) fail(line, "%( ) replacements are nested too deeply");
    std::string out;
    for (std::size_t i = 0; i < text.size();) {
      if (text.compare(i, 2, "%(") != 0) {
        out += text[i++];
        continue;
      }
      int open = 1;
      std::size_t end = i + 2;
      for (; end < text.size() && open > 0; ++end) {
        if (text[end] == '(') ++open;
        if (text[end] == ')') --open;
      }
      if (open > 0) fail(line, "'%(' without its closing ')' in '" + text + "'");
      const std::string inner = evaluate(text.substr(i + 2, end - 1 - (i + 2)), line, depth + 1);
      out += replacement(std::string(strip(inner)), line);
      i = end;
    }
    return out;
  }

  std::string replacement(const std::string& inner, int line) const {
    const auto space = inner.find_first_of(" \t");
    if (space == std::string::npos) return define_value(inner, line);
    const std::string function = inner.substr(0, space);
    const std::string arguments(strip(std::string_view(inner).substr(space)));
    if (function == "env") {
      const auto comma = arguments.find(',');
      const std::string name(strip(std::string_view(arguments).substr(0, comma)));
      if (const char* value = std::getenv(name.c_str())) return value;
      if (comma == std::string::npos) fail(line, "the environment variable '" + name + "' is not set");
      return single_line_value(std::string_view(arguments).substr(comma + 1));
    }
    if (function == "get_port_from_string") {
      // LN's stable port for a text: 1024 + (sum of the characters) mod 64511.
      unsigned long sum = 0;
      for (unsigned char c : arguments) sum += c;
      return std::to_string(1024 + sum % 64511);
    }
    if (function == "dirname") return dirname_of(arguments);
    if (function == "basename") return basename_of(arguments);
    if (function == "realpath") return real_path(arguments);
    if (function == "strip") return arguments;
    if (function == "shell")
      fail(line, "%(shell ...) is not supported: ln_core's manager never runs commands from its config");
    fail(line, "the function '" + function + "' in %(" + inner + ") is not supported by ln_core's manager");
  }

  std::string define_value(const std::string& name, int line) const {
    if (name == "CURDIR") return dirname_of(real_path(file_));
    if (name == "CURRENT") return real_path(file_);
    if (name == "instance_name")
      return instance_name_override_.empty() ? settings_.instance_name : instance_name_override_;
    if (name == "hostname") {
      char host[256] = "";
      ::gethostname(host, sizeof host - 1);
      return host;
    }
    if (name == "manager" && settings_.manager_port)
      return (settings_.manager_host->empty() ? "127.0.0.1" : *settings_.manager_host) + ":" +
             std::to_string(*settings_.manager_port);
    const auto it = defines_.find(name);
    if (it == defines_.end()) fail(line, "there is no define '" + name + "'");
    if (!it->second.problem.empty()) fail(line, "define '" + name + "' is unusable: " + it->second.problem);
    return it->second.value;
  }

  const LogFunction& log_;
  std::string instance_name_override_;
  std::string file_;
  std::string section_;
  std::map<std::string, Define> defines_;
  std::set<std::string> reported_;
  LncSettings settings_;
};

}  // namespace

ConfigError::ConfigError(const std::string& file, int line, const std::string& reason)
    : std::runtime_error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + reason),
      file_(file),
      line_(line) {}

std::pair<std::string, std::uint16_t> split_host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw std::invalid_argument("'" + text + "' is not [HOST]:PORT");
  const std::string host(strip(std::string_view(text).substr(0, colon)));
  const std::string port(strip(std::string_view(text).substr(colon + 1)));
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoul(port) > 65535)
    throw std::invalid_argument("'" + port + "' in '" + text + "' is not a port number (0..65535)");
  return {host, static_cast<std::uint16_t>(std::stoul(port))};
}

LncSettings read_lnc_text(const std::string& text, const std::string& path, const LogFunction& log,
                          const std::string& instance_name) {
  LncReader reader(log, instance_name);
  reader.read_text(text, path, 0);
  return reader.settings();
}

LncSettings read_lnc_file(const std::string& path, const LogFunction& log, const std::string& instance_name) {
  if (!is_regular_file(path)) throw ConfigError(path, 0, "no such configuration file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path, 0, "cannot read the configuration file");
  return read_lnc_text(read_whole_file(path), path, log, instance_name);
}

}  // namespace ln::manager
