// LN message definitions -> ROS 2 interface packages.
//
// Built on ln_core's message-definition model (ln::md): every LN definition
// maps to one ROS type (deduplicated by its absolute LN name):
//   plain definition  -> pkg/msg/Type
//   service           -> pkg/srv/Type (request/response)
//   event             -> pkg/msg/TypeConnect + pkg/msg/TypeCall (README: "Events")
// Field types: float -> float32, double -> float64, char -> uint8, intN_t ->
// intN, uintN_t -> uintN; T x[N] -> T[N]; T* x -> T[] (the companion x_len
// disappears: the sequence carries the count); char* -> string; sub-types ->
// their own message; a dynamic field whose type leads back to the containing
// type (recursion, impossible in ROS) -> uint8[] holding the LN flat bytes.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/mapping.hpp"
#include "msg_mapping/naming.hpp"

namespace msg_mapping {

struct GeneratedFile {
  std::string path;  ///< relative to the package directory
  std::string content;
};

struct GeneratedPackage {
  std::string name;
  std::vector<std::string> ln_definitions;  ///< the LN names it holds, sorted
  std::set<std::string> dependencies;       ///< other ROS packages it uses
  std::vector<GeneratedFile> files;         ///< package.xml, CMakeLists.txt, msg/, srv/, ln_mapping.json
};

class LnToRos {
 public:
  explicit LnToRos(NamingOptions naming = {});
  ~LnToRos();
  LnToRos(const LnToRos&) = delete;
  LnToRos& operator=(const LnToRos&) = delete;

  /// Maps `definition` and every definition it uses. Throws Error (unmappable
  /// names, collisions after escaping) naming the definition and field.
  const PairedInterface& add(const ln::md::Definition& definition);
  /// The mapping of an already added LN definition, or nullptr.
  const PairedInterface* find(std::string_view ln_name) const;
  /// Every added definition (sub-types included), sorted by LN name.
  std::vector<const PairedInterface*> interfaces() const;

  /// The ROS packages with all their files. Throws Error when packages would
  /// depend on each other in a cycle (use single-package mode then).
  std::vector<GeneratedPackage> packages() const;

  const NamingOptions& naming() const { return naming_; }

 private:
  const PairedType& map_struct(const ln::md::Definition& definition);
  PairedType& new_type(const std::string& key, const std::string& ln_name, const std::string& ln_hash,
                       const std::string& ros_name);
  void map_fields(const ln::md::Definition& owner, const std::vector<ln::md::Field>& fields, PairedType& type);
  void claim_ros_name(const std::string& ros_full_name, const std::string& ln_name);

  NamingOptions naming_;
  std::map<std::string, std::unique_ptr<PairedType>> types_;
  std::map<std::string, PairedInterface, std::less<>> interfaces_;
  std::map<std::string, std::string> ros_owner_;  ///< ROS type (and file) names -> LN name
};

/// The .msg text of one mapped message type (a message, a service's request or
/// response, an event part): its fields, each commented with its LN form, as
/// in the type's file of packages() but without the file's header comment.
/// What recordings embed as the type's schema (ln_bag).
std::string msg_text(const PairedType& type);

/// Definition names found under `dir` (every regular file, recursively,
/// relative to `dir`, '/'-separated, sorted; hidden files and md.conf skipped).
std::vector<std::string> definition_names_under(const std::string& dir);

}  // namespace msg_mapping
