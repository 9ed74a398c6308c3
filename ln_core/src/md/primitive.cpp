#include <array>

#include "ln/md/message_definition.hpp"

namespace ln::md {
namespace {

struct PrimitiveTraits {
  Primitive type;
  std::string_view c_name;
  std::size_t size;
  bool integer;
  bool is_signed;
};

// Order matches the enum.
constexpr std::array<PrimitiveTraits, 11> traits_table{{
    {Primitive::Float, "float", 4, false, true},
    {Primitive::Double, "double", 8, false, true},
    {Primitive::Char, "char", 1, true, true},
    {Primitive::Int8, "int8_t", 1, true, true},
    {Primitive::UInt8, "uint8_t", 1, true, false},
    {Primitive::Int16, "int16_t", 2, true, true},
    {Primitive::UInt16, "uint16_t", 2, true, false},
    {Primitive::Int32, "int32_t", 4, true, true},
    {Primitive::UInt32, "uint32_t", 4, true, false},
    {Primitive::Int64, "int64_t", 8, true, true},
    {Primitive::UInt64, "uint64_t", 8, true, false},
}};

struct Alias {
  std::string_view spelling;
  Primitive type;
};
constexpr std::array<Alias, 4> aliases{{
    {"float32_t", Primitive::Float},
    {"float64_t", Primitive::Double},
    {"short", Primitive::Int16},
    {"int", Primitive::Int32},
}};

const PrimitiveTraits& traits(Primitive type) { return traits_table[static_cast<std::size_t>(type)]; }

}  // namespace

std::string_view c_name(Primitive type) { return traits(type).c_name; }
std::size_t size_of(Primitive type) { return traits(type).size; }
bool is_integer(Primitive type) { return traits(type).integer; }
bool is_signed(Primitive type) { return traits(type).is_signed; }
bool is_floating_point(Primitive type) { return !traits(type).integer; }

std::optional<Primitive> primitive_from_spelling(std::string_view spelling) {
  for (const auto& t : traits_table)
    if (t.c_name == spelling) return t.type;
  for (const auto& a : aliases)
    if (a.spelling == spelling) return a.type;
  return std::nullopt;
}

}  // namespace ln::md
