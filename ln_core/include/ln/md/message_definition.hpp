// The LN message-definition model: one parser, one in-memory model and the
// layout rules (sizes, offsets, signature, hash) that every consumer shares —
// ln_generate, the manager, the client library, the Python binding and
// msg_mapping.
//
// A message definition is a text file found by its slash-separated name on a
// search path (see SearchPath). The language (ln_spec.md §2):
//
//   [service | event]            first significant line selects the kind
//   request | response           service sections (fields before a marker: request)
//   connect | call               event sections
//   define LOCAL as "other/md"   import another definition as a local type name
//   TYPE NAME                    scalar
//   TYPE NAME[COUNT]             fixed array; COUNT is an integer expression (6*6)
//   TYPE* NAME                   dynamic field; its element count lives in NAME_len
//   # comment                    anywhere after '#'
//
// Results agree with LN 2.9 bit for bit: struct layouts, signature strings
// and SHA-256 definition hashes (checked by a differential test against LN
// 2.9's own ln_generate).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace ln::md {

/// A problem in a message definition (or in finding one). `file()` and
/// `line()` locate it when known (line 0: the file as a whole).
class Error : public std::runtime_error {
 public:
  Error(std::string file, int line, const std::string& message);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  /// The message without the "file:line: " prefix that what() carries.
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  int line_;
  std::string message_;
};

enum class Primitive : std::uint8_t { Float, Double, Char, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64 };

/// Canonical C spelling (`int32_t` for the alias `int`), as generated code
/// and signatures use it.
std::string_view c_name(Primitive type);
/// Size in bytes (LN transfers host byte order, no padding).
std::size_t size_of(Primitive type);
bool is_integer(Primitive type);
bool is_signed(Primitive type);
bool is_floating_point(Primitive type);
/// Parses a canonical name or an alias (float32_t, float64_t, short, int).
std::optional<Primitive> primitive_from_spelling(std::string_view spelling);

enum class Kind { Plain, Service, Event };

class Definition;

struct Field {
  std::string name;
  /// The type as written (aliases kept, without '*'): part of the hash.
  std::string type_spelling;
  /// Exactly one of `primitive` and `sub` is set.
  std::optional<Primitive> primitive;
  const Definition* sub = nullptr;
  /// `TYPE* name`: the element count travels in the companion `name_len`.
  bool dynamic = false;
  /// Fixed array length (1 for scalars and dynamic fields).
  std::uint32_t count = 1;
  /// Source line, 0 for a `_len` companion that LN inserts implicitly.
  int line = 0;
  /// The name exactly as LN 2.9 keeps it for hashing: `frame [16]` hashes
  /// "frame " with its trailing blank.
  std::string hash_name;

  bool is_sub_type() const { return sub != nullptr; }
  /// `name_len` for dynamic fields.
  std::string length_field_name() const { return name + "_len"; }
};

struct Define {
  std::string local_name;
  /// The definition's name as generated code names it: relative to the
  /// defining file's directory when found there, else as quoted.
  std::string absolute_name;
  const Definition* definition = nullptr;
  int line = 0;
};

class Definition {
 public:
  std::string name;  ///< e.g. "elevator/request/elevator_call"
  std::string path;  ///< the file it was read from ("<text>" for put text)
  Kind kind = Kind::Plain;
  std::vector<Define> defines;
  /// Indices into `defines` in the order the text lists them, a repeated
  /// define (same local name, same definition) again where it repeats:
  /// LN 2.9's hash depends on that order.
  std::vector<std::size_t> define_order;
  /// Plain fields, a service's request, or an event's connect data.
  std::vector<Field> fields;
  /// A service's response, or an event's call data; empty for plain.
  std::vector<Field> response_fields;
  /// SHA-256 (hex) over fields, response fields and all imported sub-types,
  /// computed as LN 2.9 does; see hash.cpp.
  std::string hash;

  bool is_service() const { return kind == Kind::Service; }
  bool is_event() const { return kind == Kind::Event; }
  /// True when any field (of any section) is dynamic.
  bool is_dynamic() const;
  /// "name|hash", the form LN passes to the manager to pin a definition.
  std::string name_with_hash() const { return name + "|" + hash; }
  /// The define that introduced `local_name`, or nullptr.
  const Define* find_define(std::string_view local_name) const;
};

// ---------------------------------------------------------------- layout

/// Bytes of one packet on a topic (LN's message size): the non-dynamic
/// fields only, sub-types expanded.
std::size_t packet_size(const Definition& definition);

/// The packed host struct that ln_generate emits for a field list: a dynamic
/// field is a pointer (`pointer_size` bytes; its count is the separate
/// `_len` field), a sub-type field is the sub-type's own host struct.
struct StructLayout {
  std::size_t size = 0;
  std::vector<std::size_t> offsets;  ///< one per field, in field order
};
StructLayout struct_layout(const std::vector<Field>& fields, std::size_t pointer_size = sizeof(void*));

/// Where `member` ("pose.position[2]") lies inside a packet of `definition`:
/// byte offset and size of the addressed element (LN's
/// locate_member_in_message_definition). Throws Error if it does not exist.
struct MemberLocation {
  std::size_t offset = 0;
  std::size_t size = 0;
};
MemberLocation locate_member(const Definition& definition, std::string_view member);

// ------------------------------------------------------------- signature

/// The signature of one field list: comma-joined "<type><*> <size> <count>".
std::string fields_signature(const Definition& owner, const std::vector<Field>& fields);
/// A plain definition's field signature; "request|response" for a service,
/// "connect|call" for an event (the generated header prefixes each event
/// half with "name: " itself).
std::string signature(const Definition& definition);

// ------------------------------------------------- LN 2.9's Python notation

/// The definition as LN 2.9's manager hands it to Python clients and writes
/// it into logger data and recorder (pcap) files: the Python repr() of
/// {'fields': [[type, name, count], ...], 'resp_fields': [...],
///  'defines': {local name: fields, ...}} (defines depth first, in define
/// order, a nested one of the same local name replacing the outer's fields).
std::string python_dict_text(const Definition& definition);

// ------------------------------------------------------------ search path

/// The ordered list of directories where definition names are looked up;
/// the first directory that has the file wins.
class SearchPath {
 public:
  /// LN's standard order: `explicit_dirs` (--md-dir, config), the built-in
  /// directories, ~/ln_message_definitions, $LN_MESSAGE_DEFINITION_DIRS,
  /// then directories listed by md.conf files found in any of those,
  /// repeatedly; directories that do not exist are dropped.
  static SearchPath standard(std::vector<std::string> explicit_dirs = {});
  /// Exactly these directories (md.conf files still expand them).
  static SearchPath exactly(std::vector<std::string> dirs);

  const std::vector<std::string>& dirs() const { return dirs_; }
  /// Path of the file for `name`, if any directory has it.
  std::optional<std::string> find(std::string_view name) const;
  /// Re-reads the directories (an md.conf may have changed).
  void rescan();

  /// Built-in definition directories of this installation.
  static std::vector<std::string> builtin_dirs();

 private:
  std::vector<std::string> requested_;
  bool standard_ = false;
  std::vector<std::string> dirs_;
};

// --------------------------------------------------------------- library

/// Loads definitions by name, with everything they import, and keeps them.
/// Definitions are immutable once loaded; references stay valid for the
/// lifetime of the Library.
class Library {
 public:
  explicit Library(SearchPath search_path);
  ~Library();
  Library(const Library&) = delete;
  Library& operator=(const Library&) = delete;

  /// The definition `name` (leading/trailing "./" as on LN's command line
  /// are not stripped here). Throws Error naming the file and line of any
  /// problem, or listing the searched directories when not found.
  const Definition& load(std::string_view name);
  /// Parses `text` as definition `name`; its defines resolve through the
  /// search path. Throws Error.
  const Definition& load_text(std::string_view name, std::string_view text);

  /// Makes `text` the content of definition `name` without touching the
  /// file system: load() and defines find it before any file. This is how a client rebuilds the manager's
  /// definitions from the bundle of texts it receives. Replacing the text
  /// of an already loaded name throws Error.
  void add_source(std::string_view name, std::string_view text);

  const SearchPath& search_path() const { return search_path_; }

 private:
  struct Loader;
  SearchPath search_path_;
  std::map<std::string, std::unique_ptr<Definition>, std::less<>> loaded_;
  std::map<std::string, std::string, std::less<>> sources_;
};

/// True for names that are usable definition names: non-empty,
/// '/'-separated, no "..", no leading '/', no empty component.
bool is_valid_definition_name(std::string_view name);

/// The C identifier LN derives from a definition name: runs of ' ', '/',
/// '.' become '_', outer '_' stripped ("a/b/c" -> "a_b_c").
std::string identifier_from_name(std::string_view name);

/// A C++ keyword or alternative token, or a C keyword (`restrict`, `_Bool`, ...): a name that
/// generated C/C++ code cannot use, so no field or type of a definition may have it.
bool is_reserved_word(std::string_view name);

}  // namespace ln::md
