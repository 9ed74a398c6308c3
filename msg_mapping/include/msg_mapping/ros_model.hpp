// The ROS 2 side of msg_mapping: an in-memory model of .msg/.srv interface
// definitions, a parser for the rosidl ".msg" syntax (as rosidl_adapter reads
// it), an emitter, and a store that finds installed interface files.
//
// Only what a mapping needs is modelled: fields with their types, array and
// bound information, constants and comments. Actions are not modelled.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace msg_mapping {

/// A problem found while generating or validating a mapping (bad names,
/// collisions, unknown types, bad rules). The message names the definition
/// and the field concerned.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class RosPrimitive : std::uint8_t {
  Bool,
  Byte,
  Char,
  Float32,
  Float64,
  Int8,
  UInt8,
  Int16,
  UInt16,
  Int32,
  UInt32,
  Int64,
  UInt64,
  String,
  WString
};

std::string_view spelling(RosPrimitive type);
std::optional<RosPrimitive> ros_primitive_from_spelling(std::string_view spelling);
/// Bytes on the CDR wire (and CDR alignment) of a non-string primitive.
std::size_t cdr_size(RosPrimitive type);
bool is_string(RosPrimitive type);

struct RosFieldType {
  enum class Array : std::uint8_t { None, Fixed, Bounded, Unbounded };

  std::optional<RosPrimitive> primitive;  ///< unset: a nested message
  std::string nested;                     ///< "pkg/Type" of a nested message
  std::uint32_t string_bound = 0;         ///< string<=N (0: unbounded)
  Array array = Array::None;
  std::uint32_t array_size = 0;  ///< T[N] or T[<=N]

  bool is_nested() const { return !primitive.has_value(); }
  bool is_sequence() const { return array == Array::Bounded || array == Array::Unbounded; }
  /// The element type as written in a .msg file ("float64", "string<=8", "std_msgs/Header").
  std::string element_spelling() const;
  /// The full type as written in a .msg file ("float64[3]", "uint8[<=4]").
  std::string spelling() const;
};

struct RosField {
  std::string name;
  RosFieldType type;
  std::string default_value;          ///< as written, empty when none
  std::vector<std::string> comments;  ///< emitted as "# ..." lines before the field
};

struct RosConstant {
  std::string type;
  std::string name;
  std::string value;
};

struct RosMessage {
  std::string package;
  std::string name;  ///< "Pose"; "Foo_Request" for a service part
  std::vector<RosField> fields;
  std::vector<RosConstant> constants;
  std::vector<std::string> comments;  ///< file-level comment lines

  /// "pkg/msg/Pose" (or "pkg/srv/Foo_Request" for service parts).
  std::string full_name() const;
  bool is_service_part = false;
};

struct RosService {
  std::string package;
  std::string name;
  RosMessage request;
  RosMessage response;
  std::vector<std::string> comments;

  std::string full_name() const { return package + "/srv/" + name; }
};

/// Parses .msg text as rosidl_adapter does (comments start at the first '#',
/// "TYPE NAME", "TYPE NAME DEFAULT", "TYPE NAME=VALUE"). A nested type
/// without a package belongs to `package`. Throws Error naming file and line.
RosMessage parse_msg(std::string_view package, std::string_view name, std::string_view text);
/// Parses .srv text: request fields, a line "---", response fields.
RosService parse_srv(std::string_view package, std::string_view name, std::string_view text);

/// .msg text of a message (comments, constants, fields).
std::string emit_msg(const RosMessage& message);
/// .srv text of a service.
std::string emit_srv(const RosService& service);

/// Splits "pkg/msg/Type", "pkg/srv/Type" or "pkg/Type" into package and type.
/// `kind` receives "msg", "srv" or "" (not given). Throws Error when malformed.
void split_ros_type_name(std::string_view full, std::string& package, std::string& kind, std::string& type);

/// Finds installed interface files: <share dir>/<pkg>/msg/<Type>.msg and
/// <share dir>/<pkg>/srv/<Type>.srv, first share dir wins. Parsed files are kept.
class RosTypeStore {
 public:
  explicit RosTypeStore(std::vector<std::string> share_dirs);

  /// The message "pkg/msg/Type" (or "pkg/Type"). Throws Error when unknown.
  const RosMessage& message(std::string_view full_name);
  /// The service "pkg/srv/Type". Throws Error when unknown.
  const RosService& service(std::string_view full_name);
  bool has_message(std::string_view full_name);
  /// Every message/service type of an installed package, sorted ("pkg/msg/A", ...).
  std::vector<std::string> package_types(std::string_view package, std::string_view kind);

  /// Registers a message that does not come from a file (tests, generated types).
  void add(RosMessage message);

  const std::vector<std::string>& share_dirs() const { return share_dirs_; }

 private:
  std::optional<std::string> find_file(const std::string& package, const std::string& kind,
                                       const std::string& type) const;
  std::vector<std::string> share_dirs_;
  std::map<std::string, std::unique_ptr<RosMessage>, std::less<>> messages_;
  std::map<std::string, std::unique_ptr<RosService>, std::less<>> services_;
};

}  // namespace msg_mapping
