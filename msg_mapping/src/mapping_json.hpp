// The JSON form of paired types, shared by both generator directions: it is
// what ln_mapping.json / ros_mapping.json record for each type.
#pragma once

#include "json.hpp"
#include "msg_mapping/mapping.hpp"

namespace msg_mapping {

inline const char* shape_name(Shape shape) {
  switch (shape) {
    case Shape::Single:
      return "single";
    case Shape::FixedArray:
      return "fixed_array";
    case Shape::Sequence:
      return "sequence";
    case Shape::InlineSequence:
      return "inline_sequence";
    case Shape::Opaque:
      return "opaque";
  }
  return "?";
}

inline Json paired_type_json(const PairedType& type) {
  Json fields = Json::array();
  for (const PairedField& f : type.fields) {
    Json field = Json::object();
    field.set("ln", f.ln_name).set("ros", f.ros_name);
    field.set("ln_type", f.ln_spelling()).set("ros_type", f.ros_type().spelling());
    if (!f.ln_length_name.empty()) field.set("ln_length", f.ln_length_name);
    if (f.shape == Shape::Opaque) field.set("encoding", "ln_flat");
    if (!f.note.empty()) field.set("note", f.note);
    // Machine-readable form of the pairing (what tools and the bridge use).
    field.set("shape", shape_name(f.shape));
    if (f.shape == Shape::FixedArray || f.shape == Shape::InlineSequence) field.set("count", f.count);
    if (f.ros_bound) field.set("ros_bound", f.ros_bound);
    switch (f.element) {
      case ElementKind::Primitive:
        field.set("element", "primitive");
        field.set("ln_primitive", std::string(ln::md::c_name(f.ln_primitive)));
        field.set("ros_primitive", std::string(spelling(f.ros_primitive)));
        break;
      case ElementKind::String:
        field.set("element", "string");
        if (f.string_capacity) field.set("string_capacity", f.string_capacity);
        if (f.ros_string_bound) field.set("ros_string_bound", f.ros_string_bound);
        break;
      case ElementKind::Struct:
        field.set("element", "struct");
        field.set("ros_struct", f.struct_type->ros_name);
        field.set("ln_struct", f.struct_type->ln_name);
        break;
    }
    fields.push(std::move(field));
  }
  Json out = Json::object();
  out.set("ln_name", type.ln_name).set("ros_type", type.ros_name);
  if (type.ros_dummy_member) out.set("ros_dummy_member", true);
  out.set("fields", std::move(fields));
  return out;
}

inline const char* interface_kind_name(InterfaceKind kind) {
  switch (kind) {
    case InterfaceKind::Message:
      return "message";
    case InterfaceKind::Service:
      return "service";
    case InterfaceKind::Event:
      return "event";
  }
  return "?";
}

inline Json paired_interface_json(const PairedInterface& i, bool ln_topic_compatible) {
  Json out = Json::object();
  out.set("ln_name", i.ln_name).set("ln_hash", i.ln_hash).set("kind", interface_kind_name(i.kind));
  out.set("ros_type", i.ros_name);
  switch (i.kind) {
    case InterfaceKind::Message:
      out.set("ln_topic_compatible", ln_topic_compatible);
      out.set("message", paired_type_json(*i.first));
      break;
    case InterfaceKind::Service:
      out.set("request", paired_type_json(*i.first)).set("response", paired_type_json(*i.second));
      break;
    case InterfaceKind::Event:
      out.set("connect", paired_type_json(*i.first)).set("call", paired_type_json(*i.second));
      break;
  }
  return out;
}

}  // namespace msg_mapping
