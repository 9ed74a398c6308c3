#include <dlfcn.h>
#include <limits.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>

#include "ln/md/message_definition.hpp"
#include "md/files.hpp"
#include "md/text.hpp"

namespace ln::md {
namespace {

using files::exists;
using files::is_directory;
using files::is_regular_file;

std::string home_directory() {
  const char* home = std::getenv("HOME");
  return home ? home : "";
}

std::string absolute(const std::string& path) {
  if (!path.empty() && path.front() == '/') return path;
  char cwd[PATH_MAX];
  if (!::getcwd(cwd, sizeof cwd)) return path;
  return text::join_path(cwd, path);
}

// Like Python's os.path.realpath: resolves what exists, keeps the rest.
std::string real_path(const std::string& path) {
  char resolved[PATH_MAX];
  if (::realpath(path.c_str(), resolved)) return resolved;
  return absolute(path);
}

std::string expand_user(const std::string& path) {
  if (path == "~") return home_directory();
  if (text::starts_with(path, "~/")) return home_directory() + path.substr(1);
  return path;
}

// An md.conf lists further definition directories, one per line; relative
// entries are relative to the md.conf itself. A listed directory may bring
// its own md.conf, so expand until nothing new appears.
void expand_md_conf(std::vector<std::string>& dirs) {
  for (;;) {
    std::vector<std::string> found;
    for (const auto& dir : dirs) {
      std::string conf;
      if (is_directory(dir))
        conf = dir + "/md.conf";
      else if (is_regular_file(dir))
        conf = dir;
      if (conf.empty() || !is_regular_file(conf)) continue;
      std::ifstream in(conf);
      std::string line;
      while (std::getline(in, line)) {
        const std::string entry(text::strip(line));
        if (entry.empty() || entry.front() == '#') continue;
        std::string candidate = expand_user(entry);
        if (candidate.front() != '/') candidate = text::join_path(text::dirname(conf), candidate);
        candidate = real_path(candidate);
        auto known = [&](const std::vector<std::string>& v) {
          return std::find(v.begin(), v.end(), candidate) != v.end();
        };
        if (exists(candidate) && !known(dirs) && !known(found)) found.push_back(candidate);
      }
    }
    if (found.empty()) return;
    dirs.insert(dirs.end(), found.begin(), found.end());
  }
}

std::vector<std::string> standard_dirs(const std::vector<std::string>& explicit_dirs) {
  std::vector<std::string> dirs = explicit_dirs;
  for (auto& d : SearchPath::builtin_dirs()) dirs.push_back(d);
  const std::string home = home_directory();
  if (!home.empty()) dirs.push_back(home + "/ln_message_definitions");
  if (const char* env = std::getenv("LN_MESSAGE_DEFINITION_DIRS")) {
    std::string_view list = env;
    while (!list.empty()) {
      const auto colon = std::min(list.find(':'), list.size());
      const std::string entry(text::strip(list.substr(0, colon)));
      if (!entry.empty()) dirs.push_back(real_path(entry));
      list.remove_prefix(std::min(colon + 1, list.size()));
    }
  }
  return dirs;
}

// The installation's share directory: next to the binary or library that
// contains this code (<prefix>/lib/.. or <prefix>/bin/..), else the
// configured install prefix.
std::string share_directory() {
  Dl_info info;
  if (::dladdr(reinterpret_cast<void*>(&share_directory), &info) && info.dli_fname) {
    const std::string module = real_path(info.dli_fname);
    const std::string prefix(text::dirname(text::dirname(module)));
    if (is_directory(prefix + "/share/links_and_nodes")) return prefix + "/share";
  }
#ifdef LN_INSTALL_SHARE_DIR
  return LN_INSTALL_SHARE_DIR;
#else
  return "/usr/local/share";
#endif
}

}  // namespace

std::vector<std::string> SearchPath::builtin_dirs() {
  const std::string share = share_directory();
  return {share + "/links_and_nodes/message_definitions", share + "/ln_runtime/message_definitions"};
}

SearchPath SearchPath::standard(std::vector<std::string> explicit_dirs) {
  SearchPath path;
  path.requested_ = std::move(explicit_dirs);
  path.standard_ = true;
  path.rescan();
  return path;
}

SearchPath SearchPath::exactly(std::vector<std::string> dirs) {
  SearchPath path;
  path.requested_ = std::move(dirs);
  path.rescan();
  return path;
}

void SearchPath::rescan() {
  std::vector<std::string> dirs = standard_ ? standard_dirs(requested_) : requested_;
  expand_md_conf(dirs);
  dirs_.clear();
  for (auto& d : dirs)
    if (is_directory(d) && std::find(dirs_.begin(), dirs_.end(), d) == dirs_.end()) dirs_.push_back(d);
}

std::optional<std::string> SearchPath::find(std::string_view name) const {
  for (const auto& dir : dirs_) {
    std::string candidate = text::join_path(dir, name);
    if (is_regular_file(candidate)) return candidate;
  }
  return std::nullopt;
}

}  // namespace ln::md
