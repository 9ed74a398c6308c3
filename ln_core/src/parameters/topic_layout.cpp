#include "parameters/topic_layout.hpp"

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>

namespace ln::paramcore {

namespace {

const char* c_type(ElementType type) {
  switch (type) {
    case ElementType::Double:
      return "double";
    case ElementType::Single:
      return "float";
    case ElementType::Int8:
      return "int8_t";
    case ElementType::UInt8:
    case ElementType::Boolean:
      return "uint8_t";
    case ElementType::Int16:
      return "int16_t";
    case ElementType::UInt16:
      return "uint16_t";
    case ElementType::Int32:
      return "int32_t";
    case ElementType::UInt32:
      return "uint32_t";
    case ElementType::Int64:
      return "int64_t";
    case ElementType::UInt64:
      return "uint64_t";
  }
  return "uint8_t";
}

// FNV-1a, 64 bit: a stable name for a definition text.
std::string text_hash(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

struct Node {
  std::vector<std::pair<std::string, std::unique_ptr<Node>>> children;  // in order of first appearance
  std::size_t field = SIZE_MAX;                                         // a leaf: index into the fields

  Node* child(const std::string& name) {
    for (auto& [child_name, node] : children)
      if (child_name == name) return node.get();
    children.emplace_back(name, std::make_unique<Node>());
    return children.back().second.get();
  }
};

class Builder {
 public:
  explicit Builder(const std::vector<TopicField>& fields) : fields_(fields) {}

  // The definition name of `node`; adds it (and what it imports) once.
  std::string define(const Node& node) {
    if (node.field != SIZE_MAX && !node.children.empty() && layout.error.empty())
      layout.error = "parameter '" + fields_[node.field].full_name + "' is also the name of a group ('" +
                     fields_[node.field].full_name + "." + node.children.front().first + "')";
    if (node.field != SIZE_MAX) {
      const TopicField& f = fields_[node.field];
      layout.order.push_back(node.field);
      layout.packet_size += 2 * f.elements * element_size(f.type) + 1;
      const std::string count = f.elements == 1 ? "" : "[" + std::to_string(f.elements) + "]";
      const std::string name = std::string("gen/ln/parameters/") + element_type_name(f.type) +
                               (f.elements == 1 ? "" : "x" + std::to_string(f.elements)) + "_field";
      add(name, std::string(c_type(f.type)) + " input" + count + "\n" + c_type(f.type) + " output" + count +
                    "\nuint8_t override_enabled\n");
      return name;
    }
    std::string text;
    std::size_t local = 0;
    for (const auto& [name, child] : node.children) {
      const std::string type = "t" + std::to_string(local++) + "_t";
      text += "define " + type + " as \"" + define(*child) + "\"\n" + type + " " + name + "\n";
    }
    const std::string name = "gen/ln/parameters/s_" + text_hash(text);
    add(name, text);
    return name;
  }

  TopicLayout layout;

 private:
  void add(const std::string& name, const std::string& text) {
    for (const auto& [known, unused] : layout.definitions)
      if (known == name) return;
    layout.definitions.emplace_back(name, text);
  }
  const std::vector<TopicField>& fields_;
};

}  // namespace

TopicLayout topic_layout(const std::vector<TopicField>& fields) {
  Node root;
  std::string builder_error;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    Node* node = &root;
    const std::string& name = fields[i].full_name;
    for (std::size_t start = 0;;) {
      const std::size_t dot = name.find('.', start);
      const std::string part = name.substr(start, dot - start);
      if (part.empty() && builder_error.empty()) builder_error = "parameter '" + name + "' has an empty name part";
      node = node->child(part);
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    node->field = i;
  }
  Builder builder(fields);
  builder.layout.root = builder.define(root);
  if (!builder_error.empty()) builder.layout.error = builder_error;
  return std::move(builder.layout);
}

void append_to_packet(std::vector<std::uint8_t>& packet, const std::vector<std::uint8_t>& input,
                      const std::vector<std::uint8_t>& output, bool override_enabled) {
  packet.insert(packet.end(), input.begin(), input.end());
  packet.insert(packet.end(), output.begin(), output.end());
  packet.push_back(override_enabled ? 1 : 0);
}

}  // namespace ln::paramcore
