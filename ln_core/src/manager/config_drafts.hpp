// Between reading and the model (config.hpp): the sections that describe
// objects (process, state, group, template) as the reader collects them,
// evaluated key by key with LN's list modifiers, before they are checked
// and their names resolved (config_objects.cpp). Internal to the reader.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "manager/config.hpp"

namespace ln::manager {

struct TemplateLine {
  std::string key;
  std::string value;  ///< not evaluated: %(parameter) is replaced first
  ConfigPlace place;
};

/// One `add_process_default_template: T` directive.
struct DefaultTemplate {
  std::string prefix;  ///< the name prefix in effect where it was written
  std::string use;     ///< "T(args)", evaluated when applied
  ConfigPlace place;
};

struct Draft {
  std::string type;  ///< "process", "state", "group" or "template"
  std::string name;  ///< full name
  std::string display_name;
  std::vector<std::string> prefixes;
  ConfigPlace place;  ///< the section header

  std::map<std::string, std::string> scalars;
  std::map<std::string, std::vector<std::string>> lists;
  std::map<std::string, ConfigPlace> where;  ///< key -> its last assignment
  std::vector<std::pair<std::string, std::string>> alt_commands;
  /// Keys LN 2.9 knows that ln_core ignores, with where they were set.
  std::map<std::string, ConfigPlace> ignored;

  // templates
  std::vector<std::pair<std::string, std::string>> template_params;  ///< name, default
  std::vector<TemplateLine> body;

  /// `key: value` (lists: comma-separated items replace the list).
  void set(const std::string& key, const std::string& value, const ConfigPlace& at);
  /// `key+: value` (text appended; lists extended).
  void append(const std::string& key, const std::string& value, const ConfigPlace& at);
  /// `add key: item` (KEY=VALUE lists replace the item of that KEY).
  void add_item(const std::string& key, const std::string& value, const ConfigPlace& at);
  /// `del key: item`
  void delete_item(const std::string& key, const std::string& value, const ConfigPlace& at);
  /// `reset key:`
  void reset(const std::string& key, const ConfigPlace& at);
  /// `append|prepend|remove key ITEM: text` on the ITEM=... entry.
  void edit_item(const std::string& operation, const std::string& key, const std::string& item,
                 const std::string& value, const ConfigPlace& at);
  void set_alt_command(const std::string& name, const std::string& command);

  const std::vector<std::string>& list(const std::string& key) const;
  bool has_flag(const std::string& flag) const;

 private:
  enum class Kind { Scalar, List, Accumulating, Ignored };
  Kind kind_of(const std::string& key, const ConfigPlace& at) const;
  std::string list_key(const std::string& key, const std::string& operation, const ConfigPlace& at) const;
};

struct Drafts {
  std::vector<std::unique_ptr<Draft>> all;  ///< in config order
  std::vector<DefaultTemplate> default_templates;
  std::vector<std::string> files;
  bool auto_groups = false;

  void add(std::unique_ptr<Draft> draft) { all.push_back(std::move(draft)); }
  const Draft* find(const std::string& name, const std::string& type) const;
  const Draft* find_any(const std::string& name) const;
};

/// What finishing the model needs from the reader.
struct DraftContext {
  LogFunction log;
  /// Applies `use_template: use` to `draft` (for default templates).
  std::function<void(Draft& draft, const std::string& use, const ConfigPlace& place)> apply_template;
  /// A node name through the node_map.
  std::function<std::string(const std::string& node)> map_node;
};

/// Checks every draft and fills the processes, states and groups of
/// `settings`, with their names resolved. Throws ConfigError.
void complete_model(Drafts& drafts, const DraftContext& context, LncSettings& settings);

}  // namespace ln::manager
