#include "manager/lnc_eval.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <ifaddrs.h>
#include <limits.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace ln::manager {
namespace {

constexpr int max_depth = 32;
constexpr std::size_t max_shell_output = 1u << 20;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

std::string strip(const std::string& s) {
  std::size_t first = 0, last = s.size();
  while (first < last && is_space(s[first])) ++first;
  while (last > first && is_space(s[last - 1])) --last;
  return s.substr(first, last - first);
}

// Past the closing quote of the "..." that starts at `open`, or npos.
std::size_t after_quoted(const std::string& text, std::size_t open) {
  for (std::size_t i = open + 1; i < text.size(); ++i) {
    if (text[i] == '\\')
      ++i;
    else if (text[i] == '"')
      return i + 1;
  }
  return std::string::npos;
}

// The index of the ')' that closes the '%(' at `open`, or npos. Quoted
// strings and \( \) inside do not count.
std::size_t closing_paren(const std::string& text, std::size_t open) {
  int depth = 1;
  for (std::size_t i = open + 2; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\\' && i + 1 < text.size()) {
      ++i;
    } else if (c == '"') {
      const std::size_t end = after_quoted(text, i);
      if (end == std::string::npos) return std::string::npos;
      i = end - 1;
    } else if (c == '(') {
      ++depth;
    } else if (c == ')' && --depth == 0) {
      return i;
    }
  }
  return std::string::npos;
}

// The first whitespace of `inner` outside nested %( ) and quotes, or npos.
std::size_t top_level_space(const std::string& inner) {
  for (std::size_t i = 0; i < inner.size(); ++i) {
    if (inner.compare(i, 2, "%(") == 0) {
      const std::size_t close = closing_paren(inner, i);
      if (close == std::string::npos) return std::string::npos;
      i = close;
    } else if (is_space(inner[i])) {
      return i;
    }
  }
  return std::string::npos;
}

std::string python_dirname(const std::string& path) {
  const auto slash = path.rfind('/');
  if (slash == std::string::npos) return "";
  std::string head = path.substr(0, slash + 1);
  // os.path.dirname keeps a root of slashes, strips trailing ones otherwise
  if (head.find_first_not_of('/') != std::string::npos)
    while (head.size() > 1 && head.back() == '/') head.pop_back();
  return head;
}

std::string python_basename(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string real_path(const std::string& path) {
  char resolved[PATH_MAX];
  if (::realpath(path.c_str(), resolved)) return resolved;
  return path;  // os.path.realpath of a missing path: kept as it is
}

bool path_exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

long to_integer(const std::string& text, const std::string& function) {
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || errno != 0 || *end != '\0')
    throw EvaluationError("%(" + function + " ...): '" + text + "' is not an integer");
  return value;
}

void require_count(const std::vector<std::string>& args, std::size_t low, std::size_t high, const std::string& function,
                   const char* form) {
  if (args.size() < low || args.size() > high)
    throw EvaluationError("%(" + function + " ...) takes " + form + " (quoted, comma-separated), got " +
                          std::to_string(args.size()) + " argument(s)");
}

}  // namespace

std::vector<std::string> split_words(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (is_space(c)) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else if (c == '\'' || c == '"') {
      in_word = true;
      std::size_t j = i + 1;
      for (; j < text.size() && text[j] != c; ++j) {
        if (c == '"' && text[j] == '\\' && j + 1 < text.size() && std::strchr("\"\\$`", text[j + 1]) != nullptr) ++j;
        word += text[j];
      }
      if (j >= text.size())
        throw EvaluationError(std::string("a ") + c + " has no closing " + c + " in '" + text + "'");
      i = j;
    } else if (c == '\\' && i + 1 < text.size()) {
      in_word = true;
      word += text[++i];
    } else {
      in_word = true;
      word += c;
    }
  }
  if (in_word) words.push_back(word);
  return words;
}

std::size_t replacement_end(const std::string& text, std::size_t open) { return closing_paren(text, open); }

unsigned port_from_string(const std::string& text) {
  unsigned long sum = 0;
  for (unsigned char c : text) sum += c;
  return static_cast<unsigned>(1024 + sum % 64511);
}

std::optional<std::string> interface_ipv4(const std::string& name) {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return std::nullopt;
  std::optional<std::string> found;
  for (ifaddrs* entry = list; entry != nullptr && !found; entry = entry->ifa_next) {
    if (entry->ifa_addr == nullptr || entry->ifa_addr->sa_family != AF_INET || name != entry->ifa_name) continue;
    char text[INET_ADDRSTRLEN] = "";
    ::inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(entry->ifa_addr)->sin_addr, text, sizeof text);
    found = text;
  }
  ::freeifaddrs(list);
  return found;
}

Evaluator::Evaluator(Defines defines, IsLocalNode is_local_node)
    : defines_(std::move(defines)), is_local_node_(std::move(is_local_node)) {}

std::string Evaluator::evaluate(const std::string& text) const { return evaluate(text, 0, nullptr); }

std::string Evaluator::evaluate(const std::string& text, int depth,
                                const std::map<std::string, std::string>* arguments) const {
  if (depth > max_depth) throw EvaluationError("%( ) replacements are nested too deeply (a define that uses itself?)");
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    if (text[i] == '\\' && i + 1 < text.size() && (text[i + 1] == '(' || text[i + 1] == ')')) {
      out += text[i + 1];
      i += 2;
    } else if (text.compare(i, 2, "%(") == 0) {
      const std::size_t close = closing_paren(text, i);
      if (close == std::string::npos) throw EvaluationError("'%(' without its closing ')' in '" + text + "'");
      out += replacement(text.substr(i + 2, close - i - 2), depth + 1, arguments);
      i = close + 1;
    } else {
      out += text[i++];
    }
  }
  return out;
}

std::string Evaluator::replacement(const std::string& raw_inner, int depth,
                                   const std::map<std::string, std::string>* arguments) const {
  const std::string inner = strip(raw_inner);
  const std::size_t space = top_level_space(inner);
  if (space == std::string::npos) return define_value(evaluate(inner, depth, arguments), arguments);
  const std::string function = evaluate(inner.substr(0, space), depth, arguments);
  const std::string args = evaluate(strip(inner.substr(space)), depth, arguments);
  return call(function, args, depth);
}

std::string Evaluator::define_value(const std::string& name,
                                    const std::map<std::string, std::string>* arguments) const {
  if (arguments != nullptr) {
    if (const auto it = arguments->find(name); it != arguments->end()) return it->second;
  }
  if (auto value = defines_(name)) return *value;
  throw EvaluationError("there is no define '" + name + "'");
}

std::string Evaluator::call(const std::string& function, const std::string& raw, int depth) const {
  if (const auto user = functions_.find(function); user != functions_.end()) {
    const std::vector<std::string> args = split_arguments(raw);
    std::map<std::string, std::string> bound;
    for (std::size_t i = 0; i < user->second.parameters.size(); ++i)
      bound[user->second.parameters[i]] = i < args.size() ? args[i] : "";
    return evaluate(user->second.body, depth, &bound);
  }
  if (function == "strip") return strip(raw);
  if (function == "get_port_from_string") {
    std::string joined;
    for (const auto& part : split_arguments(raw)) joined += (joined.empty() ? "" : " ") + part;
    return std::to_string(port_from_string(joined));
  }
  std::vector<std::string> args = split_arguments(raw);
  if (function == "env") {
    // ln_core also takes `env NAME, DEFAULT` unquoted.
    if (args.size() == 1 && raw.find(',') != std::string::npos && raw.front() != '"') {
      const auto comma = raw.find(',');
      args = {strip(raw.substr(0, comma)), strip(raw.substr(comma + 1))};
    }
    require_count(args, 1, 2, function, "NAME or \"NAME\", \"DEFAULT\"");
    if (const char* value = std::getenv(args[0].c_str())) return value;
    if (args.size() == 2) return args[1];
    throw EvaluationError("the environment variable '" + args[0] + "' is not set");
  }
  if (function == "realpath" || function == "dirname" || function == "basename" || function == "length" ||
      function == "ifip" || function == "shell") {
    require_count(args, 1, 1, function, "one argument");
    if (function == "realpath") return real_path(args[0]);
    if (function == "dirname") return python_dirname(args[0]);
    if (function == "basename") return python_basename(args[0]);
    if (function == "length") return std::to_string(args[0].size());
    if (function == "shell") return run_shell(args[0]);
    if (auto ip = interface_ipv4(args[0])) return *ip;
    throw EvaluationError("%(ifip " + args[0] + "): this host has no interface '" + args[0] + "' with an IPv4 address");
  }
  if (function == "subst") {
    require_count(args, 3, 3, function, "\"SEARCH\", \"REPLACE\", \"TEXT\"");
    if (args[0].empty()) return args[2];
    std::string text = args[2];
    for (std::size_t at = text.find(args[0]); at != std::string::npos; at = text.find(args[0], at + args[1].size()))
      text.replace(at, args[0].size(), args[1]);
    return text;
  }
  if (function == "substring") {
    require_count(args, 2, 3, function, "\"TEXT\", \"START\"[, \"COUNT\"]");
    const long size = static_cast<long>(args[0].size());
    long start = to_integer(args[1], function);
    if (start < 0) start = std::max(0L, size + start);  // Python slicing
    start = std::min(start, size);
    long count = args.size() == 3 ? to_integer(args[2], function) : size - start;
    long end = count < 0 ? size + count : start + count;
    end = std::max(start, std::min(end, size));
    return args[0].substr(static_cast<std::size_t>(start), static_cast<std::size_t>(end - start));
  }
  if (function == "findstring") {
    require_count(args, 2, 2, function, "\"SEARCH\", \"TEXT\"");
    return args[1].find(args[0]) != std::string::npos ? args[0] : "";
  }
  if (function == "ifndef") {
    require_count(args, 2, 2, function, "\"DEFINE\", \"VALUE_IF_NOT_DEFINED\"");
    if (auto value = defines_(args[0])) return *value;
    return args[1];
  }
  if (function == "ifexists") {
    require_count(args, 3, 3, function, "\"PATH\", \"IF_EXISTS\", \"IF_NOT\"");
    return path_exists(args[0]) ? args[1] : args[2];
  }
  if (function == "ifeq") {
    require_count(args, 4, 4, function, "\"A\", \"B\", \"IF_EQUAL\", \"IF_NOT\"");
    return args[0] == args[1] ? args[2] : args[3];
  }
  if (function == "get_host_ifip") {
    require_count(args, 2, 2, function, "\"NODE\", \"INTERFACE\"");
    if (!is_local_node_(args[0]))
      throw EvaluationError("%(get_host_ifip " + raw + "): '" + args[0] +
                            "' is another host; ln_core's manager knows only its own host's interfaces");
    if (auto ip = interface_ipv4(args[1])) return *ip;
    throw EvaluationError("%(get_host_ifip " + raw + "): this host has no interface '" + args[1] + "'");
  }
  if (function == "get_host_ip_reachable_from_host") {
    require_count(args, 2, 2, function, "\"FROM_NODE\", \"NODE\"");
    if (is_local_node_(args[0]) && is_local_node_(args[1])) return "127.0.0.1";
    throw EvaluationError("%(get_host_ip_reachable_from_host " + raw +
                          "): ln_core's manager knows only its own host (no hosts and networks)");
  }
  if (function == "deffun")
    throw EvaluationError("%(deffun ...) defines a function only as the whole value of a define");
  throw EvaluationError("there is no function '" + function + "'");
}

std::string Evaluator::run_shell(const std::string& command) const {
  const ShellResult result = run_shell_command(command, shell_timeout_);
  if (result.timed_out)
    throw EvaluationError("%(shell " + command + "): did not finish within " + std::to_string(int(shell_timeout_)) +
                          " s");
  const std::string errors = strip(result.errors);
  if (result.status != 0 || !errors.empty())
    throw EvaluationError("%(shell " + command + ") failed" +
                          (result.status >= 0 ? " with exit status " + std::to_string(result.status)
                                              : std::string(" (killed by a signal)")) +
                          (errors.empty() ? "" : ": " + errors));
  std::string output = result.output;
  while (!output.empty() && output.back() == '\n') output.pop_back();
  return output;
}

ShellResult run_shell_command(const std::string& command, double timeout_seconds) {
  int out_pipe[2], err_pipe[2];
  if (::pipe2(out_pipe, O_CLOEXEC) != 0) throw EvaluationError("pipe: " + std::string(std::strerror(errno)));
  if (::pipe2(err_pipe, O_CLOEXEC) != 0) {
    ::close(out_pipe[0]);
    ::close(out_pipe[1]);
    throw EvaluationError("pipe: " + std::string(std::strerror(errno)));
  }
  // Everything the child needs is prepared here: between fork and exec a
  // multi-threaded process may only make async-signal-safe calls.
  std::vector<std::string> environment{"LANG=C"};
  for (char** entry = environ; *entry != nullptr; ++entry)
    if (std::strncmp(*entry, "LANG=", 5) != 0) environment.emplace_back(*entry);
  std::vector<char*> envp;
  for (auto& entry : environment) envp.push_back(entry.data());
  envp.push_back(nullptr);
  std::string shell = "/bin/sh", dash_c = "-c", command_copy = command;
  char* argv[] = {shell.data(), dash_c.data(), command_copy.data(), nullptr};
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int null = ::open("/dev/null", O_RDONLY);
    ::dup2(null, 0);
    ::dup2(out_pipe[1], 1);
    ::dup2(err_pipe[1], 2);
    ::execve(argv[0], argv, envp.data());
    ::_exit(127);
  }
  ::close(out_pipe[1]);
  ::close(err_pipe[1]);
  if (pid < 0) {
    ::close(out_pipe[0]);
    ::close(err_pipe[0]);
    throw EvaluationError("fork: " + std::string(std::strerror(errno)));
  }
  ShellResult result;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_seconds);
  pollfd fds[2] = {{out_pipe[0], POLLIN, 0}, {err_pipe[0], POLLIN, 0}};
  const int originals[2] = {out_pipe[0], err_pipe[0]};
  int open_fds = 2;
  while (open_fds > 0) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      result.timed_out = true;
      break;
    }
    if (::poll(fds, 2, static_cast<int>(left.count())) < 0 && errno != EINTR) break;
    for (int k = 0; k < 2; ++k) {
      pollfd& p = fds[k];
      if (p.fd < 0 || !(p.revents & (POLLIN | POLLHUP | POLLERR))) continue;
      char buffer[4096];
      const ssize_t n = ::read(p.fd, buffer, sizeof buffer);
      if (n > 0) {
        std::string& into = k == 0 ? result.output : result.errors;
        if (into.size() < max_shell_output) into.append(buffer, static_cast<std::size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        p.fd = -1;
        --open_fds;
      }
    }
  }
  ::close(originals[0]);
  ::close(originals[1]);
  if (result.timed_out) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.status = !result.timed_out && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

bool Evaluator::is_function_definition(const std::string& text) { return strip(text).rfind("%(deffun ", 0) == 0; }

void Evaluator::define_function(const std::string& name, const std::string& definition) {
  std::string text = strip(definition);
  if (!is_function_definition(text) || text.back() != ')')
    throw EvaluationError("a function definition is %(deffun \"PARAMETERS\", \"BODY\"), not '" + text + "'");
  const std::vector<std::string> parts = split_arguments(strip(text.substr(9, text.size() - 10)));
  if (parts.size() != 2)
    throw EvaluationError("%(deffun ...) takes \"PARAMETERS\", \"BODY\" (quoted, comma-separated)");
  UserFunction function;
  std::string parameters = parts[0];
  for (std::size_t start = 0; start <= parameters.size();) {
    const std::size_t comma = std::min(parameters.find(',', start), parameters.size());
    const std::string parameter = strip(parameters.substr(start, comma - start));
    if (!parameter.empty()) function.parameters.push_back(parameter);
    start = comma + 1;
  }
  function.body = parts[1];
  functions_[name] = std::move(function);
}

std::vector<std::string> Evaluator::split_arguments(const std::string& text) {
  std::size_t i = 0;
  while (i < text.size() && is_space(text[i])) ++i;
  if (i >= text.size() || text[i] != '"') return {text};
  std::vector<std::string> args;
  for (;;) {
    if (i >= text.size() || text[i] != '"') throw EvaluationError("expected a quoted argument in '" + text + "'");
    std::string arg;
    ++i;
    for (; i < text.size() && text[i] != '"'; ++i) {
      if (text[i] == '\\' && i + 1 < text.size()) arg += text[i++];  // kept as written, as LN 2.9 does
      arg += text[i];
    }
    if (i >= text.size()) throw EvaluationError("a quoted argument in '" + text + "' has no closing '\"'");
    args.push_back(std::move(arg));
    ++i;
    while (i < text.size() && is_space(text[i])) ++i;
    if (i >= text.size()) return args;
    if (text[i] != ',') throw EvaluationError("expected ',' between the quoted arguments in '" + text + "'");
    ++i;
    while (i < text.size() && is_space(text[i])) ++i;
  }
}

}  // namespace ln::manager
