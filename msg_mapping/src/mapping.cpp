#include "msg_mapping/mapping.hpp"

namespace msg_mapping {

using ln::md::Primitive;

RosPrimitive ros_primitive_for(Primitive primitive) {
  switch (primitive) {
    case Primitive::Float:
      return RosPrimitive::Float32;
    case Primitive::Double:
      return RosPrimitive::Float64;
    // LN char is C char: bytes of text or small numbers. uint8 carries them
    // exactly (rosidl's own `char` is uint8 on the wire too); LN char* (text)
    // maps to string instead.
    case Primitive::Char:
      return RosPrimitive::UInt8;
    case Primitive::Int8:
      return RosPrimitive::Int8;
    case Primitive::UInt8:
      return RosPrimitive::UInt8;
    case Primitive::Int16:
      return RosPrimitive::Int16;
    case Primitive::UInt16:
      return RosPrimitive::UInt16;
    case Primitive::Int32:
      return RosPrimitive::Int32;
    case Primitive::UInt32:
      return RosPrimitive::UInt32;
    case Primitive::Int64:
      return RosPrimitive::Int64;
    case Primitive::UInt64:
      return RosPrimitive::UInt64;
  }
  return RosPrimitive::UInt8;
}

Primitive ln_primitive_for(RosPrimitive primitive) {
  switch (primitive) {
    case RosPrimitive::Bool:
    case RosPrimitive::Byte:
    case RosPrimitive::Char:
    case RosPrimitive::UInt8:
      return Primitive::UInt8;
    case RosPrimitive::Float32:
      return Primitive::Float;
    case RosPrimitive::Float64:
      return Primitive::Double;
    case RosPrimitive::Int8:
      return Primitive::Int8;
    case RosPrimitive::Int16:
      return Primitive::Int16;
    case RosPrimitive::UInt16:
      return Primitive::UInt16;
    case RosPrimitive::Int32:
      return Primitive::Int32;
    case RosPrimitive::UInt32:
      return Primitive::UInt32;
    case RosPrimitive::Int64:
      return Primitive::Int64;
    case RosPrimitive::UInt64:
      return Primitive::UInt64;
    case RosPrimitive::String:
    case RosPrimitive::WString:
      break;
  }
  return Primitive::Char;
}

RosFieldType PairedField::ros_type() const {
  RosFieldType type;
  if (shape == Shape::Opaque) {
    type.primitive = RosPrimitive::UInt8;
    type.array = RosFieldType::Array::Unbounded;
    return type;
  }
  switch (element) {
    case ElementKind::Primitive:
      type.primitive = ros_primitive;
      break;
    case ElementKind::String:
      type.primitive = RosPrimitive::String;
      type.string_bound = ros_string_bound;
      break;
    case ElementKind::Struct:
      type.nested = struct_type->ros_package() + "/" + struct_type->ros_type_name();
      break;
  }
  switch (shape) {
    case Shape::Single:
    case Shape::Opaque:
      break;
    case Shape::FixedArray:
      type.array = RosFieldType::Array::Fixed;
      type.array_size = count;
      break;
    case Shape::Sequence:
    case Shape::InlineSequence:
      type.array = ros_bound ? RosFieldType::Array::Bounded : RosFieldType::Array::Unbounded;
      type.array_size = ros_bound;
      break;
  }
  return type;
}

std::string PairedField::ln_spelling() const {
  std::string element_name;
  switch (element) {
    case ElementKind::Primitive:
      element_name = std::string(ln::md::c_name(ln_primitive));
      break;
    case ElementKind::String:
      element_name = string_capacity ? "char[" + std::to_string(string_capacity) + "]+len" : "char*";
      break;
    case ElementKind::Struct:
      element_name = struct_type ? struct_type->ln_name : "?";
      break;
  }
  switch (shape) {
    case Shape::Single:
      return element_name;
    case Shape::FixedArray:
      return element_name + "[" + std::to_string(count) + "]";
    case Shape::Sequence:
    case Shape::Opaque:
      return element_name + "*";
    case Shape::InlineSequence:
      return element_name + "[" + std::to_string(count) + "]+len";
  }
  return element_name;
}

std::string PairedType::ros_package() const { return ros_name.substr(0, ros_name.find('/')); }

std::string PairedType::ros_type_name() const { return ros_name.substr(ros_name.rfind('/') + 1); }

}  // namespace msg_mapping
