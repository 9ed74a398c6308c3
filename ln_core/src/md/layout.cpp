#include <charconv>

#include "ln/md/message_definition.hpp"
#include "md/text.hpp"

namespace ln::md {

std::size_t packet_size(const Definition& definition) {
  std::size_t size = 0;
  for (const Field& f : definition.fields) {
    if (f.dynamic) continue;  // pointed-to data never travels in a packet
    const std::size_t element = f.primitive ? size_of(*f.primitive) : packet_size(*f.sub);
    size += element * f.count;
  }
  return size;
}

StructLayout struct_layout(const std::vector<Field>& fields, std::size_t pointer_size) {
  StructLayout layout;
  layout.offsets.reserve(fields.size());
  for (const Field& f : fields) {
    layout.offsets.push_back(layout.size);
    std::size_t element;
    if (f.dynamic)
      element = pointer_size;
    else if (f.primitive)
      element = size_of(*f.primitive);
    else
      element = struct_layout(f.sub->fields, pointer_size).size;
    layout.size += element * f.count;
  }
  return layout;
}

MemberLocation locate_member(const Definition& definition, std::string_view member) {
  const Definition* current = &definition;
  MemberLocation location;
  std::string_view rest = member;
  for (;;) {
    const auto dot = rest.find('.');
    std::string_view part = text::strip(rest.substr(0, dot));
    std::string_view name = part;
    std::int64_t index = 0;
    if (text::ends_with(part, "]")) {
      const auto bracket = part.rfind('[');
      if (bracket == std::string_view::npos)
        throw Error(definition.name, 0, "member '" + std::string(member) + "': unbalanced ']'");
      name = text::strip(part.substr(0, bracket));
      const auto digits = text::strip(part.substr(bracket + 1, part.size() - bracket - 2));
      const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
      if (error != std::errc() || end != digits.data() + digits.size())
        throw Error(definition.name, 0,
                    "member '" + std::string(member) + "': index '" + std::string(digits) + "' is not an integer");
    }
    const Field* found = nullptr;
    std::size_t offset = 0;
    std::size_t element_size = 0;
    for (const Field& f : current->fields) {
      if (f.dynamic)
        throw Error(definition.name, 0,
                    "cannot locate members in '" + current->name + "': it has dynamic fields (" + f.name + ")");
      element_size = f.primitive ? size_of(*f.primitive) : packet_size(*f.sub);
      if (f.name == name) {
        found = &f;
        break;
      }
      offset += element_size * f.count;
    }
    if (!found)
      throw Error(definition.name, 0,
                  "'" + current->name + "' has no field '" + std::string(name) + "' (looking for '" +
                      std::string(member) + "')");
    if (index < 0) index += found->count;  // Python-style index from the end
    if (index < 0 || index >= static_cast<std::int64_t>(found->count))
      throw Error(definition.name, 0,
                  "field '" + found->name + "' has " + std::to_string(found->count) + " element(s); '" +
                      std::string(part) + "' is out of range");
    location.offset += offset + static_cast<std::size_t>(index) * element_size;
    location.size = element_size;
    if (dot == std::string_view::npos) return location;
    if (!found->sub)
      throw Error(definition.name, 0,
                  "field '" + found->name + "' is a " + std::string(c_name(*found->primitive)) +
                      " and has no members (looking for '" + std::string(member) + "')");
    current = found->sub;
    rest = rest.substr(dot + 1);
  }
}

}  // namespace ln::md
