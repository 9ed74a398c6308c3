#include "client/name_mapping.hpp"

namespace ln::clientlib {
namespace {

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

std::string apply_rule(const NameMapping::Rule& rule, std::string name) {
  std::string_view pattern = rule.source;
  const bool anchored_start = starts_with(pattern, "^");
  if (anchored_start) pattern.remove_prefix(1);
  const bool anchored_end = ends_with(pattern, "$");
  if (anchored_end) pattern.remove_suffix(1);

  if (anchored_start && anchored_end) return name == pattern ? rule.destination : name;
  if (anchored_start) {
    if (starts_with(name, pattern)) name.replace(0, pattern.size(), rule.destination);
    return name;
  }
  if (anchored_end) {
    if (ends_with(name, pattern)) name.replace(name.size() - pattern.size(), pattern.size(), rule.destination);
    return name;
  }
  if (pattern.empty()) return name;  // an empty pattern would match everywhere; it means nothing
  if (const auto at = name.find(pattern); at != std::string::npos) name.replace(at, pattern.size(), rule.destination);
  return name;
}

}  // namespace

void NameMapping::add_all(const std::vector<Rule>& rules) {
  for (const Rule& rule : rules) add(rule);
}

void NameMapping::add_from_environment(const char* value) {
  if (value == nullptr) return;
  std::vector<std::string> parts;
  std::string_view rest(value);
  for (;;) {
    const auto bar = rest.find('|');
    parts.emplace_back(rest.substr(0, bar));
    if (bar == std::string_view::npos) break;
    rest.remove_prefix(bar + 1);
  }
  for (std::size_t i = 0; i + 1 < parts.size(); i += 2) {
    if (!parts[i].empty()) add({parts[i], parts[i + 1]});
  }
}

std::string NameMapping::apply(std::string_view name) const {
  std::string mapped(name);
  for (const Rule& rule : rules_) mapped = apply_rule(rule, std::move(mapped));
  return mapped;
}

}  // namespace ln::clientlib
