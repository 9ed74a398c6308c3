#include "manager/definitions.hpp"

#include <fcntl.h>
#include <ftw.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

#include "manager/limits.hpp"
#include "manager/names.hpp"
#include "manager/request_error.hpp"
#include "md/sha256.hpp"

namespace ln::manager {
namespace {

constexpr std::size_t max_definition_text_size = 1024 * 1024;

std::optional<std::string> first_dynamic_field_in(const md::Definition& definition,
                                                  std::set<const md::Definition*>& visiting) {
  if (!visiting.insert(&definition).second) return std::nullopt;
  for (const auto* fields : {&definition.fields, &definition.response_fields}) {
    for (const md::Field& field : *fields) {
      if (field.dynamic) return field.name;
      if (field.sub)
        if (auto inner = first_dynamic_field_in(*field.sub, visiting)) return field.name + "." + *inner;
    }
  }
  return std::nullopt;
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw RequestError(LNE_REQUEST_FAILED, "cannot read '" + path + "': " + std::strerror(errno));
  std::ostringstream content;
  content << in.rdbuf();
  if (content.str().size() > max_definition_text_size)
    throw RequestError(LNE_REQUEST_FAILED, "message-definition file '" + path + "' is larger than 1 MiB");
  return content.str();
}

// mkdir -p for the directory part of `path` below an existing or creatable `root`.
void make_directories(const std::string& path) {
  for (std::size_t slash = path.find('/', 1); slash != std::string::npos; slash = path.find('/', slash + 1)) {
    const std::string dir = path.substr(0, slash);
    if (::mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST)
      throw RequestError(LNE_REQUEST_FAILED, "cannot create directory '" + dir + "': " + std::strerror(errno));
  }
}

// Writes via a temporary file and rename(), so readers never see half a file.
void write_file_atomically(const std::string& path, std::string_view content) {
  make_directories(path);
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw RequestError(LNE_REQUEST_FAILED, "cannot write '" + temporary + "': " + std::strerror(errno));
  std::size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string reason = std::strerror(errno);
      ::close(fd);
      ::unlink(temporary.c_str());
      throw RequestError(LNE_REQUEST_FAILED, "cannot write '" + temporary + "': " + reason);
    }
    written += static_cast<std::size_t>(n);
  }
  ::close(fd);
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temporary.c_str());
    throw RequestError(LNE_REQUEST_FAILED, "cannot store '" + path + "': " + reason);
  }
}

std::optional<struct stat> stat_of(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  return st;
}

// A stored definition is a regular file that is not a temporary one of write_file_atomically().
bool is_stored_definition(const char* path, const struct stat& st) {
  return S_ISREG(st.st_mode) && std::string(path).find(".tmp.") == std::string::npos;
}

// nftw() takes a plain function: the counts of the walk in progress (the
// manager's loop is its only caller).
thread_local std::size_t walk_files = 0;
thread_local std::uint64_t walk_bytes = 0;

int count_one(const char* path, const struct stat* st, int, FTW*) {
  if (is_stored_definition(path, *st)) {
    ++walk_files;
    walk_bytes += static_cast<std::uint64_t>(st->st_size);
  }
  return 0;
}

}  // namespace

std::optional<std::string> first_dynamic_field(const md::Definition& definition) {
  std::set<const md::Definition*> visiting;
  return first_dynamic_field_in(definition, visiting);
}

DefinitionStore::DefinitionStore(std::vector<std::string> configured_dirs, std::string generated_dir,
                                 const ManagerLimits& limits)
    : configured_dirs_(std::move(configured_dirs)), generated_dir_(std::move(generated_dir)), limits_(limits) {
  while (generated_dir_.size() > 1 && generated_dir_.back() == '/') generated_dir_.pop_back();
  if (!generated_dir_.empty() && generated_dir_.front() != '/') {
    char cwd[4096];
    if (::getcwd(cwd, sizeof cwd)) generated_dir_ = std::string(cwd) + "/" + generated_dir_;
  }
  reload();
  count_stored();
}

DefinitionStore::~DefinitionStore() = default;

void DefinitionStore::count_stored() {
  walk_files = 0;
  walk_bytes = 0;
  ::nftw(generated_dir_.c_str(), count_one, 16, FTW_PHYS);
  stored_files_ = walk_files;
  stored_bytes_ = walk_bytes;
}

void DefinitionStore::check_quota(const std::string& path, std::size_t bytes) const {
  const auto existing = stat_of(path);
  const bool replaces = existing && is_stored_definition(path.c_str(), *existing);
  const std::size_t files = stored_files_ + (replaces ? 0 : 1);
  const std::uint64_t total = stored_bytes_ - (replaces ? static_cast<std::uint64_t>(existing->st_size) : 0) + bytes;
  if (files > limits_.max_stored_definitions)
    throw RequestError(LNE_REQUEST_FAILED, "'" + generated_dir_ + "' holds " + std::to_string(stored_files_) +
                                               " stored definitions, as many as the manager allows "
                                               "(max_stored_definitions); remove some or raise the limit");
  if (total > limits_.max_stored_definition_bytes)
    throw RequestError(LNE_REQUEST_FAILED, "'" + generated_dir_ + "' holds " + byte_text(stored_bytes_) +
                                               " of stored definitions; this one would exceed the " +
                                               byte_text(limits_.max_stored_definition_bytes) +
                                               " the manager allows (max_stored_definition_bytes)");
}

std::optional<DefinitionStore::Stored> DefinitionStore::cached_put(const std::string& name,
                                                                   const std::string& digest) const {
  const auto it = put_cache_.find(name);
  if (it == put_cache_.end() || it->second.digest != digest) return std::nullopt;
  // Still the file the name resolves to, and nothing it was read from changed.
  const auto found = library_->search_path().find(name);
  if (!found || *found != it->second.files.front().path) return std::nullopt;
  for (const FileStamp& known : it->second.files) {
    const auto st = stat_of(known.path);
    if (!st) return std::nullopt;
    const FileStamp now{known.path, static_cast<std::uint64_t>(st->st_ino), static_cast<std::uint64_t>(st->st_size),
                        static_cast<std::int64_t>(st->st_mtim.tv_sec) * 1000000000 + st->st_mtim.tv_nsec};
    if (!(now == known)) return std::nullopt;
  }
  return Stored{name, it->second.hash};
}

void DefinitionStore::remember_put(const std::string& name, const std::string& digest, const md::Definition& stored) {
  CachedPut entry{digest, stored.hash, {}};
  std::vector<const md::Definition*> pending{&stored};
  std::set<const md::Definition*> seen{&stored};
  while (!pending.empty()) {
    const md::Definition* current = pending.back();
    pending.pop_back();
    const auto st = stat_of(current->path);
    if (!st) return;  // not from a file: nothing to check later, so nothing to remember
    entry.files.push_back({current->path, static_cast<std::uint64_t>(st->st_ino),
                           static_cast<std::uint64_t>(st->st_size),
                           static_cast<std::int64_t>(st->st_mtim.tv_sec) * 1000000000 + st->st_mtim.tv_nsec});
    for (const md::Define& define : current->defines)
      if (define.definition && seen.insert(define.definition).second) pending.push_back(define.definition);
  }
  // Bounded like the directory it describes.
  if (put_cache_.size() >= limits_.max_stored_definitions && !put_cache_.count(name))
    put_cache_.erase(put_cache_.begin());
  put_cache_[name] = std::move(entry);
}

md::SearchPath DefinitionStore::make_search_path() const {
  std::vector<std::string> dirs = configured_dirs_;
  dirs.push_back(generated_dir_);
  return md::SearchPath::standard(std::move(dirs));
}

void DefinitionStore::reload() { library_ = std::make_unique<md::Library>(make_search_path()); }

std::vector<std::string> DefinitionStore::search_dirs() const { return library_->search_path().dirs(); }

const md::Definition& DefinitionStore::resolve(std::string_view name_with_hash) {
  const auto [name, expected_hash] = split_name_and_hash(name_with_hash);
  if (auto problem = definition_name_problem(name)) throw RequestError(LNE_INVALID_PARAMETER, *problem);
  const md::Definition* definition = nullptr;
  try {
    definition = &library_->load(name);
  } catch (const md::Error& e) {
    throw RequestError(LNE_REQUEST_FAILED, e.what());
  }
  if (!expected_hash.empty() && expected_hash != definition->hash)
    throw RequestError(LNE_WRONG_MD_HASH, "message definition '" + name + "' has hash " + definition->hash +
                                              " here, but the client expects " + expected_hash +
                                              " (it was built with another version of the definition)");
  return *definition;
}

DefinitionBundle DefinitionStore::bundle(const md::Definition& definition) const {
  DefinitionBundle out;
  out.name = definition.name;
  out.hash = definition.hash;
  out.message_size = static_cast<std::int64_t>(md::packet_size(definition));
  // Depth first from the definition itself, each import once: the client
  // can then rebuild the same model from these texts.
  std::vector<const md::Definition*> pending{&definition};
  std::set<const md::Definition*> seen{&definition};
  while (!pending.empty()) {
    const md::Definition* current = pending.front();
    pending.erase(pending.begin());
    out.names.push_back(current->name);
    out.texts.push_back(read_text_file(current->path));
    for (const md::Define& define : current->defines)
      if (define.definition && seen.insert(define.definition).second) pending.push_back(define.definition);
  }
  return out;
}

DefinitionStore::Stored DefinitionStore::put(std::string_view name, std::string_view text,
                                             const std::function<bool(const std::string&)>& in_use,
                                             std::size_t& client_parses) {
  const std::string wanted(name);
  if (auto problem = definition_name_problem(wanted)) throw RequestError(LNE_INVALID_PARAMETER, *problem);
  if (text.size() > max_definition_text_size)
    throw RequestError(LNE_INVALID_PARAMETER, "message definition '" + wanted + "' is larger than 1 MiB");
  const std::string digest = md::sha256_hex(text);
  if (auto known = cached_put(wanted, digest)) return *known;
  // Parsing a large text takes a while of the manager's only thread (about
  // 0.1 s for 1 MiB), and so does a text that fails late: each client has
  // its count of them.
  if (client_parses >= limits_.max_definitions_per_client)
    throw RequestError(LNE_REQUEST_FAILED, "this client has put " + std::to_string(client_parses) +
                                               " new message definitions, as many as the manager allows per client "
                                               "(max_definitions_per_client)");
  ++client_parses;

  reload();  // look at the directories as they are now, not as they were

  // Parse in a scratch library first: a bad text never reaches the disk.
  std::string new_hash;
  try {
    md::Library scratch(library_->search_path());
    new_hash = scratch.load_text(wanted, text).hash;
  } catch (const md::Error& e) {
    throw RequestError(LNE_INVALID_PARAMETER, "invalid message definition '" + wanted + "': " + e.what());
  }

  if (const auto existing_path = library_->search_path().find(wanted)) {
    const bool generated = existing_path->rfind(generated_dir_ + "/", 0) == 0;
    std::string existing_hash;
    try {
      existing_hash = library_->load(wanted).hash;
    } catch (const md::Error& e) {
      // A broken stored file may be replaced; anything else stays untouched.
      if (!generated) throw RequestError(LNE_REQUEST_FAILED, e.what());
    }
    if (existing_hash == new_hash) {
      if (generated) remember_put(wanted, digest, library_->load(wanted));
      return {wanted, new_hash};
    }
    if (!generated)
      throw RequestError(LNE_REQUEST_FAILED, "message definition '" + wanted + "' already exists as '" +
                                                 *existing_path +
                                                 "' with different content; put yours under another name");
    if (in_use(wanted))
      throw RequestError(LNE_REQUEST_FAILED, "message definition '" + wanted +
                                                 "' is in use by a topic with different content; it cannot be "
                                                 "replaced until that topic is gone");
  }
  const std::string path = generated_dir_ + "/" + wanted;
  check_quota(path, text.size());
  write_file_atomically(path, text);
  count_stored();
  reload();
  const md::Definition& stored = resolve(wanted);
  if (stored.hash != new_hash)
    throw RequestError(LNE_REQUEST_FAILED, "message definition '" + wanted +
                                               "' was stored, but the name resolves to '" + stored.path +
                                               "' with different content");
  remember_put(wanted, digest, stored);
  return {stored.name, stored.hash};
}

}  // namespace ln::manager
