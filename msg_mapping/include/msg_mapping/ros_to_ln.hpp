// ROS 2 .msg/.srv types -> LN message definitions, so LN nodes can use ROS types.
//
// LN names: <prefix>/<pkg>/msg/<Type> and <prefix>/<pkg>/srv/<Type> (prefix
// "ros2" by default). Two variants of a message exist when it contains
// strings or sequences:
//   fixed   (<prefix>/<pkg>/msg/<Type>): for LN topics, which carry fixed-size
//           packets. A string becomes `uint32_t x_len; char x[cap]`, a sequence
//           `uint32_t x_len; T x[cap]`. cap = the ROS bound (string<=N, T[<=N])
//           or a configurable capacity (defaults: 255 bytes, 64 elements).
//           Converting a longer ROS value is an error, never a truncation.
//   dynamic (<prefix>/<pkg>/msg/<Type>_dynamic): for services (and anything
//           nested in them), which keep dynamic fields: `char* x`, `T* x`.
// Strings inside arrays use helper types <prefix>/msg_mapping/string<cap>
// (`uint32_t data_len; char data[cap]`) and <prefix>/msg_mapping/string
// (`char* data`). bool, byte and char become uint8_t; wstring is rejected.
// Constants and default values become comments (LN has neither). An empty
// message keeps rosidl's `uint8_t structure_needs_at_least_one_member`.
//
// Capacities are configured per field: "pkg/msg/Type.field" (elements of a
// sequence, or bytes of a string field) and "pkg/msg/Type.field[]" (bytes of
// each string in a string array or sequence).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/mapping.hpp"
#include "msg_mapping/ros_model.hpp"

namespace msg_mapping {

class FieldWriter;  // ros_to_ln.cpp

struct RosToLnOptions {
  std::string prefix = "ros2";
  std::uint32_t default_string_capacity = 255;
  std::uint32_t default_sequence_capacity = 64;
  std::map<std::string, std::uint32_t> capacities;
};

class RosToLn {
 public:
  RosToLn(std::vector<std::string> share_dirs, RosToLnOptions options = {});
  ~RosToLn();
  RosToLn(const RosToLn&) = delete;
  RosToLn& operator=(const RosToLn&) = delete;

  /// Maps the ROS type "pkg/msg/Type" (fixed variant, or dynamic when
  /// `dynamic`) or "pkg/srv/Type" (always dynamic) and everything it uses.
  /// Throws Error.
  const PairedInterface& add(const std::string& ros_type, bool dynamic = false);
  const PairedInterface* find(const std::string& ros_type, bool dynamic = false) const;

  /// Every generated LN definition: name -> text.
  const std::map<std::string, std::string>& definitions() const { return texts_; }
  /// ros_mapping.json: every added interface with its field pairing.
  std::string mapping_json() const;

  RosTypeStore& store() { return store_; }
  /// The LN library holding the generated texts (loaded, hashed by ln_core's model).
  ln::md::Library& library() { return *library_; }
  /// The LN name of the (fixed or dynamic) variant of message `ros_type`.
  std::string ln_name_for(const std::string& ros_type, bool dynamic);

 private:
  const PairedType& map_message(const std::string& ros_type, bool dynamic);
  void write_fields(const RosMessage& message, const std::string& where, bool dynamic, PairedType& type,
                    FieldWriter& writer);
  std::string string_helper(std::uint32_t capacity);  ///< LN name of a string helper type
  std::uint32_t capacity(const std::string& key, std::uint32_t fallback) const;
  bool has_containers(const std::string& ros_type);
  void finish(const std::vector<std::string>& new_names);

  RosTypeStore store_;
  RosToLnOptions options_;
  std::unique_ptr<ln::md::Library> library_;
  std::map<std::string, std::unique_ptr<PairedType>> types_;  // by LN name
  std::map<std::string, PairedInterface> interfaces_;         // by "ros_type" or "ros_type#dynamic"
  std::map<std::string, std::string> texts_;                  // LN name -> text
  std::map<std::string, PairedType*> string_helpers_;         // LN name -> helper pairing
  std::vector<std::string> pending_;                          // LN names created by the current add()
};

}  // namespace msg_mapping
