// The manager's view of message definitions: resolves names (optionally
// pinned by "|hash") on the search path, hands out definition bundles and
// stores definitions that clients put at run time.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ln/md/message_definition.hpp"

namespace ln::manager {

/// A definition with everything it imports, as the protocol sends it: the
/// first name/text pair is the definition itself.
struct DefinitionBundle {
  std::string name;
  std::string hash;
  std::int64_t message_size = 0;
  std::vector<std::string> names;
  std::vector<std::string> texts;
};

/// The first field (as "outer.inner") that makes packets of `definition`
/// variable-sized, looking into sub-types held by value.
std::optional<std::string> first_dynamic_field(const md::Definition& definition);

class DefinitionStore {
 public:
  /// Search order: `configured_dirs`, then `generated_dir` (where put
  /// definitions go), then md::SearchPath::standard's directories.
  DefinitionStore(std::vector<std::string> configured_dirs, std::string generated_dir);
  ~DefinitionStore();

  /// "name" or "name|hash". Throws RequestError (invalid name, not found,
  /// parse error, LNE_WRONG_MD_HASH). The reference stays valid until the
  /// next put().
  const md::Definition& resolve(std::string_view name_with_hash);
  /// Throws RequestError when a file cannot be read.
  DefinitionBundle bundle(const md::Definition& definition) const;

  struct Stored {
    std::string name;
    std::string hash;
  };
  /// Validates `text` by parsing it and stores it as `name` in the generated
  /// directory. Storing the same content again is a no-op; replacing a stored
  /// definition is refused while `in_use(name)` says a topic uses it, and
  /// a definition found outside the generated directory is never shadowed.
  Stored put(std::string_view name, std::string_view text, const std::function<bool(const std::string&)>& in_use);

  std::vector<std::string> search_dirs() const;
  const std::string& generated_dir() const { return generated_dir_; }

 private:
  md::SearchPath make_search_path() const;
  /// Starts over with a fresh library, so replaced files are read again.
  void reload();

  std::vector<std::string> configured_dirs_;
  std::string generated_dir_;
  std::unique_ptr<md::Library> library_;
};

}  // namespace ln::manager
