// Loop prevention per ROS publisher: which sender's messages a ROS -> LN path
// forwards. Messages of bridge publishers (this bridge's and other bridges':
// their node names match the bridge patterns) came from LN and must not go
// back; every other publisher's are forwarded, also on the same topic.
//
// Every rmw puts the sending publisher's gid in the message info, and the ROS
// graph maps that gid to the publisher's node (rcl_get_publishers_info_by_topic).
// A message from a publisher the graph does not place yet (discovery still
// running) is held -- the newest `hold` per publisher -- until the graph names
// its node, or for at most `pending` seconds, after which the publisher counts
// as a non-bridge: a plain DDS participant never gets a node name.
//
// Pure logic (time is passed in, the graph is a function), not thread-safe:
// one path's worker thread owns it.
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
  using Lookup = std::function<std::vector<Endpoint>()>;
  using IsBridge = std::function<bool(const std::string& node)>;

  SenderFilter(Lookup lookup, IsBridge is_bridge, std::size_t hold, double pending = 2.0,
               double lookup_interval = 0.05);

  /// What to do with a message of `gid` now; an unknown sender makes the graph
  /// be asked (at most every lookup_interval). Drop counts in dropped().
  Decision decide(const Gid& gid, double now);
  /// Keeps a message whose decision was Hold (the oldest of its sender goes
  /// when `hold` are kept).
  void hold(const Gid& gid, HeldMessage message, double now);
  /// Held messages that can go now, in order: their senders were placed
  /// meanwhile or waited `pending` seconds. `refresh` asks the graph again and
  /// forgets senders that left it.
  std::vector<HeldMessage> release(double now, bool refresh);

  bool has_held() const { return !held_.empty(); }
  std::size_t held_count() const;
  bool is_bridge(const Gid& gid) const;
  /// Messages not forwarded because a bridge sent them.
  std::uint64_t dropped() const { return dropped_; }
  /// Senders forwarded after `pending` seconds without a node (taken once).
  std::vector<Gid> take_nodeless();

 private:
  void classify(double now, bool force, std::vector<Endpoint>* seen = nullptr);

  struct Held {
    double first_seen = 0;
    std::deque<HeldMessage> messages;
  };

  Lookup lookup_;
  IsBridge is_bridge_;
  std::size_t hold_;
  double pending_, lookup_interval_;
  double looked_up_at_ = -1e300;
  std::map<Gid, bool> verdicts_;  ///< true: forward, false: a bridge's
  std::map<Gid, Held> held_;
  std::vector<Gid> nodeless_;
  std::uint64_t dropped_ = 0;
};

/// fnmatch(3) of the node's last path component against any of `patterns`
/// (the bridge configuration's loop_prevention.bridge_names).
bool matches_any(const std::string& node, const std::vector<std::string>& patterns);

}  // namespace msg_mapping::bridge
