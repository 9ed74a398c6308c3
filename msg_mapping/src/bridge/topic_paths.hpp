// ln_ros2_bridge's per-message data path, in compiled code next to the codecs:
//
//   LN -> ROS:  LN read (zero-copy on ln_core) -> codec -> rcl_publish_serialized_message
//   ROS -> LN:  rcl_take_serialized_message (with the publisher's gid) -> loop
//               prevention -> codec -> ln_write
//
// Each path runs its own thread that never touches Python; the bridge's Python
// side (configuration, discovery, services) makes and closes paths and reads
// their reports. LN calls go through LnApi (the libln the Python side loaded),
// rcl calls through RclApi (rclpy's librcl).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bridge/ln_api.hpp"
#include "bridge/rcl_api.hpp"
#include "bridge/sender_filter.hpp"
#include "msg_mapping/codec.hpp"
#include "msg_mapping/rules.hpp"

namespace msg_mapping::bridge {

/// LN packet <-> CDR for one topic: a generated or derived type's Codec, or a
/// RuleCodec (an LN definition mapped onto a standard ROS type). Does not own
/// the codec.
class TopicCodec {
 public:
  explicit TopicCodec(const Codec& codec) : codec_(&codec) {}
  explicit TopicCodec(const RuleCodec& rule) : rule_(&rule) {}

  std::size_t ln_size() const { return codec_ ? codec_->fixed_ln_size() : rule_->ln_size(); }
  /// LN packet -> CDR in `out` (grown as needed); returns the CDR size.
  std::size_t to_cdr(Bytes ln, std::vector<std::uint8_t>& out) const;
  /// CDR -> the LN packet (exactly ln_size() bytes).
  void to_ln(Bytes cdr, MutableBytes packet) const;

 private:
  const Codec* codec_ = nullptr;
  const RuleCodec* rule_ = nullptr;
};

/// What a path did since it started; `errors_text` and `nodeless` since the
/// previous report.
struct PathReport {
  std::uint64_t received = 0;   ///< packets read from LN / messages taken from ROS
  std::uint64_t forwarded = 0;  ///< published on ROS / written to LN
  std::uint64_t errors = 0;     ///< not forwarded: conversion or publish failed
  std::uint64_t lost = 0;       ///< LN: skipped by the port (ln_core); ROS: gaps in a publisher's sequence
  std::uint64_t ignored = 0;    ///< ROS -> LN: sent by bridge publishers (loop prevention)
  std::uint64_t held = 0;       ///< ROS -> LN: waiting for the graph to name their publisher
  std::uint64_t error_count_in_text = 0;  ///< errors since the previous report
  std::string errors_text;      ///< the newest error since the previous report
  std::vector<std::string> nodeless;  ///< gids (hex) of publishers forwarded without a node
  bool failed = false;          ///< the thread stopped (LN connection lost, ...)
  std::string failure;
};

/// Counters and texts shared by a path's thread and its reader.
class PathState {
 public:
  std::atomic<std::uint64_t> received{0}, forwarded{0}, errors{0}, lost{0}, ignored{0}, held{0};
  void error(const std::string& text);
  void fail(const std::string& text);
  void nodeless(const std::string& gid_hex);
  bool failed() const { return failed_.load(); }
  PathReport report();

 private:
  std::mutex mutex_;
  std::uint64_t new_errors_ = 0;
  std::string last_error_, failure_;
  std::vector<std::string> nodeless_;
  std::atomic<bool> failed_{false};
};

/// An LN client handle for the data path: the Python side's own (ln_core
/// exposes its handle) or one opened here (LN 2.9's Python API does not).
class LnClient {
 public:
  /// Uses a client owned elsewhere.
  LnClient(const LnApi& api, ln_client handle);
  /// Connects a client of its own (closed by the destructor). Throws.
  LnClient(const LnApi& api, const std::string& name, const std::string& manager);
  ~LnClient();
  LnClient(const LnClient&) = delete;
  LnClient& operator=(const LnClient&) = delete;

  const LnApi& api() const { return api_; }
  ln_client handle() const { return handle_; }
  std::string name() const;
  void close();

 private:
  const LnApi& api_;
  ln_client handle_ = nullptr;
  bool owned_ = false;
};

struct LnPortOptions {
  double rate = -1;
  unsigned int buffers = 1;
  bool reliable_transport = false;
};

/// An LN subscription republished on an rcl publisher (made by rclpy; it must
/// outlive the path).
class LnToRosPath {
 public:
  LnToRosPath(const LnClient& client, const std::string& topic, const std::string& md_name,
              const LnPortOptions& options, TopicCodec codec, rcl_publisher_t* publisher);
  ~LnToRosPath();
  LnToRosPath(const LnToRosPath&) = delete;
  LnToRosPath& operator=(const LnToRosPath&) = delete;

  /// Stops the thread and unsubscribes; idempotent.
  void close();
  PathReport report() { return state_.report(); }

 private:
  void run();

  const LnApi& ln_;
  const RclApi& rcl_;
  TopicCodec codec_;
  rcl_publisher_t* publisher_;
  ln_inport port_ = nullptr;
  std::size_t size_ = 0;
  std::atomic<bool> stop_{false};
  PathState state_;
  std::thread thread_;
};

/// ROS QoS of a subscription, by the configuration's names.
struct RosQos {
  std::string reliability = "reliable";  ///< reliable | best_effort | best_available
  std::string durability = "volatile";   ///< volatile | transient_local | best_available
  std::string history = "keep_last";     ///< keep_last | keep_all
  std::size_t depth = 10;
};

/// An rcl subscription (made here, so no rclpy executor takes from it)
/// written into an LN topic this path publishes.
class RosToLnPath {
 public:
  /// `node` is rclpy's rcl node (it must outlive the path), `type_support` the
  /// message type's rosidl_message_type_support_t. `bridge_names`: fnmatch
  /// patterns of bridge node names, whose messages are not forwarded.
  RosToLnPath(const LnClient& client, const std::string& topic, const std::string& md_name, unsigned int buffers,
              TopicCodec codec, rcl_node_t* node, const rosidl_message_type_support_t* type_support,
              const std::string& ros_topic, const RosQos& qos, std::vector<std::string> bridge_names);
  ~RosToLnPath();
  RosToLnPath(const RosToLnPath&) = delete;
  RosToLnPath& operator=(const RosToLnPath&) = delete;

  void close();
  PathReport report() { return state_.report(); }
  /// The fully qualified ROS topic (after the node's namespace and remapping).
  const std::string& ros_topic() const { return ros_topic_; }

 private:
  static void on_new_message(const void* self, std::size_t count);
  void run();
  void process(const std::uint8_t* cdr, std::size_t size, const rmw_message_info_t& info);
  void write(const std::uint8_t* cdr, std::size_t size, std::int64_t source_timestamp);
  std::vector<Endpoint> publishers() const;

  const LnApi& ln_;
  const RclApi& rcl_;
  TopicCodec codec_;
  rcl_node_t* node_;
  rcl_subscription_t subscription_;
  std::string ros_topic_;
  ln_outport port_ = nullptr;
  std::vector<std::uint8_t> packet_;
  std::vector<std::string> bridge_names_;
  SenderFilter senders_;
  std::map<Gid, std::uint64_t> last_sequence_;
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  std::size_t unread_ = 0;  ///< guarded by wake_mutex_
  std::atomic<bool> stop_{false};
  PathState state_;
  std::thread thread_;
};

}  // namespace msg_mapping::bridge
