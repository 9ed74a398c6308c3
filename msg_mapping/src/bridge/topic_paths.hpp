// ln_ros2_bridge's per-message data path, in compiled code next to the codecs:
//
//   LN -> ROS:  LN read (zero-copy on ln_core) -> codec -> rcl_publish_serialized_message
//   ROS -> LN:  rcl_take_serialized_message (with the publisher's gid) -> loop
//               prevention -> codec -> ln_write
//
// Messages move in threads that never touch Python (a shared LN reader, the
// middleware's receiving threads, a thread per large-packet path); the bridge's
// Python side (configuration, discovery, services) makes and closes paths and
// reads their reports. LN calls go through LnApi (the libln the Python side
// loaded), rcl calls through RclApi (rclpy's librcl).
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
  std::uint64_t received = 0;             ///< packets read from LN / messages taken from ROS
  std::uint64_t forwarded = 0;            ///< published on ROS / written to LN
  std::uint64_t errors = 0;               ///< not forwarded: conversion or publish failed
  std::uint64_t lost = 0;                 ///< LN: skipped by the port (ln_core); ROS: gaps in a publisher's sequence
  std::uint64_t ignored = 0;              ///< ROS -> LN: sent by bridge publishers (loop prevention)
  std::uint64_t held = 0;                 ///< ROS -> LN: waiting for the graph to name their publisher
  std::uint64_t error_count_in_text = 0;  ///< errors since the previous report
  std::string errors_text;                ///< the newest error since the previous report
  std::vector<std::string> nodeless;      ///< gids (hex) of publishers forwarded without a node
  bool failed = false;                    ///< the thread stopped (LN connection lost, ...)
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

class LnReaderGroup;
class LnToRosPath;

/// An LN client handle for the data path: the Python side's own (ln_core
/// exposes its handle) or one opened here (LN 2.9's Python API does not).
/// It also runs the reader shared by the LN -> ROS paths of small packets.
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
  /// Stops the shared reader (its paths must be closed) and closes an own client.
  void close();
  /// The reader shared by LN -> ROS paths (started at first use).
  LnReaderGroup& readers();

 private:
  const LnApi& api_;
  ln_client handle_ = nullptr;
  bool owned_ = false;
  std::mutex readers_mutex_;
  std::unique_ptr<LnReaderGroup> readers_;
};

struct LnPortOptions {
  double rate = -1;
  unsigned int buffers = 1;
  bool reliable_transport = false;
};

/// An LN subscription republished on an rcl publisher (made by rclpy; it must
/// outlive the path).
///
/// Paths of small packets share one reader thread per LN client, which sleeps
/// on all their ports at once (an LN multi-waiter): the topics of one control
/// loop, written in one go, cost one wake-up together rather than one each --
/// on a VM the wake-up is most of a message's cost. A path of packets from
/// `own_thread_above` bytes (images) reads in a thread of its own, so its
/// copies never delay the small ones.
class LnToRosPath {
 public:
  static constexpr std::size_t own_thread_above = 64 * 1024;

  LnToRosPath(LnClient& client, const std::string& topic, const std::string& md_name, const LnPortOptions& options,
              TopicCodec codec, rcl_publisher_t* publisher);
  ~LnToRosPath();
  LnToRosPath(const LnToRosPath&) = delete;
  LnToRosPath& operator=(const LnToRosPath&) = delete;

  /// Stops reading and unsubscribes; idempotent.
  void close();
  PathReport report() { return state_.report(); }

 private:
  friend class LnReaderGroup;
  void run();
  /// Publishes the packets the port has, waiting up to `timeout` s for the
  /// first; false when the path cannot go on (it is marked failed then).
  bool pump(double timeout);

  const LnApi& ln_;
  const RclApi& rcl_;
  TopicCodec codec_;
  rcl_publisher_t* publisher_;
  LnReaderGroup* group_ = nullptr;  ///< the shared reader, or nullptr: thread_
  ln_inport port_ = nullptr;
  std::size_t size_ = 0;
  std::vector<std::uint8_t> packet_, cdr_;
  std::atomic<bool> stop_{false};
  PathState state_;
  std::thread thread_;
};

/// One thread reading the ports of many LN -> ROS paths through an LN
/// multi-waiter. Ports are added and removed by the thread itself (the
/// multi-waiter belongs to it); add() and remove() return once it did.
class LnReaderGroup {
 public:
  LnReaderGroup(const LnApi& api, ln_client client);
  ~LnReaderGroup();
  LnReaderGroup(const LnReaderGroup&) = delete;
  LnReaderGroup& operator=(const LnReaderGroup&) = delete;

  void add(LnToRosPath* path);
  void remove(LnToRosPath* path);

 private:
  void run();
  void request(LnToRosPath* path, bool add);

  const LnApi& api_;
  ln_client client_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::pair<LnToRosPath*, bool>> requests_;  ///< (path, add?), guarded by mutex_
  std::uint64_t requested_ = 0, applied_ = 0;            ///< guarded by mutex_
  std::string failure_;                                  ///< the multi-waiter could not be made
  bool stop_ = false;                                    ///< guarded by mutex_
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
///
/// Messages are taken in the middleware's new-message callback, in the thread
/// that received them: a hand-over to a thread of our own would cost one more
/// wake-up per message, the biggest cost there is. Only that callback takes
/// (the middleware calls it with its reader's locks held, so a take from
/// another thread under our lock could deadlock), and it never asks the ROS
/// graph who a new publisher is: such messages are held for the path's own
/// thread, which asks and releases them.
class RosToLnPath {
 public:
  /// `node` is rclpy's rcl node (it must outlive the path), `type_support` the
  /// message type's rosidl_message_type_support_t. `bridge_names`: fnmatch
  /// patterns of bridge node names, whose messages are not forwarded.
  RosToLnPath(LnClient& client, const std::string& topic, const std::string& md_name, unsigned int buffers,
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
  /// Takes every message there is and forwards, holds or drops each (take_mutex_ held).
  void drain();
  void process(const std::uint8_t* cdr, std::size_t size, const rmw_message_info_t& info);
  void write(const std::uint8_t* cdr, std::size_t size, std::int64_t source_timestamp);
  std::vector<Endpoint> publishers() const;
  void wake();
  void release_buffer();

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
  std::mutex take_mutex_;  ///< the subscription, senders_, packet_, message_: callback and thread
  rcl_serialized_message_t message_{};
  std::mutex wake_mutex_;
  std::condition_variable wake_;
  bool wake_flag_ = false;                 ///< guarded by wake_mutex_
  std::atomic<bool> senders_held_{false};  ///< messages wait for the graph: the thread looks more often
  std::atomic<bool> stop_{false};
  PathState state_;
  std::thread thread_;
};

}  // namespace msg_mapping::bridge
