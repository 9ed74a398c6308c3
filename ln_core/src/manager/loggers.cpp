#include "manager/loggers.hpp"

#include <algorithm>
#include <charconv>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <set>
#include <thread>

#include "manager/names.hpp"
#include "manager/request_error.hpp"
#include "protocol/logger_samples.hpp"
#include "protocol/methods.hpp"

namespace ln::manager {
namespace {

namespace method = protocol::method;
using protocol::Message;
using protocol::StringList;
using protocol::logger::kSampleHeaderSize;

/// How long attaching to a publisher may take: it holds open_segment until
/// it counted the tap (about a round trip to the manager, 0.5 s at most).
constexpr std::chrono::milliseconds kAttachTimeout{3000};
constexpr std::size_t kMaxLoggerName = 255;

template <typename Number>
Number parse_decimal(const std::string& text, const char* what, const std::string& topic) {
  Number value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size())
    throw RequestError(LNE_INVALID_PARAMETER,
                       std::string(what) + " of topic '" + topic + "' is not a number in " + "range: '" + text + "'");
  return value;
}

/// The registry's topic of that name, or nullptr (a topic exists while it is
/// published or subscribed).
const Topic* known_topic(const Registry& registry, const std::string& name) {
  for (const auto& entry : registry.topics())
    if (entry.second.name == name) return &entry.second;
  return nullptr;
}

std::string label(const std::string& logger, const std::string& topic) {
  return "logger '" + logger + "', topic '" + topic + "'";
}

}  // namespace

/// One thread running jobs in order; jobs queued at destruction are dropped,
/// a running one finishes first.
class Loggers::Worker {
 public:
  Worker() : thread_([this] { run(); }) {}
  ~Worker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      jobs_.clear();
    }
    wake_.notify_all();
    thread_.join();
  }
  void add(std::function<void()> job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back(std::move(job));
    }
    wake_.notify_all();
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (stopping_) return;
      std::function<void()> job = std::move(jobs_.front());
      jobs_.pop_front();
      lock.unlock();
      job();
      lock.lock();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::thread thread_;
};

Loggers::Loggers(Registry& registry, DefinitionStore& definitions, Post post, LogFunction log)
    : registry_(registry),
      definitions_(definitions),
      post_(std::move(post)),
      log_(log),
      recorder_(log),
      attacher_(std::make_unique<Worker>()),
      saver_(std::make_unique<Worker>()) {}

Loggers::~Loggers() {
  closing_->store(true);
  saver_.reset();
  attacher_.reset();
}

bool Loggers::handles(std::string_view name) {
  return name == method::logger_enable || name == method::logger_disable || name == method::logger_download ||
         name == method::logger_download_data || name == method::logger_manager_save;
}

std::optional<Message> Loggers::handle(Id client, const Message& request, Outbox& out) {
  const std::string name = request.get_string("method");
  if (name == method::logger_enable) {
    bool deferred = false;
    Message answer = enable(client, request, out, deferred);
    if (deferred) return std::nullopt;
    return answer;
  }
  if (name == method::logger_disable) return disable(request, out);
  if (name == method::logger_download) return download(client, request);
  if (name == method::logger_download_data) return download_data(client, request);
  manager_save(client, request);
  return std::nullopt;
}

Loggers::Logger& Loggers::existing(const std::string& name) {
  const auto it = loggers_.find(name);
  if (it == loggers_.end())
    throw RequestError(LNE_REQUEST_FAILED, "logger '" + name +
                                               "' does not exist: the manager knows a logger from "
                                               "its first enable on");
  return it->second;
}

// ------------------------------------------------------------------ enable

Message Loggers::enable(Id client, const Message& request, Outbox& out, bool& deferred) {
  const std::string name = request.get_string("name");
  if (name.empty() || name.size() > kMaxLoggerName)
    throw RequestError(LNE_INVALID_PARAMETER, "a logger name must have 1 to 255 characters");
  const StringList& names = request.get_list("topics");
  const StringList& sizes = request.get_list("log_sizes");
  const StringList& divisors = request.get_list("divisors");
  if (sizes.size() != names.size() || divisors.size() != names.size())
    throw RequestError(LNE_INVALID_PARAMETER, "logger_enable needs as many log_sizes and divisors as topics");
  if (names.empty()) throw RequestError(LNE_NO_LOGGER_TOPICS, "logger '" + name + "' has no topics to record");
  const bool only_ts = request.get_bool_or("only_ts", false);

  // The new topic list, checked completely before anything changes.
  std::vector<LoggedTopic> topics;
  std::uint64_t known_bytes = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (auto problem = topic_name_problem(names[i])) throw RequestError(LNE_INVALID_PARAMETER, *problem);
    LoggedTopic topic;
    topic.name = names[i];
    topic.log_size = parse_decimal<std::uint64_t>(sizes[i], "the log size", topic.name);
    topic.divisor = parse_decimal<std::uint32_t>(divisors[i], "the divisor", topic.name);
    if (topic.log_size == 0)
      throw RequestError(LNE_INVALID_PARAMETER, label(name, topic.name) + ": the log size must be at least 1 sample");
    auto same = std::find_if(topics.begin(), topics.end(), [&](const LoggedTopic& t) { return t.name == topic.name; });
    if (same != topics.end()) topics.erase(same);  // named twice: the later settings count
    topics.push_back(std::move(topic));
  }
  for (const LoggedTopic& topic : topics) {
    const Topic* known = known_topic(registry_, topic.name);
    // A topic not known yet gets its log when it appears; it needs the sample headers at least.
    if (known == nullptr) {
      check_log_fits(topic.log_size, kSampleHeaderSize, label(name, topic.name));
      continue;
    }
    const std::uint64_t sample = kSampleHeaderSize + (only_ts ? 0 : known->message_size);
    check_log_fits(topic.log_size, sample, label(name, topic.name));
    const std::uint64_t bytes = topic.log_size * sample;
    if (known_bytes > std::numeric_limits<std::uint64_t>::max() - bytes)
      check_log_fits(2, std::numeric_limits<std::uint64_t>::max() / 2, "logger '" + name + "'");
    known_bytes += bytes;
  }
  check_log_fits(1, known_bytes, "logger '" + name + "' (all its topics)");

  Logger& logger = loggers_[name];
  logger.name = name;
  if (logger.enabled) stop(logger, out);
  logger.topics = std::move(topics);
  logger.only_ts = only_ts;
  logger.enabled = true;
  ++logger.recording;

  const std::uint64_t answer = ++last_answer_;
  PendingAnswer& pending = pending_[answer];
  pending.client = client;
  pending.request = request;
  try {
    for (LoggedTopic& topic : logger.topics) {
      const Topic* known = known_topic(registry_, topic.name);
      topic.tap = registry_.add_tap(
          topic.name, known != nullptr ? tap_slots(static_cast<std::uint64_t>(known->message_size)) : kMinTapSlots,
          out);
      if (known == nullptr) continue;
      learn_definition(logger, topic, *known, out);
      if (attach(logger, topic, *known, answer)) ++pending.waiting_for;
    }
  } catch (...) {
    pending_.erase(answer);
    stop(logger, out);
    throw;
  }
  if (pending.waiting_for > 0) {
    deferred = true;
    return Message();
  }
  pending_.erase(answer);
  return Message::response_to(request);
}

void Loggers::learn_definition(Logger& logger, LoggedTopic& topic, const Topic& known, Outbox& out) {
  if (topic.seen.md_hash == known.hash && topic.log) return;
  const md::Definition& definition = definitions_.resolve(known.definition + "|" + known.hash);
  topic.seen.name = topic.name;
  topic.seen.md_name = known.definition;
  topic.seen.md_hash = known.hash;
  topic.seen.md_text = md::python_dict_text(definition);
  topic.seen.columns = flatten_columns(definition);
  topic.seen.message_size = static_cast<std::uint32_t>(known.message_size);
  topic.seen.only_ts = logger.only_ts;
  const auto sample_size = static_cast<std::uint32_t>(kSampleHeaderSize + (logger.only_ts ? 0 : known.message_size));
  if (!topic.log || topic.log->sample_size() != sample_size) {
    // A topic redefined while recorded starts over: samples of one log share a layout.
    if (topic.log) {
      recorder_.detach(topic.tap);
      topic.reading_socket.clear();
      topic.reading_generation = -1;
      topic.attached_generation = -1;
      if (topic.log->count() > 0 && log_)
        log_(LogLevel::Warning, label(logger.name, topic.name) +
                                    ": the topic's message size changed; the samples "
                                    "recorded so far are dropped");
    }
    topic.log = SampleLog::create(topic.log_size, sample_size);
  }
  registry_.set_tap_buffers(topic.tap, tap_slots(static_cast<std::uint64_t>(known.message_size)), out);
}

bool Loggers::attach(Logger& logger, LoggedTopic& topic, const Topic& known, std::uint64_t answer) {
  if (!known.publisher || !known.publisher_ready) return false;
  const Client& publisher = registry_.client(*known.publisher);
  if (topic.reading_socket == publisher.hello.peer_socket && topic.reading_generation == known.segment_generation)
    return false;
  if (topic.reading_socket != publisher.hello.peer_socket) topic.attached_generation = -1;  // a new publisher
  topic.reading_socket = publisher.hello.peer_socket;
  topic.reading_generation = known.segment_generation;
  topic.seen.publisher = publisher.name;

  const std::string peer_socket = publisher.hello.peer_socket;
  const Id topic_id = known.id;
  const std::string topic_name = topic.name;
  const Id tap = topic.tap;
  const std::uint32_t slots = tap_slots(static_cast<std::uint64_t>(known.message_size));
  const std::string logger_name = logger.name;
  const std::uint64_t recording = logger.recording;
  attacher_->add([=, post = post_] {
    std::shared_ptr<transport::ShmReader> reader;
    std::string problem;
    std::int64_t generation = -1;
    std::uint32_t window = 1;
    try {
      OpenedSegment opened = open_publisher_segment(peer_socket, topic_id, topic_name, tap, slots, kAttachTimeout);
      generation = opened.generation;
      transport::ReaderOptions options;
      window = options.buffers = std::max<std::uint32_t>(1, std::min(slots, opened.slots));
      options.on_lag = transport::LagPolicy::keep_latest_window;  // a recorder that fell behind keeps what it can
      options.resume_after = opened.last_sequence;
      reader = std::make_shared<transport::ShmReader>(transport::ShmReader::attach(std::move(opened.fd), options));
    } catch (const std::exception& error) {
      problem = error.what();
    }
    post([=](Outbox& out) {
      finish_attach(logger_name, recording, tap, peer_socket, generation, reader, window, problem, answer, out);
    });
  });
  return true;
}

void Loggers::finish_attach(const std::string& logger_name, std::uint64_t recording, Id tap,
                            const std::string& peer_socket, std::int64_t generation,
                            std::shared_ptr<transport::ShmReader> reader, std::uint32_t window,
                            const std::string& problem, std::uint64_t answer, Outbox& out) {
  const auto it = loggers_.find(logger_name);
  if (it != loggers_.end() && it->second.enabled && it->second.recording == recording) {
    Logger& logger = it->second;
    for (LoggedTopic& topic : logger.topics) {
      if (topic.tap != tap) continue;
      if (reader) {
        // A segment is read once: the answers to two asks may name the same
        // one (it grew before the first answer), or arrive out of order.
        if (peer_socket == topic.reading_socket && generation <= topic.attached_generation) continue;
        topic.attached_generation = generation;
        recorder_.attach(tap, std::make_unique<transport::ShmReader>(std::move(*reader)), window,
                         TapSettings{topic.log, topic.divisor, logger.only_ts, label(logger.name, topic.name)});
      } else {
        topic.reading_socket.clear();  // the next publisher_ready tries again
        topic.reading_generation = -1;
        topic.attached_generation = -1;
        if (log_) log_(LogLevel::Warning, label(logger.name, topic.name) + ": " + problem);
      }
    }
  }
  answered_part(answer, problem, out);
}

void Loggers::answered_part(std::uint64_t answer, const std::string& problem, Outbox& out) {
  const auto it = pending_.find(answer);
  if (it == pending_.end()) return;
  PendingAnswer& pending = it->second;
  if (!problem.empty()) pending.problems.push_back(problem);
  if (pending.waiting_for > 1) {
    --pending.waiting_for;
    return;
  }
  std::string text;
  for (const std::string& line : pending.problems) text += (text.empty() ? "" : "\n") + line;
  out.push_back({pending.client, text.empty() ? Message::response_to(pending.request)
                                              : Message::error_response_to(pending.request, LNE_REQUEST_FAILED, text)});
  pending_.erase(it);
}

void Loggers::publisher_ready(const Topic& topic, Outbox& out) {
  for (auto& [name, logger] : loggers_) {
    if (!logger.enabled) continue;
    for (LoggedTopic& logged : logger.topics) {
      if (logged.name != topic.name || logged.tap == 0) continue;
      try {
        learn_definition(logger, logged, topic, out);
        attach(logger, logged, topic, 0);
      } catch (const std::exception& error) {
        if (log_) log_(LogLevel::Warning, label(logger.name, logged.name) + ": cannot record: " + error.what());
      }
    }
  }
}

// ----------------------------------------------------------------- disable

void Loggers::stop(Logger& logger, Outbox& out) {
  for (LoggedTopic& topic : logger.topics) {
    if (topic.tap == 0) continue;
    recorder_.detach(topic.tap);
    registry_.remove_tap(topic.tap, out);
    topic.tap = 0;
    topic.reading_socket.clear();
    topic.reading_generation = -1;
    topic.attached_generation = -1;
  }
  logger.enabled = false;
}

Message Loggers::disable(const Message& request, Outbox& out) {
  const auto it = loggers_.find(request.get_string("name"));
  if (it != loggers_.end() && it->second.enabled) stop(it->second, out);
  return Message::response_to(request);
}

// ---------------------------------------------------------------- download

std::shared_ptr<const SampleLog> Loggers::view_of(const LoggedTopic& topic) {
  if (!topic.log) return nullptr;
  if (topic.tap == 0) return topic.log;  // not recording: the log does not change any more
  recorder_.catch_up(topic.tap);
  return topic.log->snapshot();
}

Message Loggers::download(Id client, const Message& request) {
  Logger& logger = existing(request.get_string("name"));
  for (auto it = downloads_.begin(); it != downloads_.end();)  // views of clients that left
    it = registry_.clients().count(it->first) ? std::next(it) : downloads_.erase(it);
  Download& view = downloads_[client];
  view = Download{++last_download_, {}};
  StringList names, log_sizes, divisors, counts, sample_sizes, md_names, mds;
  for (const LoggedTopic& topic : logger.topics) {
    view.views.push_back(view_of(topic));
    const auto& samples = view.views.back();
    names.push_back(topic.name);
    log_sizes.push_back(std::to_string(topic.log_size));
    divisors.push_back(std::to_string(topic.divisor));
    counts.push_back(std::to_string(samples ? samples->count() : 0));
    sample_sizes.push_back(std::to_string(samples ? samples->sample_size() : 0));
    md_names.push_back(topic.seen.md_name);
    mds.push_back(topic.seen.md_text);
  }
  return Message::response_to(request)
      .set("download", view.id)
      .set("topics", std::move(names))
      .set("log_sizes", std::move(log_sizes))
      .set("divisors", std::move(divisors))
      .set("n_samples", std::move(counts))
      .set("sample_sizes", std::move(sample_sizes))
      .set("md_names", std::move(md_names))
      .set("mds", std::move(mds));
}

Message Loggers::download_data(Id client, const Message& request) {
  const auto it = downloads_.find(client);
  const std::int64_t id = request.get_int("download");
  if (it == downloads_.end() || it->second.id != id)
    throw RequestError(LNE_INVALID_PARAMETER, "download " + std::to_string(id) +
                                                  " is gone (a later "
                                                  "logger_download replaced it)");
  const auto& views = it->second.views;
  const std::int64_t topic = request.get_int("topic", 0, static_cast<std::int64_t>(views.size()) - 1);
  const auto& samples = views[static_cast<std::size_t>(topic)];
  const std::uint64_t total = samples ? samples->count() * samples->sample_size() : 0;
  const auto offset = static_cast<std::uint64_t>(request.get_int("offset", 0, static_cast<std::int64_t>(total)));
  std::string data(static_cast<std::size_t>(std::min<std::uint64_t>(total - offset, protocol::logger::kDownloadChunk)),
                   '\0');
  if (!data.empty()) samples->copy_out(offset, data.data(), data.size());
  return Message::response_to(request).set("data", std::move(data));
}

// ------------------------------------------------------------ manager_save

void Loggers::manager_save(Id client, const Message& request) {
  Logger& logger = existing(request.get_string("name"));
  const std::string filename = request.get_string("filename");
  const std::string format = choose_format(request.get_string_or("format", "auto"), filename);
  std::vector<SavedTopic> topics;
  for (const LoggedTopic& topic : logger.topics) {
    SavedTopic saved = topic.seen;
    saved.name = topic.name;
    saved.only_ts = logger.only_ts;
    saved.samples = view_of(topic);
    topics.push_back(std::move(saved));
  }
  SaveOptions options;
  if (format == "mcap") options.md_dirs = definitions_.search_dirs();
  options.cancelled = [closing = closing_] { return closing->load(); };
  saver_->add([=, post = post_] {
    std::string problem;
    int code = 0;
    try {
      save_log_file(filename, format, topics, options);
    } catch (const RequestError& error) {
      problem = error.what();
      code = error.code();
    } catch (const std::exception& error) {
      problem = error.what();
      code = LNE_INTERNAL_ERROR;
    }
    post([=](Outbox& out) {
      out.push_back({client, problem.empty() ? Message::response_to(request)
                                             : Message::error_response_to(request, code, problem)});
    });
  });
}

}  // namespace ln::manager
