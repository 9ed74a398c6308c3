// The manager's view of message definitions: resolves names (optionally
// pinned by "|hash") on the search path, hands out definition bundles and
// stores definitions that clients put at run time.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "manager/manager.hpp"

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
  /// definitions go), then md::SearchPath::standard's directories. `limits`
  /// (the max_stored_definition* quota) must outlive the store.
  DefinitionStore(std::vector<std::string> configured_dirs, std::string generated_dir, const ManagerLimits& limits);
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
  /// directory. Storing the same content again is a no-op (answered from a
  /// cache, without parsing, while the files involved are unchanged);
  /// replacing a stored definition is refused while `in_use(name)` says a
  /// topic uses it, and a definition found outside the generated directory
  /// is never shadowed. A write that would exceed the directory's quota
  /// (max_stored_definitions, max_stored_definition_bytes) is refused with a
  /// message naming the limit; so is a text that needs parsing when
  /// `client_parses` (the putting client's count of them, counted here)
  /// reached max_definitions_per_client.
  Stored put(std::string_view name, std::string_view text, const std::function<bool(const std::string&)>& in_use,
             std::size_t& client_parses);

  std::vector<std::string> search_dirs() const;
  const std::string& generated_dir() const { return generated_dir_; }

 private:
  md::SearchPath make_search_path() const;
  /// Starts over with a fresh library, so replaced files are read again.
  void reload();

  /// Counts the files and bytes in the generated directory.
  void count_stored();
  /// Throws unless writing `bytes` as `path` keeps the directory within its quota.
  void check_quota(const std::string& path, std::size_t bytes) const;
  std::optional<Stored> cached_put(const std::string& name, const std::string& digest) const;
  void remember_put(const std::string& name, const std::string& digest, const md::Definition& stored);

  std::vector<std::string> configured_dirs_;
  std::string generated_dir_;
  const ManagerLimits& limits_;
  std::unique_ptr<md::Library> library_;
  std::size_t stored_files_ = 0;
  std::uint64_t stored_bytes_ = 0;
  // put_message_definition answers by name: the text's digest, the hash it
  // had, and the files it was read from (itself and its imports) as they were.
  struct FileStamp {
    std::string path;
    std::uint64_t inode = 0, size = 0;
    std::int64_t modified_ns = 0;
    bool operator==(const FileStamp& other) const {
      return path == other.path && inode == other.inode && size == other.size && modified_ns == other.modified_ns;
    }
  };
  struct CachedPut {
    std::string digest;
    std::string hash;
    std::vector<FileStamp> files;
  };
  std::map<std::string, CachedPut> put_cache_;
};

}  // namespace ln::manager
