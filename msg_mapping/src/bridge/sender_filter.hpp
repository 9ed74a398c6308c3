// Loop prevention per ROS publisher: which sender's messages a ROS -> LN path
// forwards. Messages of bridge publishers (this bridge's and other bridges':
// their node names match the bridge patterns) came from LN and must not go
// back; every other publisher's are forwarded, also on the same topic.
//
// Every rmw puts the sending publisher's gid in the message info, and the ROS
// graph maps that gid to the publisher's node (rcl_get_publishers_info_by_topic).
// A message from a publisher the graph has not placed yet (discovery still
// running) is held -- the newest `hold` per publisher -- until the graph names
// its node, or for at most `pending` seconds, after which the publisher counts
// as a non-bridge: a plain DDS participant never gets a node name.
//
// Pure logic: time and graph snapshots are passed in, so messages can be
// decided where they are taken while the graph is asked elsewhere. Not
// thread-safe: the path serialises the calls.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace msg_mapping::bridge {

using Gid = std::array<std::uint8_t, 16>;

struct Endpoint {
  Gid gid{};
  std::string node;  ///< fully qualified node name, "" when the graph does not know it (yet)
};

/// A message kept until its sender is known.
struct HeldMessage {
  std::vector<std::uint8_t> cdr;
  std::int64_t source_timestamp = 0;
};

class SenderFilter {
 public:
  enum class Decision { Forward, Drop, Hold };
  using IsBridge = std::function<bool(const std::string& node)>;

  SenderFilter(IsBridge is_bridge, std::size_t hold, double pending = 2.0);

  /// What to do with a message of `gid`, by what the graph said so far: an
  /// unknown sender's messages are held (see hold()). Drop counts in dropped().
  Decision decide(const Gid& gid);
  /// Keeps a message whose decision was Hold (the oldest of its sender goes
  /// when `hold` are kept).
  void hold(const Gid& gid, HeldMessage message, double now);
  /// Learns the nodes of a topic's publishers from a graph snapshot; with
  /// `forget_departed`, senders missing from it are forgotten.
  void learn(const std::vector<Endpoint>& publishers, bool forget_departed);
  /// Held messages that can go now, in order: their senders were placed
  /// meanwhile or waited `pending` seconds.
  std::vector<HeldMessage> release(double now);

  bool has_held() const { return !held_.empty(); }
  std::size_t held_count() const;
  bool is_bridge(const Gid& gid) const;
  /// Messages not forwarded because a bridge sent them.
  std::uint64_t dropped() const { return dropped_; }
  /// Senders forwarded after `pending` seconds without a node (taken once).
  std::vector<Gid> take_nodeless();

 private:
  struct Held {
    double first_seen = 0;
    std::deque<HeldMessage> messages;
  };

  IsBridge is_bridge_;
  std::size_t hold_;
  double pending_;
  std::map<Gid, bool> verdicts_;  ///< true: forward, false: a bridge's
  std::map<Gid, Held> held_;
  std::vector<Gid> nodeless_;
  std::uint64_t dropped_ = 0;
};

/// fnmatch(3) of the node's last path component against any of `patterns`
/// (the bridge configuration's loop_prevention.bridge_names).
bool matches_any(const std::string& node, const std::vector<std::string>& patterns);

}  // namespace msg_mapping::bridge
