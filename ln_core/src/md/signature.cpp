#include <algorithm>
#include <vector>

#include "ln/md/message_definition.hpp"

namespace ln::md {
namespace {

std::string join_entries(const std::vector<Field>& fields, std::vector<const Definition*>& stack);

// A sub-type's signature. A type already being described (self-recursion,
// which LN 2.9 writes as "[]") has no finite signature and is named "[]".
std::string sub_signature(const Definition& sub, std::vector<const Definition*>& stack) {
  if (std::find(stack.begin(), stack.end(), &sub) != stack.end()) return "";
  stack.push_back(&sub);
  std::string inner = join_entries(sub.fields, stack);
  stack.pop_back();
  return inner;
}

std::string join_entries(const std::vector<Field>& fields, std::vector<const Definition*>& stack) {
  std::string out;
  for (const Field& f : fields) {
    if (!out.empty()) out += ',';
    std::string type;
    std::size_t element_size;
    if (f.primitive) {
      type = std::string(c_name(*f.primitive));
      element_size = size_of(*f.primitive);
    } else if (std::find(stack.begin(), stack.end(), f.sub) != stack.end()) {
      type = "[]";
      element_size = 0;
    } else {
      type = "[" + sub_signature(*f.sub, stack) + "]";
      element_size = packet_size(*f.sub);
    }
    out += type + (f.dynamic ? "*" : "") + " " + std::to_string(element_size) + " " + std::to_string(f.count);
  }
  return out;
}

}  // namespace

std::string fields_signature(const Definition& owner, const std::vector<Field>& fields) {
  std::vector<const Definition*> stack{&owner};
  return join_entries(fields, stack);
}

std::string signature(const Definition& definition) {
  if (definition.kind == Kind::Plain) return fields_signature(definition, definition.fields);
  return fields_signature(definition, definition.fields) + "|" +
         fields_signature(definition, definition.response_fields);
}

}  // namespace ln::md
