// Records LN topics into an McapWriter: one thread reads every subscription
// zero-copy (ln_read_borrow), converts each packet to CDR straight into the
// current chunk and hands full chunks to the writer's I/O thread.
//
// The thread drains all subscriptions, then either sleeps on a multi-waiter
// until a packet arrives or, while data flows, for a short batch interval,
// so the cost per message stays a borrow, a conversion and an index entry
// however many topics there are. Subscriptions are sized to hold a few
// hundred milliseconds of traffic (see RecorderOptions), which covers the
// batch interval and the writer's queue stalls many times over; anything
// still lost in transport is counted per topic from the LN sample info.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ln_bag/mcap_writer.hpp"
#include "ln_bag/topic_mapping.hpp"

namespace ln_bag {

struct RecorderOptions {
  /// The LN manager ("HOST:PORT") and this recorder's client name.
  std::string manager;
  std::string client_name = "ln_record";
  /// Stop after this many messages in total (0: no limit).
  std::uint64_t max_messages = 0;
  /// Stop this many seconds after start() (0: no limit).
  double max_seconds = 0;
  /// While messages flow, sleep this long between draining rounds.
  double batch_seconds = 0.002;
  /// Close a chunk that is older than this, so a slow topic reaches the disk.
  double chunk_seconds = 1.0;
};

struct TopicStats {
  std::string topic;
  std::uint16_t channel_id = 0;
  std::uint64_t messages = 0;
  std::uint64_t bytes = 0;  ///< CDR bytes recorded
  std::uint64_t lost = 0;   ///< published but never received (LN sample info)
  unsigned buffers = 0;     ///< subscription buffers
  std::string error;        ///< why the topic stopped being recorded, if it did
};

class Recorder {
 public:
  /// Connects to the manager (throws BagError). `writer` must outlive the
  /// recorder and is used only by the recording thread while it runs.
  Recorder(McapWriter& writer, RecorderOptions options);
  /// stop()s.
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// Subscribes `topic` (LN definition pinned to the mapping's hash) with
  /// `buffers` slots and adds its channel (schema per ROS type, once) with
  /// `metadata`. Runs in the recording thread once it runs; returns the
  /// channel id or throws BagError (e.g. the topic's definition changed).
  std::uint16_t add_topic(const std::string& topic, const std::string& ros_topic, const TopicMapping& mapping,
                          const std::map<std::string, std::string>& metadata, unsigned buffers);

  /// Adds a channel that is not a subscription (e.g. service calls, see
  /// post_message()); the schema once per ROS type. Returns its id.
  std::uint16_t add_channel(const std::string& ros_topic, const TopicMapping& mapping,
                            const std::map<std::string, std::string>& metadata);
  /// Queues a message of a channel of add_channel() for the recording thread
  /// (which owns the writer); returns at once.
  void post_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                    std::uint64_t publish_time, std::string data);

  /// Starts the recording thread.
  void start();
  /// Waits up to `timeout` seconds (< 0: without limit) for the recording to
  /// end by itself (message count, duration, an error); true if it did.
  bool wait(double timeout);
  /// Ends the recording; the current chunk goes to the writer. Idempotent.
  void stop();
  /// Why the recording ended early ("" if it did not): the writer's error.
  std::string error() const;
  std::vector<TopicStats> stats() const;
  std::uint64_t messages() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ln_bag
