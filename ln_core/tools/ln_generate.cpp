// ln_generate: writes the C/C++ header for LN message definitions, with LN
// 2.9's command line (ln_spec.md §3). Only the c++ output format exists.
#include <dirent.h>
#include <limits.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "generate/c_header.hpp"
#include "ln/md/message_definition.hpp"

namespace {

const char* const usage_text = R"(usage: ln_generate [options] [MDNAME ...]

Generates the C/C++ header (structs, MD_NAME, SIGNATURE constants, service
base classes) for LN message definitions.

positional arguments:
  MDNAME                        message definition names, e.g. elevator/sensors/floor_count

options:
  -h, --help                    show this help and exit
  --md-dir DIR, -md_dir DIR     add a message-definition directory (searched first; repeatable)
  --md-dirs-from-env-var VAR    add the ':'-separated directories in environment variable VAR
  --recursive DIR               add DIR and generate every definition file below it
  --mds-from-file FILE          read definition names from FILE (one per line, # comments)
  -o FILE, --output FILE        output file (default: ln_messages.h; '-' for stdout)
  -f, --force                   write even if the output would not change
  --depfile FILE                also write a Make-style depfile naming every definition
                                file (and md.conf) read, for build systems
  --output-format c++           output format (only c++ is supported)
  --map-service-base X=Y        name the C++ base class of definition X "Y_base"
  --wrapping-ns NS              wrap the generated C++ code in namespace NS (repeatable)
  --prefix-ns-define DEFINE     macro that, when defined, names an outer namespace
                                (default: LN_MD_PREFIX_NS)

Definitions are searched in: --md-dir/--recursive dirs, the built-in dirs,
~/ln_message_definitions, $LN_MESSAGE_DEFINITION_DIRS, and dirs listed in md.conf files.
)";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::vector<std::string> names;
  std::vector<std::string> md_dirs;
  std::vector<std::string> recursive_dirs;
  std::vector<std::string> env_vars;
  std::vector<std::string> name_files;
  std::string output = "ln_messages.h";
  std::string depfile;
  bool force = false;
  ln::generate::CHeaderOptions header;
};

Options parse_arguments(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string inline_value;
    bool has_inline_value = false;
    if (arg.rfind("--", 0) == 0) {
      if (const auto eq = arg.find('='); eq != std::string::npos) {
        inline_value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        has_inline_value = true;
      }
    }
    auto value = [&]() -> std::string {
      if (has_inline_value) return inline_value;
      if (i + 1 >= argc) throw UsageError("option " + arg + " needs a value");
      return argv[++i];
    };
    if (arg == "-h" || arg == "--help") {
      std::cout << usage_text;
      std::exit(0);
    } else if (arg == "--md-dir" || arg == "-md_dir") {
      o.md_dirs.push_back(value());
    } else if (arg == "--md-dirs-from-env-var") {
      o.env_vars.push_back(value());
    } else if (arg == "--recursive") {
      o.recursive_dirs.push_back(value());
    } else if (arg == "--mds-from-file") {
      o.name_files.push_back(value());
    } else if (arg == "-o" || arg == "--output") {
      o.output = value();
    } else if (arg == "--depfile") {
      o.depfile = value();
    } else if (arg == "-f" || arg == "--force") {
      o.force = true;
    } else if (arg == "--output-format") {
      const std::string format = value();
      if (format != "c++") throw UsageError("output format '" + format + "' is not supported by ln_core (only c++)");
    } else if (arg == "--map-service-base") {
      const std::string mapping = value();
      const auto eq = mapping.find('=');
      if (eq == std::string::npos || eq == 0 || eq + 1 == mapping.size())
        throw UsageError("--map-service-base expects X=Y, got '" + mapping + "'");
      o.header.service_base_names[mapping.substr(0, eq)] = mapping.substr(eq + 1);
    } else if (arg == "--wrapping-ns") {
      o.header.wrapping_namespaces.push_back(value());
    } else if (arg == "--prefix-ns-define") {
      o.header.prefix_namespace_define = value();
    } else if (arg == "--sfunction-parameter" || arg == "-sfunction_parameter" ||
               arg == "--sfunction-parameter-with-hash" || arg == "--idf" || arg == "-idf" || arg == "--java-package" ||
               arg == "--jna-skip-builtin") {
      throw UsageError("option " + arg + " (Simulink/IDF/Java output) is not supported by ln_core");
    } else if (!arg.empty() && arg[0] == '-' && arg != "-") {
      throw UsageError("unknown option " + arg);
    } else {
      o.names.push_back(arg);
    }
  }
  return o;
}

void collect_files_below(const std::string& base, const std::string& relative, std::vector<std::string>& out) {
  const std::string dir = relative.empty() ? base : base + "/" + relative;
  DIR* d = ::opendir(dir.c_str());
  if (!d) throw std::runtime_error("cannot read directory " + dir + ": " + std::strerror(errno));
  std::vector<std::string> entries;
  while (const dirent* e = ::readdir(d))
    if (e->d_name[0] != '.') entries.emplace_back(e->d_name);
  ::closedir(d);
  std::sort(entries.begin(), entries.end());  // deterministic output
  for (const auto& entry : entries) {
    const std::string rel = relative.empty() ? entry : relative + "/" + entry;
    struct stat st;
    if (::stat((base + "/" + rel).c_str(), &st) != 0) continue;
    if (S_ISDIR(st.st_mode))
      collect_files_below(base, rel, out);
    else if (S_ISREG(st.st_mode) && entry != "md.conf")
      out.push_back(rel);
  }
}

std::vector<std::string> names_from_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path + ": " + std::strerror(errno));
  std::vector<std::string> names;
  std::string line;
  while (std::getline(in, line)) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    names.push_back(line.substr(first, line.find_last_not_of(" \t\r") - first + 1));
  }
  return names;
}

// LN strips any '.' and '/' from both ends of a name ("./a/b" -> "a/b").
std::string clean_name(const std::string& name) {
  const auto first = name.find_first_not_of("./");
  if (first == std::string::npos) return "";
  return name.substr(first, name.find_last_not_of("./") - first + 1);
}

std::string current_directory() {
  char cwd[PATH_MAX];
  return ::getcwd(cwd, sizeof cwd) ? cwd : ".";
}

std::string absolute_output_path(const std::string& output) {
  char resolved[PATH_MAX];
  if (::realpath(output.c_str(), resolved)) return resolved;
  return output.front() == '/' ? output : current_directory() + "/" + output;
}

bool read_whole_file(const std::string& path, std::string& content) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream s;
  s << in.rdbuf();
  content = s.str();
  return true;
}

void make_directories(const std::string& dir) {
  if (dir.empty()) return;
  struct stat st;
  if (::stat(dir.c_str(), &st) == 0) return;
  make_directories(dir.substr(0, dir.rfind('/')));
  if (::mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST)
    throw std::runtime_error("cannot create directory " + dir + ": " + std::strerror(errno));
}

// Readers of the header (make, a parallel compiler) must never see half of
// it: write a temporary file next to it and rename it into place.
void write_atomically(const std::string& path, const std::string& content) {
  make_directories(path.substr(0, path.rfind('/')));
  std::string temp = path + ".tmp.XXXXXX";
  const int fd = ::mkstemp(temp.data());
  if (fd < 0) throw std::runtime_error("cannot create a file next to " + path + ": " + std::strerror(errno));
  std::size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = errno;
      ::close(fd);
      ::unlink(temp.c_str());
      throw std::runtime_error("cannot write " + temp + ": " + std::strerror(error));
    }
    written += static_cast<std::size_t>(n);
  }
  // mkstemp creates 0600; a header is an ordinary file for everyone.
  const mode_t umask_value = ::umask(0);
  ::umask(umask_value);
  ::fchmod(fd, 0666 & ~umask_value);
  if (::close(fd) != 0 || ::rename(temp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(temp.c_str());
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(error));
  }
}

// Every file the header was made from: the requested definitions, all they
// define (recursively), and the md.conf files that shaped the search path.
std::vector<std::string> files_read(const std::vector<const ln::md::Definition*>& requested,
                                    const ln::md::SearchPath& search_path) {
  std::vector<std::string> files;
  std::vector<const ln::md::Definition*> pending = requested;
  std::vector<const ln::md::Definition*> seen;
  while (!pending.empty()) {
    const ln::md::Definition* def = pending.back();
    pending.pop_back();
    if (std::find(seen.begin(), seen.end(), def) != seen.end()) continue;
    seen.push_back(def);
    if (!def->path.empty() && def->path.front() != '<') files.push_back(def->path);  // not put text
    for (const auto& define : def->defines)
      if (define.definition) pending.push_back(define.definition);
  }
  for (const auto& dir : search_path.dirs()) {
    const std::string conf = dir + "/md.conf";
    struct stat st;
    if (::stat(conf.c_str(), &st) == 0 && S_ISREG(st.st_mode)) files.push_back(conf);
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

// Make's syntax: spaces, '#' and '$' escaped; one prerequisite per line.
std::string make_escaped(const std::string& path) {
  std::string out;
  for (const char c : path) {
    if (c == ' ' || c == '#') out += '\\';
    if (c == '$') out += '$';
    out += c;
  }
  return out;
}

std::string depfile_text(const std::string& target, const std::vector<std::string>& prerequisites) {
  std::string text = make_escaped(target) + ":";
  for (const auto& file : prerequisites) text += " \\\n  " + make_escaped(absolute_output_path(file));
  return text + "\n";
}

int run(int argc, char** argv) {
  Options o = parse_arguments(argc, argv);

  std::vector<std::string> explicit_dirs = o.recursive_dirs;
  explicit_dirs.insert(explicit_dirs.end(), o.md_dirs.begin(), o.md_dirs.end());
  for (const auto& var : o.env_vars) {
    const char* list = std::getenv(var.c_str());
    std::stringstream entries(list ? list : "");
    for (std::string dir; std::getline(entries, dir, ':');)
      if (!dir.empty()) explicit_dirs.push_back(dir);
  }

  std::vector<std::string> names = o.names;
  for (const auto& dir : o.recursive_dirs) collect_files_below(dir, "", names);
  for (const auto& file : o.name_files) {
    auto more = names_from_file(file);
    names.insert(names.end(), more.begin(), more.end());
  }
  if (names.empty()) throw UsageError("no message definitions given (see --help)");

  ln::md::Library library(ln::md::SearchPath::standard(explicit_dirs));
  std::vector<const ln::md::Definition*> definitions;
  for (const auto& name : names) definitions.push_back(&library.load(clean_name(name)));

  std::string command_line;
  for (int i = 0; i < argc; ++i) command_line += (i ? " " : "") + std::string(argv[i]);
  o.header.preamble = "/* Generated by ln_generate (ln_core) -- do not edit; regenerate with\n  cd " +
                      current_directory() + "\n  " + command_line + "\n*/\n\n";
  o.header.guard = ln::generate::guard_for_output(o.output == "-" ? "ln_messages.h" : o.output);
  const std::string header = ln::generate::emit_c_header(definitions, o.header);

  if (o.output == "-") {
    if (!o.depfile.empty()) throw UsageError("--depfile needs an output file (-o), not stdout");
    std::cout << header << std::flush;
    return std::cout ? 0 : 1;
  }
  const std::string path = absolute_output_path(o.output);
  std::string existing;
  if (!o.force && read_whole_file(path, existing) && existing == header) {
    std::cout << argv[0] << ": " << path << " is up to date." << std::endl;
  } else {
    write_atomically(path, header);
  }
  if (!o.depfile.empty())
    write_atomically(absolute_output_path(o.depfile),
                     depfile_text(path, files_read(definitions, library.search_path())));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "ln_generate: error: " << e.what() << "\n(see ln_generate --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "ln_generate: error: " << e.what() << "\n";
    return 1;
  }
}
