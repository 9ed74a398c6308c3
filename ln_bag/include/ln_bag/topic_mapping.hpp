// How one LN definition travels in a recording: the ROS 2 type msg_mapping
// maps it to (named as ln_ros2_gen names it), the type's "ros2msg" schema,
// and the codec between LN bytes and CDR.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "msg_mapping/codec.hpp"

namespace ln_bag {

/// The name MCAP schemas of ROS 2 message definitions carry.
inline constexpr const char* ros2msg_encoding = "ros2msg";

class TopicMapping {
 public:
  /// Maps LN definition `name` (a message; or a service or event with `part`
  /// "request"/"response" or "connect"/"call"). Definitions are taken from
  /// `texts` (name -> definition text, e.g. what the manager or a recording
  /// holds) before the directories `md_dirs`. Throws BagError naming the
  /// definition and what is wrong.
  TopicMapping(const std::string& name, const std::map<std::string, std::string>& texts,
               const std::vector<std::string>& md_dirs = {}, const std::string& part = "");
  ~TopicMapping();
  TopicMapping(TopicMapping&&) noexcept;
  TopicMapping& operator=(TopicMapping&&) noexcept;

  const std::string& ln_name() const { return ln_name_; }
  const std::string& ln_hash() const { return ln_hash_; }
  /// "pkg/msg/Type" ("pkg/srv/Type_Request" for a service part).
  const std::string& ros_type() const { return ros_type_; }
  /// The ros2msg schema: the type's .msg text, then for every type it uses a
  /// line of 80 '=', "MSG: pkg/Type" and that type's .msg text.
  const std::string& schema() const { return schema_; }
  /// Bytes of an LN topic packet (fixed part), as LN sends it.
  std::size_t packet_size() const { return packet_size_; }
  /// True when the definition has dynamic fields (services; no topic).
  bool dynamic() const { return dynamic_; }
  /// The text of the definition and of every definition it uses (name -> text).
  const std::map<std::string, std::string>& texts() const { return texts_; }
  const msg_mapping::Codec& codec() const { return *codec_; }

 private:
  std::string ln_name_, ln_hash_, ros_type_, schema_;
  std::size_t packet_size_ = 0;
  bool dynamic_ = false;
  std::map<std::string, std::string> texts_;
  std::unique_ptr<msg_mapping::Codec> codec_;
};

}  // namespace ln_bag
