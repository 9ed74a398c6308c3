#include "client/logger_data.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

#include "client/failure.hpp"
#include "client/live_handles.hpp"
#include "protocol/logger_samples.hpp"

namespace ln::clientlib {
namespace {

constexpr std::uint16_t kByteOrderMark = 0x0420;
constexpr std::uint16_t kSwappedByteOrderMark = 0x2004;
constexpr std::uint32_t kVersion = 3;
constexpr std::uint32_t kVersion32BitLogSize = 2;
constexpr char kComment[] = "\r# links and nodes logger data (ln_core); read it with ln_logger_data_load()\n";

class Writer {
 public:
  template <typename T>
  void put(T value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof value);
  }
  void text(const std::string& value) {
    put(static_cast<std::uint32_t>(value.size()));
    bytes_ += value;
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

/// Reads a file's bytes with bounds checks; a short read names the place.
class Reader {
 public:
  Reader(const std::string& bytes, const std::string& filename) : bytes_(bytes), filename_(filename) {}

  template <typename T>
  T get(const char* what) {
    T value;
    need(sizeof value, what);
    std::memcpy(&value, bytes_.data() + at_, sizeof value);
    at_ += sizeof value;
    return value;
  }
  std::string text(const char* what) {
    const std::uint32_t size = get<std::uint32_t>(what);
    need(size, what);
    std::string value = bytes_.substr(at_, size);
    at_ += size;
    return value;
  }
  std::vector<unsigned char> block(std::uint64_t size, const char* what) {
    need(size, what);
    std::vector<unsigned char> value(bytes_.begin() + static_cast<std::ptrdiff_t>(at_),
                                     bytes_.begin() + static_cast<std::ptrdiff_t>(at_ + size));
    at_ += static_cast<std::size_t>(size);
    return value;
  }
  [[noreturn]] void damaged(const std::string& what) const {
    throw Failure(LNE_INVALID_PARAMETER, "'" + filename_ + "' is not valid LN logger data: " + what + " (at byte " +
                                             std::to_string(at_) + ")");
  }
  bool at_end() const { return at_ == bytes_.size(); }

 private:
  void need(std::uint64_t size, const char* what) const {
    if (size > bytes_.size() - at_)
      damaged(std::string("the file ends within ") + what + " (" + std::to_string(bytes_.size()) + " bytes)");
  }

  const std::string& bytes_;
  const std::string& filename_;
  std::size_t at_ = 0;
};

LiveHandles& live_data() {
  static LiveHandles live;
  return live;
}

}  // namespace

LoggerData::LoggerData(std::vector<Topic> topics) : topics_(std::move(topics)) {
  views_.reserve(topics_.size());
  for (Topic& topic : topics_) {
    if (topic.samples.size() != static_cast<std::uint64_t>(topic.n_samples) * topic.sample_size ||
        (topic.n_samples > 0 && topic.sample_size < protocol::logger::kSampleHeaderSize))
      throw Failure(LNE_INVALID_PARAMETER, "topic '" + topic.name + "': " + std::to_string(topic.n_samples) +
                                               " samples of " + std::to_string(topic.sample_size) +
                                               " bytes do not "
                                               "match " +
                                               std::to_string(topic.samples.size()) + " bytes of data");
    logger_topic view{};
    view.name = topic.name.data();
    view.log_size = topic.log_size;
    view.divisor = topic.divisor;
    view.n_samples = topic.n_samples;
    view.sample_size = topic.sample_size;
    view.md_name = topic.md_name.data();
    view.md = topic.md.data();
    view.samples = topic.samples.empty() ? nullptr : reinterpret_cast<logger_sample*>(topic.samples.data());
    views_.push_back(view);
  }
  live_data().add(this);
}

LoggerData::~LoggerData() { live_data().remove(this); }

bool LoggerData::alive(const void* handle) { return live_data().contains(handle); }

logger_topic* LoggerData::topic(std::size_t index) { return index < views_.size() ? &views_[index] : nullptr; }

void LoggerData::save(const std::string& filename) const {
  // Each topic's samples follow its header: written topic by topic, not copied.
  std::FILE* file = std::fopen(filename.c_str(), "wbe");
  if (file == nullptr) throw errno_failure(errno, "cannot write logger data to '" + filename + "'");
  Writer header;
  header.put(kByteOrderMark);
  header.put(kVersion);
  header.text(kComment);
  header.put(static_cast<std::uint32_t>(topics_.size()));
  bool ok = std::fwrite(header.bytes().data(), 1, header.bytes().size(), file) == header.bytes().size();
  for (const Topic& topic : topics_) {
    Writer head;
    head.text(topic.name);
    head.put(topic.log_size);
    head.put(topic.divisor);
    head.put(topic.n_samples);
    head.put(topic.sample_size);
    head.text(topic.md_name);
    head.text(topic.md);
    ok = ok && std::fwrite(head.bytes().data(), 1, head.bytes().size(), file) == head.bytes().size();
    ok = ok && (topic.samples.empty() ||
                std::fwrite(topic.samples.data(), 1, topic.samples.size(), file) == topic.samples.size());
  }
  const int error = errno;
  ok = std::fclose(file) == 0 && ok;
  if (!ok) throw errno_failure(error != 0 ? error : EIO, "cannot write logger data to '" + filename + "'");
}

std::unique_ptr<LoggerData> LoggerData::load(const std::string& filename) {
  std::ifstream file(filename, std::ios::binary);
  if (!file) throw errno_failure(errno != 0 ? errno : ENOENT, "cannot read logger data from '" + filename + "'");
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (file.bad()) throw errno_failure(EIO, "cannot read logger data from '" + filename + "'");
  Reader in(bytes, filename);
  const auto mark = in.get<std::uint16_t>("the byte order mark");
  if (mark == kSwappedByteOrderMark)
    throw Failure(LNE_WRONG_BYTE_ORDER, "'" + filename + "' was written on a host of the other byte order");
  if (mark != kByteOrderMark) in.damaged("it does not start with LN's byte order mark 0x0420");
  const auto version = in.get<std::uint32_t>("the version");
  if (version > kVersion)
    throw Failure(LNE_LOG_FILE_TOO_NEW, "'" + filename + "' is logger data of version " + std::to_string(version) +
                                            "; this library reads versions 2 and 3");
  if (version != kVersion && version != kVersion32BitLogSize)
    in.damaged("version " + std::to_string(version) + " is not one this library reads (2, 3)");
  in.text("the comment");
  const auto count = in.get<std::uint32_t>("the topic count");
  std::vector<Topic> topics;
  for (std::uint32_t i = 0; i < count; ++i) {
    Topic topic;
    topic.name = in.text("a topic name");
    topic.log_size = version == kVersion ? in.get<std::uint64_t>("a log size") : in.get<std::uint32_t>("a log size");
    topic.divisor = in.get<std::uint32_t>("a divisor");
    topic.n_samples = in.get<std::uint32_t>("a sample count");
    topic.sample_size = in.get<std::uint32_t>("a sample size");
    topic.md_name = in.text("a message definition name");
    topic.md = in.text("a message definition");
    if (topic.n_samples > 0 && topic.sample_size < protocol::logger::kSampleHeaderSize)
      in.damaged("topic '" + topic.name + "' has samples of " + std::to_string(topic.sample_size) +
                 " bytes, less than their 20-byte header");
    topic.samples = in.block(static_cast<std::uint64_t>(topic.n_samples) * topic.sample_size, "the samples");
    topics.push_back(std::move(topic));
  }
  if (!in.at_end()) in.damaged("unexpected bytes after the last topic");
  auto data = std::make_unique<LoggerData>(std::move(topics));
  data->loaded_ = true;
  return data;
}

std::unique_ptr<LoggerData> LoggerData::copy() const {
  auto data = std::make_unique<LoggerData>(topics_);
  data->loaded_ = true;
  return data;
}

}  // namespace ln::clientlib
