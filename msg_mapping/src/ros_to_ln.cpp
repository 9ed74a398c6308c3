#include "msg_mapping/ros_to_ln.hpp"

#include <set>

#include "mapping_json.hpp"
#include "msg_mapping/naming.hpp"
#include "text_util.hpp"

namespace msg_mapping {

namespace md = ln::md;

namespace {

constexpr const char* dummy_member = "structure_needs_at_least_one_member";

std::string canonical_message(const std::string& ros_type) {
  std::string package, kind, type;
  split_ros_type_name(ros_type, package, kind, type);
  return package + "/msg/" + type;
}

// True when the LN side has no dynamic field anywhere (a topic packet).
bool is_fixed(const PairedType& type) {
  for (const PairedField& f : type.fields) {
    if (f.shape == Shape::Sequence || f.shape == Shape::Opaque) return false;
    if (f.element == ElementKind::String && !f.string_capacity) return false;
    if (f.element == ElementKind::Struct && !is_fixed(*f.struct_type)) return false;
  }
  return true;
}

// LN bytes of a fixed-size paired type (for the self-check against ln_core's packet_size).
std::size_t fixed_ln_size(const PairedType& type) {
  std::size_t size = 0;
  for (const PairedField& f : type.fields) {
    std::size_t element = 0;
    switch (f.element) {
      case ElementKind::Primitive:
        element = md::size_of(f.ln_primitive);
        break;
      case ElementKind::String:
        element = 4 + f.string_capacity;
        break;
      case ElementKind::Struct:
        element = fixed_ln_size(*f.struct_type);
        break;
    }
    size += f.shape == Shape::InlineSequence ? 4 + element * f.count : element * f.count;
  }
  return size;
}

}  // namespace

// Emits the LN lines of one field list and pairs its fields.
class FieldWriter {
 public:
  FieldWriter(std::map<std::string, std::string>& defines, std::string where)
      : defines_(defines), where_(std::move(where)) {}

  std::vector<std::string> lines;

  void comment(const std::string& text) { lines.push_back("# " + text); }

  void field(const std::string& spelling, const std::string& name) {
    reserve(name.substr(0, name.find('[')));
    lines.push_back(spelling + " " + name);
  }

  // Claims an LN field name (also the implicit X_len of a dynamic field X).
  void reserve(const std::string& name) {
    if (!names_.insert(name).second)
      throw Error(where_ + ": the LN field name '" + name +
                  "' is needed twice (a ROS field named like another field's _len companion?)");
  }

  // Registers `define local as "ln_name"` and returns the local type name.
  std::string use(const std::string& local, const std::string& ln_name) {
    defines_[local] = ln_name;
    return local;
  }

 private:
  std::map<std::string, std::string>& defines_;
  std::string where_;
  std::set<std::string> names_;
};

namespace {

std::string define_lines(const std::map<std::string, std::string>& defines) {
  std::string out;
  for (const auto& [local, name] : defines) out += "define " + local + " as \"" + name + "\"\n";
  return out;
}

}  // namespace

RosToLn::RosToLn(std::vector<std::string> share_dirs, RosToLnOptions options)
    : store_(std::move(share_dirs)),
      options_(std::move(options)),
      library_(std::make_unique<md::Library>(md::SearchPath::exactly({}))) {
  if (!md::is_valid_definition_name(options_.prefix))
    throw Error("'" + options_.prefix + "' is not usable as the first part of LN definition names");
  if (!options_.default_string_capacity || !options_.default_sequence_capacity)
    throw Error("default capacities must be at least 1");
}

RosToLn::~RosToLn() = default;

std::uint32_t RosToLn::capacity(const std::string& key, std::uint32_t fallback) const {
  const auto it = options_.capacities.find(key);
  if (it == options_.capacities.end()) return fallback;
  if (it->second == 0) throw Error("capacity of '" + key + "' must be at least 1");
  return it->second;
}

bool RosToLn::has_containers(const std::string& ros_type) {
  const RosMessage& m = store_.message(ros_type);
  for (const auto& f : m.fields) {
    if (f.type.is_sequence() || (f.type.primitive && is_string(*f.type.primitive))) return true;
    if (f.type.is_nested() && has_containers(f.type.nested)) return true;
  }
  return false;
}

std::string RosToLn::ln_name_for(const std::string& ros_type, bool dynamic) {
  std::string package, kind, type;
  split_ros_type_name(ros_type, package, kind, type);
  const std::string base = options_.prefix + "/" + package + "/msg/" + type;
  return dynamic && has_containers(ros_type) ? base + "_dynamic" : base;
}

std::string RosToLn::string_helper(std::uint32_t capacity) {
  const std::string name = options_.prefix + "/msg_mapping/string" + (capacity ? std::to_string(capacity) : "");
  if (!texts_.count(name)) {
    texts_[name] = capacity ? "# A ROS string inside an array, for LN topics (capacity " + std::to_string(capacity) +
                                  " bytes).\nuint32_t data_len\nchar data[" + std::to_string(capacity) + "]\n"
                            : "# A ROS string inside an array, for LN services.\nchar* data\n";
    pending_.push_back(name);
  }
  return name;
}

const PairedType& RosToLn::map_message(const std::string& ros_type, bool dynamic) {
  const std::string canonical = canonical_message(ros_type);
  const std::string ln_name = ln_name_for(canonical, dynamic);
  if (auto it = types_.find(ln_name); it != types_.end()) return *it->second;
  const RosMessage& message = store_.message(canonical);
  const bool really_dynamic = dynamic && ln_name != ln_name_for(canonical, false);

  auto owned = std::make_unique<PairedType>();
  PairedType& type = *owned;
  type.ln_name = ln_name;
  type.ros_name = canonical;
  types_[ln_name] = std::move(owned);

  std::map<std::string, std::string> defines;
  FieldWriter w(defines, "ROS type " + canonical);
  for (const auto& c : message.comments) w.comment(c);
  write_fields(message, canonical, really_dynamic, type, w);

  std::string text = "# Generated by msg_mapping (ln_ros2_gen) from the ROS 2 type " + canonical + "\n# (" +
                     (really_dynamic ? "dynamic variant, for LN services" : "fixed-size variant, for LN topics") +
                     "). Do not edit: regenerate instead.\n";
  text += define_lines(defines);
  for (const auto& line : w.lines) text += line + "\n";
  texts_[ln_name] = text;
  pending_.push_back(ln_name);
  return type;
}

void RosToLn::write_fields(const RosMessage& message, const std::string& where, bool really_dynamic, PairedType& type,
                           FieldWriter& w) {
  for (const auto& c : message.constants) w.comment("constant " + c.type + " " + c.name + "=" + c.value);
  for (const RosField& f : message.fields) {
    const std::string key = where + "." + f.name;
    PairedField pf;
    pf.ros_name = f.name;
    pf.ln_name = ln_field_name_for(f.name);
    for (const auto& c : f.comments) w.comment(c);
    if (!f.default_value.empty()) w.comment("ROS default of " + f.name + ": " + f.default_value);
    if (pf.ln_name != f.name) pf.note = "renamed: '" + f.name + "' is a C/C++ keyword";

    // The element: what one array slot holds on the LN side.
    std::string element;
    if (f.type.primitive && *f.type.primitive == RosPrimitive::WString)
      throw Error("ROS type " + where + ", field '" + f.name + "': wstring has no LN counterpart");
    if (f.type.primitive && *f.type.primitive == RosPrimitive::String) {
      pf.element = ElementKind::String;
      pf.ros_string_bound = f.type.string_bound;
      if (!really_dynamic)
        pf.string_capacity = f.type.string_bound
                                 ? f.type.string_bound
                                 : capacity(f.type.array == RosFieldType::Array::None ? key : key + "[]",
                                            options_.default_string_capacity);
      if (f.type.array != RosFieldType::Array::None) {
        const std::string helper = string_helper(pf.string_capacity);
        element = w.use(pf.string_capacity ? "bounded_string" + std::to_string(pf.string_capacity) : "dynamic_string",
                        helper);
      }
    } else if (f.type.primitive) {
      pf.element = ElementKind::Primitive;
      pf.ros_primitive = *f.type.primitive;
      pf.ln_primitive = ln_primitive_for(pf.ros_primitive);
      element = std::string(md::c_name(pf.ln_primitive));
      if (pf.ros_primitive == RosPrimitive::Bool || pf.ros_primitive == RosPrimitive::Byte ||
          pf.ros_primitive == RosPrimitive::Char)
        w.comment(f.name + ": ROS " + std::string(spelling(pf.ros_primitive)));
    } else {
      pf.element = ElementKind::Struct;
      pf.struct_type = &map_message(f.type.nested, really_dynamic);
      std::string package, kind, nested_type;
      split_ros_type_name(f.type.nested, package, kind, nested_type);
      const bool nested_dynamic = pf.struct_type->ln_name != ln_name_for(f.type.nested, false);
      element = w.use(package + "__" + camel_to_snake(nested_type) + (nested_dynamic ? "_dynamic" : ""),
                      pf.struct_type->ln_name);
    }

    const std::string length_name = pf.ln_name + "_len";
    switch (f.type.array) {
      case RosFieldType::Array::None:
        pf.shape = Shape::Single;
        if (pf.element == ElementKind::String) {
          if (really_dynamic) {
            w.reserve(length_name);
            w.field("char*", pf.ln_name);
          } else {
            w.comment(f.name + ": string, capacity " + std::to_string(pf.string_capacity) + " bytes");
            w.field("uint32_t", length_name);
            w.field("char", pf.ln_name + "[" + std::to_string(pf.string_capacity) + "]");
          }
          pf.ln_length_name = length_name;
        } else {
          w.field(element, pf.ln_name);
        }
        break;
      case RosFieldType::Array::Fixed:
        pf.shape = Shape::FixedArray;
        pf.count = f.type.array_size;
        w.field(element, pf.ln_name + "[" + std::to_string(pf.count) + "]");
        break;
      case RosFieldType::Array::Bounded:
      case RosFieldType::Array::Unbounded:
        pf.ros_bound = f.type.array == RosFieldType::Array::Bounded ? f.type.array_size : 0;
        pf.ln_length_name = length_name;
        if (really_dynamic) {
          pf.shape = Shape::Sequence;
          w.reserve(length_name);
          w.field(element + "*", pf.ln_name);
        } else {
          pf.shape = Shape::InlineSequence;
          pf.count = pf.ros_bound ? pf.ros_bound : capacity(key, options_.default_sequence_capacity);
          w.comment(f.name + ": sequence, capacity " + std::to_string(pf.count) + " elements");
          w.field("uint32_t", length_name);
          w.field(element, pf.ln_name + "[" + std::to_string(pf.count) + "]");
        }
        break;
    }
    type.fields.push_back(std::move(pf));
  }
  if (message.fields.empty()) {
    PairedField pf;
    pf.ln_name = pf.ros_name = dummy_member;
    pf.note = "rosidl's member of an empty message";
    w.field("uint8_t", dummy_member);
    type.fields.push_back(std::move(pf));
  }
}

const PairedInterface& RosToLn::add(const std::string& ros_type, bool dynamic) {
  std::string package, kind, type_name;
  split_ros_type_name(ros_type, package, kind, type_name);
  const bool service = kind == "srv";
  const std::string canonical = package + (service ? "/srv/" : "/msg/") + type_name;
  const std::string key = canonical + (dynamic && !service ? "#dynamic" : "");
  if (auto it = interfaces_.find(key); it != interfaces_.end()) return it->second;

  pending_.clear();
  try {
    PairedInterface interface;
    interface.ros_name = canonical;
    if (!service) {
      const PairedType& t = map_message(canonical, dynamic);
      interface.kind = InterfaceKind::Message;
      interface.ln_name = t.ln_name;
      interface.first = &t;
    } else {
      const RosService& svc = store_.service(canonical);
      interface.kind = InterfaceKind::Service;
      interface.ln_name = options_.prefix + "/" + package + "/srv/" + type_name;
      std::map<std::string, std::string> defines;
      std::string sections;
      PairedType* parts[2];
      const RosMessage* messages[2] = {&svc.request, &svc.response};
      const char* section_names[2] = {"request", "response"};
      FieldWriter* writers[2];
      FieldWriter request_writer(defines, "ROS service " + canonical + " (request)");
      FieldWriter response_writer(defines, "ROS service " + canonical + " (response)");
      writers[0] = &request_writer;
      writers[1] = &response_writer;
      for (int k = 0; k < 2; ++k) {
        const std::string part_name = interface.ln_name + "#" + section_names[k];
        auto owned = std::make_unique<PairedType>();
        owned->ln_name = part_name;
        owned->ros_name = canonical + "_" + (k == 0 ? "Request" : "Response");
        parts[k] = owned.get();
        types_[part_name] = std::move(owned);
        write_fields(*messages[k], parts[k]->ros_name, true, *parts[k], *writers[k]);
        sections += std::string(section_names[k]) + "\n";
        for (const auto& line : writers[k]->lines) sections += line + "\n";
      }
      interface.first = parts[0];
      interface.second = parts[1];
      texts_[interface.ln_name] = "# Generated by msg_mapping (ln_ros2_gen) from the ROS 2 service " + canonical +
                                  ".\n# Do not edit: regenerate instead.\nservice\n" + define_lines(defines) + sections;
      pending_.push_back(interface.ln_name);
    }
    finish(pending_);
    interface.ln_hash = library_->load(interface.ln_name).hash;
    if (service) {
      const_cast<PairedType*>(interface.first)->ln_hash = interface.ln_hash;
      const_cast<PairedType*>(interface.second)->ln_hash = interface.ln_hash;
    }
    pending_.clear();
    return interfaces_[key] = interface;
  } catch (...) {
    for (const auto& name : pending_) {
      texts_.erase(name);
      types_.erase(name);
    }
    pending_.clear();
    throw;
  }
}

void RosToLn::finish(const std::vector<std::string>& new_names) {
  for (const auto& name : new_names) library_->add_source(name, texts_.at(name));
  for (const auto& name : new_names) {
    const md::Definition& d = library_->load(name);
    auto it = types_.find(name);
    if (it == types_.end()) continue;  // string helpers and services have no type of their own
    PairedType& t = *it->second;
    t.ln_hash = d.hash;
    // Self-check: the pairing and ln_core's model agree on the packet size.
    if (is_fixed(t) && md::packet_size(d) != fixed_ln_size(t))
      throw Error("internal error: LN packet size of " + name + " is " + std::to_string(md::packet_size(d)) +
                  ", the mapping expects " + std::to_string(fixed_ln_size(t)));
  }
}

const PairedInterface* RosToLn::find(const std::string& ros_type, bool dynamic) const {
  std::string package, kind, type_name;
  split_ros_type_name(ros_type, package, kind, type_name);
  const bool service = kind == "srv";
  const std::string key = package + (service ? "/srv/" : "/msg/") + type_name + (dynamic && !service ? "#dynamic" : "");
  const auto it = interfaces_.find(key);
  return it == interfaces_.end() ? nullptr : &it->second;
}

std::string RosToLn::mapping_json() const {
  Json mapping = Json::object();
  mapping.set("format", "msg_mapping/ros_to_ln/1");
  mapping.set("prefix", options_.prefix);
  Json capacities = Json::object();
  capacities.set("string_default", options_.default_string_capacity);
  capacities.set("sequence_default", options_.default_sequence_capacity);
  for (const auto& [k, v] : options_.capacities) capacities.set(k, v);
  mapping.set("capacities", std::move(capacities));
  Json interfaces = Json::array();
  for (const auto& [key, i] : interfaces_)
    interfaces.push(paired_interface_json(i, i.kind == InterfaceKind::Message && is_fixed(*i.first)));
  mapping.set("interfaces", std::move(interfaces));
  // Every paired type, nested ones included (interfaces only list what was asked for).
  Json types = Json::array();
  for (const auto& [name, type] : types_) types.push(paired_type_json(*type));
  mapping.set("types", std::move(types));
  return mapping.dump();
}

}  // namespace msg_mapping
