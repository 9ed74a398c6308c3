// Mapping rules: an LN definition mapped onto an *existing* ROS type field by
// field, instead of generating a ROS type for it (README: "Rules").
//
//   - ln: robot/tcp_pose                       # LN definition (fixed-size)
//     ros: geometry_msgs/msg/PoseStamped       # existing ROS message type
//     fields:
//       header.stamp: {from: time, convert: seconds_to_time}
//       header.frame_id: {value: map}
//       pose.position.x: {from: "pos_mm[0]", scale: 0.001}
//       pose.orientation: ...                  # leaves only, see below
//
// Each rule targets a ROS leaf: a number (also one element "a[2]" of a fixed
// array), a whole numeric array/sequence (from an LN array), a string (from
// an LN char array or a constant), a whole array/sequence of strings, or a
// builtin_interfaces Time/Duration (convert: seconds_to_time from an LN number
// of seconds, nanoseconds_to_time from an LN integer of nanoseconds). A path
// through an LN array of sub-types without an index, "joints.name", reads that
// field of every element: one number, or one text (char array), per element of
// the ROS array -- so sensor_msgs/msg/JointState keeps its joint names. `scale`/`offset` apply ros = ln * scale
// + offset (and the inverse from ROS to LN). Numeric conversions that can lose
// information (float -> int, narrowing, float64 -> float32, scaling into an
// integer) need `lossy: true`. ROS fields without a rule are zero/empty; ROS
// constants set by rules are ignored from ROS to LN.
//
// Conversion goes through the fixed-size LN form of the ROS type (RosToLn),
// whose compiled Codec produces the CDR; so the default capacities apply to
// unmapped strings/sequences received from ROS (configurable there).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ln/md/message_definition.hpp"
#include "msg_mapping/codec.hpp"
#include "msg_mapping/ros_to_ln.hpp"

namespace msg_mapping {

struct FieldRule {
  std::string ros_path;  ///< "pose.position.x", "covariance", "covariance[3]", "header.stamp"
  std::string ln_path;   ///< "pos_mm[0]", "cov", "sub.x"; empty with a constant
  bool has_constant = false;
  std::string constant;       ///< number or text
  std::string scale, offset;  ///< decimal numbers, empty: none
  std::string convert;        ///< "", "seconds_to_time", "nanoseconds_to_time"
  bool lossy = false;
};

struct RuleMove;  // rules.cpp

class RuleCodec {
 public:
  /// Validates and compiles the rules. Throws Error naming the LN definition,
  /// the ROS type and the field.
  RuleCodec(const ln::md::Definition& ln, RosToLn& ros, const std::string& ros_type,
            const std::vector<FieldRule>& rules);
  ~RuleCodec();
  RuleCodec(RuleCodec&&) noexcept;
  RuleCodec& operator=(RuleCodec&&) noexcept;

  const std::string& ln_name() const { return ln_name_; }
  const std::string& ros_name() const { return ros_name_; }
  std::size_t ln_size() const { return ln_size_; }

  /// LN packet -> CDR (header included). Throws CodecError.
  std::vector<std::uint8_t> ln_to_cdr(Bytes ln) const;
  /// CDR -> LN packet. Throws CodecError.
  std::vector<std::uint8_t> cdr_to_ln(Bytes cdr) const;

  std::string describe() const;

 private:
  std::string ln_name_, ros_name_;
  std::size_t ln_size_ = 0;
  std::size_t mid_size_ = 0;
  std::unique_ptr<Codec> mid_codec_;  ///< the ROS type's fixed-size LN form <-> CDR
  std::vector<RuleMove> moves_;
};

}  // namespace msg_mapping
