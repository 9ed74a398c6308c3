// Topic and service name mappings (ln_spec §5.5): a program can be pointed
// at other names without changing its code, by --ln-map-topic SRC DST, by
// LN_MAP_TOPICS="src|dst|src|dst" or by the manager's config.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace ln::clientlib {

class NameMapping {
 public:
  /// A source pattern and its replacement. Pattern forms: "^abc$" the whole
  /// name, "^abc" a prefix, "abc$" a suffix, "abc" the first occurrence.
  /// (LN 2.9 replaces every name that merely starts with abc by "^abc$";
  /// we keep to the documented meaning.)
  struct Rule {
    std::string source;
    std::string destination;
  };

  void add(Rule rule) { rules_.push_back(std::move(rule)); }
  void add_all(const std::vector<Rule>& rules);
  /// Adds the pairs of an LN_MAP_* value ("src|dst|src|dst"); a trailing
  /// source without destination is ignored.
  void add_from_environment(const char* value);

  /// `name` after every rule, applied in order, each to the result of the
  /// previous one.
  std::string apply(std::string_view name) const;

  bool empty() const { return rules_.empty(); }

 private:
  std::vector<Rule> rules_;
};

}  // namespace ln::clientlib
