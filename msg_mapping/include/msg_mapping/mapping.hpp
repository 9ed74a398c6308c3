// The pairing of an LN definition with a ROS 2 type, field by field.
//
// Both generator directions produce these (LN -> ROS from the ln_core
// message-definition model, ROS -> LN from parsed .msg/.srv files), the
// emitters write .msg/.srv or LN definition text from them, the mapping file
// records them, and the codec compiles its conversion program from them. So a
// type's two textual forms and its codec can never disagree.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/ros_model.hpp"

namespace msg_mapping {

/// How a field's elements are laid out on the two sides.
enum class Shape : std::uint8_t {
  Single,          ///< one element on both sides
  FixedArray,      ///< LN `T x[N]`                  <-> ROS `T[N] x`
  Sequence,        ///< LN `T* x` (dynamic)          <-> ROS `T[] x` / `T[<=B] x`
  InlineSequence,  ///< LN `uint32_t x_len; T x[cap]` <-> ROS `T[] x` / `T[<=B] x` (LN topics are fixed-size)
  Opaque,          ///< LN `T* x` of a recursive type <-> ROS `uint8[] x` holding x's LN flat bytes
};

enum class ElementKind : std::uint8_t {
  Primitive,  ///< same-size numbers; ROS bool <-> LN uint8_t
  String,     ///< ROS string <-> LN `char* x` or `uint32_t x_len; char x[cap]`
  Struct,     ///< a nested message <-> an LN sub-type (define)
};

struct PairedType;

struct PairedField {
  std::string ln_name;
  /// The LN field that holds the element count ("x_len"): the companion of a
  /// dynamic field (gone on the ROS side, where the sequence carries its
  /// length) or the length of an inline string/sequence. Empty when none.
  std::string ln_length_name;
  std::string ros_name;
  /// Why the ROS name differs from the LN name, or how the field is carried.
  std::string note;

  Shape shape = Shape::Single;
  std::uint32_t count = 1;      ///< FixedArray: N; InlineSequence: LN capacity
  std::uint32_t ros_bound = 0;  ///< ROS `T[<=B]` of a (inline) sequence, 0: unbounded

  ElementKind element = ElementKind::Primitive;
  ln::md::Primitive ln_primitive = ln::md::Primitive::UInt8;
  RosPrimitive ros_primitive = RosPrimitive::UInt8;
  /// String elements: LN keeps `uint32_t len; char data[cap]` (0: `char*`, dynamic).
  std::uint32_t string_capacity = 0;
  std::uint32_t ros_string_bound = 0;  ///< ROS `string<=N`, 0: unbounded
  const PairedType* struct_type = nullptr;

  /// The field's ROS type as a .msg would spell it.
  RosFieldType ros_type() const;
  /// The field's LN form, for comments and the mapping file ("double[3]", "char*").
  std::string ln_spelling() const;
};

struct PairedType {
  std::string ln_name;  ///< the LN definition (a plain definition or "svc#request")
  std::string ln_hash;
  std::string ros_name;  ///< "pkg/msg/Type", "pkg/srv/Svc_Request", ...
  std::vector<PairedField> fields;
  /// rosidl gives a message without fields the member `uint8
  /// structure_needs_at_least_one_member`: one zero byte on the wire that has
  /// no LN counterpart.
  bool ros_dummy_member = false;

  std::string ros_package() const;
  std::string ros_type_name() const;  ///< "Type" (last component)
};

enum class InterfaceKind : std::uint8_t { Message, Service, Event };

/// A top-level mapping: a message, a service (request + response) or an LN
/// event (connect + call data, mapped to two ROS messages).
struct PairedInterface {
  InterfaceKind kind = InterfaceKind::Message;
  std::string ln_name;
  std::string ln_hash;
  std::string ros_name;                ///< "pkg/msg/T" or "pkg/srv/T"; events: the connect message
  const PairedType* first = nullptr;   ///< message, request or connect
  const PairedType* second = nullptr;  ///< response or call (services and events only)
};

/// Which ROS primitive an LN primitive maps to (LN char -> uint8, see README).
RosPrimitive ros_primitive_for(ln::md::Primitive primitive);
/// Which LN primitive a ROS primitive maps to (bool, byte, char -> uint8_t).
ln::md::Primitive ln_primitive_for(RosPrimitive primitive);

}  // namespace msg_mapping
