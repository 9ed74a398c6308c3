#include "msg_mapping/naming.hpp"

#include <algorithm>
#include <array>
#include <cstdio>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/ros_model.hpp"
#include "text_util.hpp"

namespace msg_mapping {
namespace {

// C keywords beyond the ones LN's definitions already refuse (ln::md::is_reserved_word):
// C11's and C23's, for names of generated C code.
constexpr std::string_view more_c_keywords[] = {"_Alignas",       "_Alignof",      "_Atomic", "_Imaginary",
                                                "_Static_assert", "_Thread_local", "typeof",  "typeof_unqual"};

// Python 3 keywords and IDL 4.2 keywords (rosidl's .idl stage), exact spelling.
constexpr std::string_view other_keywords[] = {
    "False",       "None",       "True",      "as",         "assert",    "async",     "await",     "def",
    "del",         "elif",       "except",    "finally",    "from",      "global",    "import",    "in",
    "is",          "lambda",     "nonlocal",  "pass",       "raise",     "with",      "yield",     "abstract",
    "any",         "alias",      "attribute", "bitfield",   "bitmask",   "bitset",    "boolean",   "component",
    "connector",   "consumes",   "context",   "custom",     "emits",     "eventtype", "exception", "factory",
    "FALSE",       "finder",     "fixed",     "getraises",  "getter",    "home",      "inout",     "interface",
    "local",       "manages",    "map",       "mirrorport", "module",    "multiple",  "native",    "Object",
    "octet",       "oneway",     "out",       "primarykey", "port",      "porttype",  "provides",  "publishes",
    "raises",      "readonly",   "setraises", "setter",     "sequence",  "string",    "supports",  "TRUE",
    "truncatable", "typeprefix", "uses",      "ValueBase",  "valuetype", "wchar",     "wstring",   "int8",
    "uint8",       "int16",      "uint16",    "int32",      "uint32",    "int64",     "uint64"};

template <std::size_t N>
bool contains(const std::string_view (&list)[N], std::string_view name) {
  return std::find(std::begin(list), std::end(list), name) != std::end(list);
}

// ^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$
bool is_lower_snake(std::string_view n) {
  if (n.empty() || !text::is_lower(n[0]) || n.back() == '_') return false;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const char c = n[i];
    if (!(text::is_lower(c) || text::is_digit(c) || c == '_')) return false;
    if (c == '_' && i + 1 < n.size() && n[i + 1] == '_') return false;
  }
  return true;
}

std::string describe_char(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (u >= 0x20 && u < 0x7f) return std::string("'") + c + "'";
  char buffer[8];
  std::snprintf(buffer, sizeof buffer, "0x%02x", u);
  return std::string("byte ") + buffer;
}

bool is_word_separator(char c) { return c == '_' || c == '-' || c == '.' || c == ' '; }

// "arm_pose-2" -> "ArmPose2": each word's first letter upper-cased.
std::string camel_case(std::string_view component, std::string_view ln_name) {
  std::string out;
  bool word_start = true;
  for (char c : component) {
    if (is_word_separator(c)) {
      word_start = true;
      continue;
    }
    if (!text::is_alnum(c))
      throw Error("LN definition '" + std::string(ln_name) + "': its name contains " + describe_char(c) +
                  ", which cannot appear in a ROS type name (only ASCII letters, digits, '_', '-', '.')");
    out += word_start ? text::to_upper(c) : c;
    word_start = false;
  }
  return out;
}

std::string package_from_component(std::string_view component, std::string_view ln_name) {
  for (char c : component)
    if (!text::is_alnum(c) && !is_word_separator(c))
      throw Error("LN definition '" + std::string(ln_name) + "': its name contains " + describe_char(c) +
                  ", which cannot appear in a ROS package name");
  std::string snake = camel_to_snake(component);
  std::string out;
  for (char c : snake) {
    const char mapped = text::is_alnum(c) ? c : '_';
    if (mapped == '_' && (out.empty() || out.back() == '_')) continue;
    out += mapped;
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  if (out.empty())
    throw Error("LN definition '" + std::string(ln_name) + "': its first component '" + std::string(component) +
                "' gives no usable ROS package name");
  if (text::is_digit(out[0])) out = "ln_" + out;
  return out;
}

}  // namespace

bool is_valid_ros_package_name(std::string_view name) { return is_lower_snake(name); }
bool is_valid_ros_field_name(std::string_view name) { return is_lower_snake(name); }

bool is_valid_ros_type_name(std::string_view name) {
  if (name.empty() || !text::is_upper(name[0])) return false;
  return std::all_of(name.begin(), name.end(), [](char c) { return text::is_alnum(c); });
}

bool is_valid_ros_constant_name(std::string_view name) {
  // ^[A-Z]([A-Z0-9_]?[A-Z0-9]+)*$ : upper case, digits, single '_' between them.
  if (name.empty() || !text::is_upper(name[0]) || name.back() == '_') return false;
  for (std::size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    if (!(text::is_upper(c) || text::is_digit(c) || c == '_')) return false;
    if (c == '_' && name[i + 1] == '_') return false;
  }
  return true;
}

bool is_c_reserved_identifier(std::string_view name) {
  return ln::md::is_reserved_word(name) || contains(more_c_keywords, name);
}

bool is_reserved_identifier(std::string_view name) {
  return is_c_reserved_identifier(name) || contains(other_keywords, name);
}

std::string camel_to_snake(std::string_view value) {
  // Step 1: '(.)([A-Z][a-z]+)' -> '\1_\2', scanning left to right like re.sub.
  std::string step1;
  for (std::size_t i = 0; i < value.size();) {
    if (i + 2 < value.size() && text::is_upper(value[i + 1]) && text::is_lower(value[i + 2])) {
      std::size_t end = i + 2;
      while (end < value.size() && text::is_lower(value[end])) ++end;
      step1 += value[i];
      step1 += '_';
      step1.append(value.substr(i + 1, end - i - 1));
      i = end;
    } else {
      step1 += value[i++];
    }
  }
  // Step 2: '([a-z0-9])([A-Z])' -> '\1_\2'
  std::string step2;
  for (std::size_t i = 0; i < step1.size(); ++i) {
    step2 += step1[i];
    if ((text::is_lower(step1[i]) || text::is_digit(step1[i])) && i + 1 < step1.size() &&
        text::is_upper(step1[i + 1])) {
      step2 += '_';
      step2 += step1[++i];
    }
  }
  for (char& c : step2) c = text::to_lower(c);
  return step2;
}

RosTypeName ros_type_name_for(std::string_view ln_name, const NamingOptions& options) {
  std::vector<std::string_view> components;
  std::size_t start = 0;
  for (;;) {
    const auto slash = ln_name.find('/', start);
    components.push_back(
        ln_name.substr(start, slash == std::string_view::npos ? std::string_view::npos : slash - start));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  RosTypeName result;
  std::size_t first_type_component = 0;
  if (!options.single_package.empty()) {
    result.package = options.single_package;
  } else if (components.size() == 1) {
    result.package = options.root_package;
  } else {
    result.package = package_from_component(components[0], ln_name) + options.package_suffix;
    first_type_component = 1;
  }
  if (!is_valid_ros_package_name(result.package) || is_reserved_identifier(result.package))
    throw Error("LN definition '" + std::string(ln_name) + "': '" + result.package +
                "' is not a valid ROS package name");
  for (std::size_t i = first_type_component; i < components.size(); ++i)
    result.type += camel_case(components[i], ln_name);
  if (result.type.empty())
    throw Error("LN definition '" + std::string(ln_name) + "': its name gives an empty ROS type name");
  if (text::is_digit(result.type[0])) result.type = "Ln" + result.type;
  if (is_reserved_identifier(result.type)) result.type += "Msg";
  if (!is_valid_ros_type_name(result.type))
    throw Error("LN definition '" + std::string(ln_name) + "': '" + result.type + "' is not a valid ROS type name");
  return result;
}

std::string ros_field_name_for(std::string_view ln_field, std::string* why) {
  std::string snake;
  for (char c : camel_to_snake(ln_field)) {
    if (c == '_' && (snake.empty() || snake.back() == '_')) continue;  // collapse "__", drop leading '_'
    snake += c;
  }
  while (!snake.empty() && snake.back() == '_') snake.pop_back();
  std::string reason;
  if (snake.empty() || !text::is_lower(snake[0])) {
    snake = snake.empty() ? "field" : "field_" + snake;
    reason = "a ROS field name must start with a letter";
  }
  if (is_reserved_identifier(snake)) {
    reason = "'" + snake + "' is a keyword in C, C++, Python or IDL";
    snake += "_field";
  }
  if (!is_valid_ros_field_name(snake))
    throw Error("field '" + std::string(ln_field) + "' gives '" + snake + "', not a valid ROS field name");
  if (why) {
    if (snake == ln_field)
      why->clear();
    else
      *why = reason.empty() ? "ROS field names are lower_snake_case" : reason;
  }
  return snake;
}

std::string ln_field_name_for(std::string_view ros_field) {
  std::string name(ros_field);
  if (is_c_reserved_identifier(name)) name += "_field";
  return name;
}

}  // namespace msg_mapping
