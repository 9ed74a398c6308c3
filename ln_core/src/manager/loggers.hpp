// Topic loggers (methods.hpp logger_*; ln.h ln_logger_*): named recordings
// that the manager makes and keeps. The rules follow LN 2.9 as observed by
// running it:
// * a logger is a name known to the manager from its first enable on, for
//   every client; it records at the publisher's side (recorder.hpp) and is
//   not a subscriber (has_subscriber, ln topic list);
// * enable starts a new recording of the listed topics (earlier samples are
//   dropped), each a ring of log_size samples, every divisor-th packet
//   counted from enable (the divisor-th is the first), only the sample
//   headers with only_ts; a topic without a publisher is recorded from the
//   moment one is ready;
// * disable keeps the packets written before it; download can be repeated
//   and gives the topics in the logger's order.
// Where ln_core differs on purpose (LN 2.9 loses or refuses data there; see
// README): the recording outlives its publisher and goes on with the next
// one; loggers of the same topic record independently; download works while
// enabled (a snapshot); only_ts downloads work (sample size 20).
//
// Everything here runs in the manager's loop thread, except the two worker
// threads: one attaches to publishers' segments (open_segment may wait for
// the publisher), one writes manager_save files; their results come back
// through `post`, and the requests that wait for them are answered then.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "manager/definitions.hpp"
#include "manager/log.hpp"
#include "manager/log_files.hpp"
#include "manager/recorder.hpp"
#include "manager/registry.hpp"
#include "protocol/wire.hpp"

namespace ln::manager {

class Loggers {
 public:
  using Task = std::function<void(Outbox&)>;
  /// Runs a task in the loop thread soon and delivers what it put in the outbox.
  using Post = std::function<void(Task)>;

  Loggers(Registry& registry, DefinitionStore& definitions, Post post, LogFunction log);
  ~Loggers();
  Loggers(const Loggers&) = delete;
  Loggers& operator=(const Loggers&) = delete;

  /// True for the logger_* methods.
  static bool handles(std::string_view method);
  /// A logger_* request of `client`: the response, or nullopt when it is
  /// sent later (as a message to `client` through `post`). Throws
  /// RequestError and ProtocolError like the dispatcher's handlers.
  std::optional<protocol::Message> handle(Id client, const protocol::Message& request, Outbox& out);
  /// A publisher of `topic` announced its segment: taps of the topic read it.
  void publisher_ready(const Topic& topic, Outbox& out);

  const Recorder& recorder() const { return recorder_; }

 private:
  struct LoggedTopic {
    std::string name;
    std::uint64_t log_size = 1;
    std::uint32_t divisor = 1;
    Id tap = 0;                             ///< registry tap while enabled
    std::shared_ptr<SampleLog> log;         ///< null until the message size is known
    SavedTopic seen;                        ///< what is known of the topic (definition, publisher)
    std::string reading_socket;             ///< the publisher whose segment is read or asked for ...
    std::int64_t reading_generation = -1;   ///< ... the generation asked for ...
    std::int64_t attached_generation = -1;  ///< ... and the newest one attached (answers may
                                            ///< come late, or two asks get the same segment)
  };
  struct Logger {
    std::string name;
    bool only_ts = false;
    bool enabled = false;
    std::uint64_t recording = 0;  ///< numbers the enables, so late results of an old one are dropped
    std::vector<LoggedTopic> topics;
  };
  struct PendingAnswer {
    Id client;
    protocol::Message request;
    std::size_t waiting_for = 0;
    std::vector<std::string> problems;
  };
  struct Download {
    std::int64_t id = 0;
    std::vector<std::shared_ptr<const SampleLog>> views;
  };
  class Worker;

  protocol::Message enable(Id client, const protocol::Message& request, Outbox& out, bool& deferred);
  protocol::Message disable(const protocol::Message& request, Outbox& out);
  protocol::Message download(Id client, const protocol::Message& request);
  protocol::Message download_data(Id client, const protocol::Message& request);
  void manager_save(Id client, const protocol::Message& request);

  Logger& existing(const std::string& name);
  void stop(Logger& logger, Outbox& out);
  /// The recording as it is now: a frozen copy of an enabled topic's log.
  std::shared_ptr<const SampleLog> view_of(const LoggedTopic& topic);
  /// Learns the topic's definition from the registry (log, columns, text).
  void learn_definition(Logger& logger, LoggedTopic& topic, const Topic& known, Outbox& out);
  /// Starts reading the topic's ready publisher unless it is read already;
  /// returns false if there is nothing to do. The result comes back to
  /// finish_attach; `answer` (if any) waits for it.
  bool attach(Logger& logger, LoggedTopic& topic, const Topic& known, std::uint64_t answer);
  void finish_attach(const std::string& logger, std::uint64_t recording, Id tap, const std::string& peer_socket,
                     std::int64_t generation, std::shared_ptr<transport::ShmReader> reader, std::uint32_t window,
                     const std::string& problem, std::uint64_t answer, Outbox& out);
  void answered_part(std::uint64_t answer, const std::string& problem, Outbox& out);

  Registry& registry_;
  DefinitionStore& definitions_;
  Post post_;
  LogFunction log_;
  Recorder recorder_;
  std::map<std::string, Logger> loggers_;
  std::map<std::uint64_t, PendingAnswer> pending_;
  std::uint64_t last_answer_ = 0;
  std::map<Id, Download> downloads_;  ///< by client
  std::int64_t last_download_ = 0;
  /// Set when the manager stops: a running manager_save conversion is stopped.
  std::shared_ptr<std::atomic<bool>> closing_ = std::make_shared<std::atomic<bool>>(false);
  std::unique_ptr<Worker> attacher_;  // last members: their threads stop first
  std::unique_ptr<Worker> saver_;
};

}  // namespace ln::manager
