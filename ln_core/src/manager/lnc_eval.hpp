// The string evaluation of LN's .lnc language (ln_spec §6.3): every
// `%(NAME)` is replaced by a define and every `%(FUNCTION ARGS)` by what the
// built-in or user-defined function returns, innermost first. Used by the
// config reader (config.cpp) for values, section names and directive
// arguments. Knows no files: the reader supplies the defines through
// Defines and turns EvaluationError into a "FILE:LINE: reason" ConfigError.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ln::manager {

/// Why a text cannot be evaluated (no file or line: the caller knows them).
class EvaluationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Evaluator {
 public:
  /// The value of a define, or nullopt when there is none of that name.
  using Defines = std::function<std::optional<std::string>(const std::string& name)>;
  /// Whether `node` names this host (for get_host_ifip and friends).
  using IsLocalNode = std::function<bool(const std::string& node)>;

  Evaluator(Defines defines, IsLocalNode is_local_node);

  /// `text` with every %( ) replaced. Throws EvaluationError.
  std::string evaluate(const std::string& text) const;

  /// Registers `%(deffun "a,b", "body")` (the value of a define NAME) as the
  /// function NAME: a call evaluates `body` with a and b defined as its
  /// arguments. Throws EvaluationError when `definition` is malformed.
  void define_function(const std::string& name, const std::string& definition);

  /// True if `text` (a define's raw value) defines a function.
  static bool is_function_definition(const std::string& text);

  /// LN's function arguments: `"a", "b"` is a list of quoted strings (a
  /// backslash escapes the next character but stays, as in LN 2.9);
  /// anything else is one argument, as written.
  static std::vector<std::string> split_arguments(const std::string& text);

  /// Limits what `%(shell ...)` may take: its run time in seconds.
  void set_shell_timeout(double seconds) { shell_timeout_ = seconds; }

 private:
  struct UserFunction {
    std::vector<std::string> parameters;
    std::string body;
  };

  std::string evaluate(const std::string& text, int depth, const std::map<std::string, std::string>* arguments) const;
  std::string replacement(const std::string& inner, int depth,
                          const std::map<std::string, std::string>* arguments) const;
  std::string call(const std::string& function, const std::string& arguments, int depth) const;
  std::string define_value(const std::string& name, const std::map<std::string, std::string>* arguments) const;
  std::string run_shell(const std::string& command) const;

  Defines defines_;
  IsLocalNode is_local_node_;
  std::map<std::string, UserFunction> functions_;
  double shell_timeout_ = 30;
};

/// What a shell command printed and how it ended.
struct ShellResult {
  std::string output;  ///< stdout (at most 1 MiB)
  std::string errors;  ///< stderr (at most 1 MiB)
  int status = -1;     ///< exit status; -1 when killed by a signal or timed out
  bool timed_out = false;
};

/// Runs `/bin/sh -c command` with stdin from /dev/null and LANG=C, waiting
/// at most `timeout_seconds` (then it is killed). Throws EvaluationError
/// when it cannot be started.
ShellResult run_shell_command(const std::string& command, double timeout_seconds);

/// The words of a command line as a POSIX shell splits them, without any
/// expansion: blanks separate, '...' and "..." group, backslash escapes.
/// Throws EvaluationError for an unclosed quote.
std::vector<std::string> split_words(const std::string& text);

/// The index of the ')' that closes the "%(" at `open` in `text` (quoted
/// strings and \( \) inside do not count), or std::string::npos.
std::size_t replacement_end(const std::string& text, std::size_t open);

/// LN's stable port for a text: 1024 + (sum of its bytes) mod 64511.
unsigned port_from_string(const std::string& text);

/// The IPv4 address of the network interface `name`; nullopt if it has none.
std::optional<std::string> interface_ipv4(const std::string& name);

}  // namespace ln::manager
