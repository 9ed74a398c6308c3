// Deterministic names on both sides of the LN <-> ROS 2 mapping.
//
// LN -> ROS (see README.md, "Naming"):
//   package  first component of the LN name, snake_cased, + "_ln_msgs"
//            ("my_robot/arm/pose" -> my_robot_ln_msgs); one-component names
//            ("two_doubles") go to "ln_msgs"; with NamingOptions::single_package
//            everything goes to that one package.
//   type     the remaining components (all of them in single-package mode),
//            CamelCased word by word ("arm/pose" -> ArmPose, "tree_info2" ->
//            TreeInfo2); Python/IDL keywords get "Msg" appended ("None" -> NoneMsg).
//   field    rosidl's camel-to-snake conversion, "__" collapsed, outer "_"
//            stripped, "field_" prefixed when it does not start with a letter,
//            "_field" appended to C/C++/Python/IDL keywords ("string" -> string_field).
// Anything that still violates rosidl's rules (non-ASCII characters, ...) is an
// Error naming the LN definition and field; collisions are detected by the
// generator after all names are known.
#pragma once

#include <string>
#include <string_view>

namespace msg_mapping {

bool is_valid_ros_package_name(std::string_view name);   ///< ^(?!.*__)(?!.*_$)[a-z][a-z0-9_]*$
bool is_valid_ros_type_name(std::string_view name);      ///< ^[A-Z][A-Za-z0-9]*$
bool is_valid_ros_field_name(std::string_view name);     ///< like package names
bool is_valid_ros_constant_name(std::string_view name);  ///< ^[A-Z]([A-Z0-9_]?[A-Z0-9]+)*$

/// A keyword of C, C++, Python or IDL 4.2 (exact spelling), which breaks one of
/// rosidl's code generators when used as a name.
bool is_reserved_identifier(std::string_view name);
/// A C or C++ keyword: not usable as an LN field or type name.
bool is_c_reserved_identifier(std::string_view name);

/// rosidl's convert_camel_case_to_lower_case_underscore ("HTTPServer" ->
/// "http_server"); rosidl names generated files with it, so two type names
/// with the same result collide.
std::string camel_to_snake(std::string_view name);

struct NamingOptions {
  std::string package_suffix = "_ln_msgs";
  std::string root_package = "ln_msgs";  ///< package of one-component LN names
  std::string single_package;            ///< non-empty: every type goes here
};

struct RosTypeName {
  std::string package;
  std::string type;
};

/// The ROS package and type name for LN definition `ln_name`. Throws Error
/// when the name cannot be mapped (e.g. characters outside ASCII letters,
/// digits and the separators '_', '-', '.').
RosTypeName ros_type_name_for(std::string_view ln_name, const NamingOptions& options);

/// The ROS field name for LN field `ln_field`; `why` (optional) receives the
/// reason when it differs. Throws Error when no valid name results.
std::string ros_field_name_for(std::string_view ln_field, std::string* why = nullptr);

/// The LN field name for ROS field `ros_field`: unchanged unless it is a C/C++
/// keyword (then "_field" is appended).
std::string ln_field_name_for(std::string_view ros_field);

}  // namespace msg_mapping
