#include "client/loggers.hpp"

#include <charconv>
#include <cstring>
#include <limits>

#include "client/client.hpp"
#include "client/failure.hpp"
#include "client/live_handles.hpp"
#include "protocol/logger_samples.hpp"
#include "protocol/methods.hpp"

namespace ln::clientlib {
namespace {

namespace method = protocol::method;
using protocol::Message;
using protocol::StringList;
using namespace std::chrono_literals;

// Enabling waits for the manager to attach to each publisher; a file may
// take a while to write.
constexpr std::chrono::milliseconds kEnableTimeout = 60s;
constexpr std::chrono::milliseconds kSaveTimeout = 600s;

LiveHandles& live_loggers() {
  static LiveHandles live;
  return live;
}

[[noreturn]] void malformed(const std::string& what) {
  throw Failure(LNE_GOT_INVALID_RESPONSE, "malformed logger_download answer from the ln_manager: " + what);
}

template <typename Number>
Number number_in(const StringList& column, std::size_t row, const char* what) {
  Number value{};
  const std::string& text = column[row];
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size())
    malformed(std::string(what) + " '" + text + "' is not a number in range");
  return value;
}

}  // namespace

Logger::Logger(Client& client, std::string name) : client_(client), name_(std::move(name)) { live_loggers().add(this); }

Logger::~Logger() { live_loggers().remove(this); }

bool Logger::alive(const void* handle) { return live_loggers().contains(handle); }

void Logger::add_topic(const std::string& topic, std::uint64_t log_size, std::uint32_t divisor) {
  if (topic.empty()) throw Failure(LNE_INVALID_PARAMETER, "logger '" + name_ + "': a topic name must not be empty");
  if (log_size == 0)
    throw Failure(LNE_INVALID_PARAMETER,
                  "logger '" + name_ + "', topic '" + topic + "': the log size must be at least 1 sample");
  const std::string recorded = client_.topic_mapping().apply(topic);
  std::lock_guard<std::mutex> lock(mutex_);
  for (Entry& entry : topics_) {
    if (entry.topic != recorded) continue;
    entry.log_size = log_size;
    entry.divisor = divisor;
    return;
  }
  topics_.push_back({recorded, log_size, divisor});
}

void Logger::clear_topics() {
  std::lock_guard<std::mutex> lock(mutex_);
  topics_.clear();
}

void Logger::set_only_ts(bool only_ts) {
  std::lock_guard<std::mutex> lock(mutex_);
  only_ts_ = only_ts;
}

void Logger::enable() {
  Message request = client_.new_request(method::logger_enable);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (topics_.empty()) throw Failure(LNE_NO_LOGGER_TOPICS, "logger '" + name_ + "' has no topics: add_topic() first");
    StringList names, sizes, divisors;
    for (const Entry& entry : topics_) {
      names.push_back(entry.topic);
      sizes.push_back(std::to_string(entry.log_size));
      divisors.push_back(std::to_string(entry.divisor));
    }
    request.set("name", name_)
        .set("topics", std::move(names))
        .set("log_sizes", std::move(sizes))
        .set("divisors", std::move(divisors))
        .set("only_ts", only_ts_);
  }
  client_.request(std::move(request), kEnableTimeout);
}

void Logger::disable() {
  Message request = client_.new_request(method::logger_disable);
  request.set("name", name_);
  client_.request(std::move(request));
}

LoggerData* Logger::download() {
  Message request = client_.new_request(method::logger_download);
  request.set("name", name_);
  const Message answer = client_.request(std::move(request));
  const StringList& names = answer.get_list("topics");
  const StringList& log_sizes = answer.get_list("log_sizes");
  const StringList& divisors = answer.get_list("divisors");
  const StringList& counts = answer.get_list("n_samples");
  const StringList& sample_sizes = answer.get_list("sample_sizes");
  const StringList& md_names = answer.get_list("md_names");
  const StringList& mds = answer.get_list("mds");
  for (const StringList* column : {&log_sizes, &divisors, &counts, &sample_sizes, &md_names, &mds})
    if (column->size() != names.size()) malformed("its topic lists differ in length");
  const std::int64_t download = answer.get_int("download");

  std::vector<LoggerData::Topic> topics;
  for (std::size_t i = 0; i < names.size(); ++i) {
    LoggerData::Topic topic;
    topic.name = names[i];
    topic.log_size = number_in<std::uint64_t>(log_sizes, i, "a log size");
    topic.divisor = number_in<std::uint32_t>(divisors, i, "a divisor");
    const auto count = number_in<std::uint64_t>(counts, i, "a sample count");
    if (count > std::numeric_limits<std::uint32_t>::max())
      throw Failure(LNE_INVALID_PARAMETER, "logger '" + name_ + "', topic '" + topic.name +
                                               "': " + std::to_string(count) +
                                               " samples are more than ln.h's "
                                               "logger_topic can count (2^32 - 1); use a smaller log size");
    topic.n_samples = static_cast<std::uint32_t>(count);
    topic.sample_size = number_in<std::uint32_t>(sample_sizes, i, "a sample size");
    topic.md_name = md_names[i];
    topic.md = mds[i];
    const std::uint64_t bytes = count * topic.sample_size;
    topic.samples.resize(static_cast<std::size_t>(bytes));
    for (std::uint64_t offset = 0; offset < bytes;) {
      Message fetch = client_.new_request(method::logger_download_data);
      fetch.set("download", download)
          .set("topic", static_cast<std::int64_t>(i))
          .set("offset", static_cast<std::int64_t>(offset));
      const Message part = client_.request(std::move(fetch));
      const std::string& data = part.get_string("data");
      if (data.empty() || data.size() > bytes - offset) malformed("a data chunk does not fit the samples");
      std::memcpy(topic.samples.data() + offset, data.data(), data.size());
      offset += data.size();
    }
    topics.push_back(std::move(topic));
  }
  auto data = std::make_unique<LoggerData>(std::move(topics));
  std::lock_guard<std::mutex> lock(mutex_);
  data_ = std::move(data);
  return data_.get();
}

LoggerData* Logger::direct_download() {
  disable();
  return download();
}

void Logger::manager_save(const std::string& filename, const std::string& format) {
  Message request = client_.new_request(method::logger_manager_save);
  request.set("name", name_).set("filename", filename).set("format", format.empty() ? "auto" : format);
  client_.request(std::move(request), kSaveTimeout);
}

Logger* ClientLoggers::get(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::unique_ptr<Logger>& logger = loggers_[name];
  if (!logger) logger = std::make_unique<Logger>(client_, name);
  return logger.get();
}

}  // namespace ln::clientlib
