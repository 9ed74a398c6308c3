#include "manager/log_files.hpp"

#include <fcntl.h>
#include <unistd.h>

#ifdef LN_WITH_MATIO
#include <matio.h>
#endif

#include <algorithm>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <mutex>

extern char** environ;

#include "manager/mcap_converter.hpp"
#include "manager/request_error.hpp"

namespace ln::manager {
namespace {

using protocol::logger::kSampleHeaderSize;

[[noreturn]] void cannot_write(const std::string& filename, const std::string& why) {
  throw RequestError(LNE_REQUEST_FAILED, "cannot write '" + filename + "': " + why);
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

/// A file written under a temporary name in the same directory and renamed
/// into place by commit(); dropped otherwise.
class AtomicFile {
 public:
  explicit AtomicFile(std::string filename)
      : filename_(std::move(filename)), temp_(filename_ + ".ln-tmp-" + std::to_string(::getpid())) {}
  ~AtomicFile() {
    if (file_ != nullptr) std::fclose(file_);
    if (!committed_) ::unlink(temp_.c_str());
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& filename() const { return filename_; }

  /// For writers that write the file themselves (libmatio).
  void check_writable() {
    const int fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) cannot_write(filename_, std::strerror(errno));
    ::close(fd);
  }

  void write(const void* data, std::size_t size) {
    if (file_ == nullptr) {
      file_ = std::fopen(temp_.c_str(), "wbe");
      if (file_ == nullptr) cannot_write(filename_, std::strerror(errno));
    }
    if (size > 0 && std::fwrite(data, 1, size, file_) != size) cannot_write(filename_, std::strerror(errno));
  }
  template <typename T>
  void put(T value) {
    write(&value, sizeof value);
  }

  /// Finishes writing temp_path() (checking for errors) without renaming it.
  void close_written() {
    if (file_ == nullptr) write(nullptr, 0);
    const bool failed = std::fflush(file_) != 0 || std::ferror(file_) != 0;
    const int error = errno;
    std::fclose(file_);
    file_ = nullptr;
    if (failed) cannot_write(filename_, std::strerror(error));
  }
  void commit() {
    close_written();
    commit_written();
  }
  /// commit() for a file written by someone else at temp_path().
  void commit_written() {
    if (::rename(temp_.c_str(), filename_.c_str()) != 0) cannot_write(filename_, std::strerror(errno));
    committed_ = true;
  }

 private:
  std::string filename_;
  std::string temp_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

std::uint64_t sample_count(const SavedTopic& topic) { return topic.samples ? topic.samples->count() : 0; }

/// Calls `visit(sample)` for every sample of `topic`, oldest first.
void for_each_sample(const SavedTopic& topic, const std::function<void(const unsigned char*)>& visit) {
  const std::uint64_t count = sample_count(topic);
  if (count == 0) return;
  const std::uint32_t size = topic.samples->sample_size();
  const std::uint64_t per_chunk = std::max<std::uint64_t>(1, (1u << 20) / size);
  std::vector<unsigned char> chunk;
  for (std::uint64_t first = 0; first < count; first += per_chunk) {
    const std::uint64_t n = std::min(per_chunk, count - first);
    chunk.resize(static_cast<std::size_t>(n * size));
    topic.samples->copy_out(first * size, chunk.data(), chunk.size());
    for (std::uint64_t i = 0; i < n; ++i) visit(chunk.data() + i * size);
  }
}

// ------------------------------------------------------------------- raw

void write_raw(AtomicFile& file, const std::vector<SavedTopic>& topics, const SaveOptions&) {
  if (topics.size() != 1)
    throw RequestError(LNE_REQUEST_FAILED, "the raw format holds exactly one topic; this logger has " +
                                               std::to_string(topics.size()) + " (use pcap or mat)");
  for_each_sample(topics.front(),
                  [&](const unsigned char* sample) { file.write(sample, topics.front().samples->sample_size()); });
  file.commit();
}

// ------------------------------------------------------------------ pcap

// Frames of LN's recorder files (link type 147): each pcap record starts
// with a u32 frame type, counted in its length.
enum FrameType : std::uint32_t { kHeaderFrame = 0, kNewTopicFrame = 1, kTopicPacketFrame = 2 };
constexpr std::uint32_t kRecorderFileVersion = 2;  // topic packets end with the publisher's timestamp

class PcapWriter {
 public:
  explicit PcapWriter(AtomicFile& file) : file_(file) {
    file_.put<std::uint32_t>(0xa1b2c3d4);  // pcap magic, in host byte order as LN writes it
    file_.put<std::uint16_t>(2);
    file_.put<std::uint16_t>(4);
    file_.put<std::uint32_t>(0);  // time zone offset
    file_.put<std::uint32_t>(0);  // time stamp accuracy
    file_.put<std::uint32_t>(0xffffffff);
    file_.put<std::uint32_t>(147);  // LINKTYPE_USER0: LN's own frames
  }

  void frame(double ts, FrameType type, const std::string& data) {
    if (!header_written_) {
      header_written_ = true;
      std::string version(4, '\0');
      const std::uint32_t value = 0xffff0000u + kRecorderFileVersion;
      std::memcpy(version.data(), &value, 4);
      frame(ts, kHeaderFrame, version);
    }
    const auto sec = static_cast<std::uint32_t>(ts);
    const auto nsec = static_cast<std::uint32_t>((ts - sec) * 1e9);
    const auto length = static_cast<std::uint32_t>(data.size() + 4);
    file_.put(sec);
    file_.put(nsec);
    file_.put(length);
    file_.put(length);
    file_.put(static_cast<std::uint32_t>(type));
    file_.write(data.data(), data.size());
  }

 private:
  AtomicFile& file_;
  bool header_written_ = false;
};

template <typename T>
void append_value(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

void append_field(std::string& out, const std::string& text) {
  append_value(out, static_cast<std::uint32_t>(text.size()));
  out += text;
}

/// The pcap into `file`, not committed yet.
void write_pcap_frames(AtomicFile& file, const std::vector<SavedTopic>& topics) {
  for (const SavedTopic& topic : topics)
    if (topic.only_ts && sample_count(topic) > 0)
      throw RequestError(LNE_REQUEST_FAILED,
                         "the pcap format carries packets, but this logger recorded only "
                         "timestamps (set_only_ts); use raw or mat");
  PcapWriter pcap(file);
  struct Cursor {
    const SavedTopic* topic;
    std::uint32_t id;
    std::uint64_t next = 0;
    std::uint64_t count;
  };
  std::vector<Cursor> cursors;
  for (const SavedTopic& topic : topics) {
    const std::uint64_t count = sample_count(topic);
    if (count == 0) continue;  // never published: nothing to announce
    const auto id = static_cast<std::uint32_t>(cursors.size());
    std::string data;
    append_value(data, id);
    append_value(data, topic.message_size);
    append_field(data, topic.name);
    append_field(data, topic.md_name);
    append_field(data, topic.md_text);
    append_field(data, topic.publisher.empty() ? std::string("<unknown>") : topic.publisher);
    append_field(data, topic.md_hash);
    pcap.frame(topic.samples->header(0).src_ts, kNewTopicFrame, data);
    cursors.push_back({&topic, id, 0, count});
  }
  // Merged by source timestamp; equal ones in topic order.
  std::vector<unsigned char> packet;
  for (;;) {
    Cursor* earliest = nullptr;
    double earliest_ts = 0;
    for (Cursor& cursor : cursors) {
      if (cursor.next == cursor.count) continue;
      const double ts = cursor.topic->samples->header(cursor.next).src_ts;
      if (earliest == nullptr || ts < earliest_ts) {
        earliest = &cursor;
        earliest_ts = ts;
      }
    }
    if (earliest == nullptr) break;
    const SampleLog& samples = *earliest->topic->samples;
    const std::size_t size = samples.sample_size() - kSampleHeaderSize;
    packet.resize(size);
    samples.copy_out(earliest->next * samples.sample_size() + kSampleHeaderSize, packet.data(), size);
    std::string data;
    append_value(data, earliest->id);
    data.append(reinterpret_cast<const char*>(packet.data()), size);
    append_value(data, earliest_ts);
    pcap.frame(earliest_ts, kTopicPacketFrame, data);
    ++earliest->next;
  }
}

void write_pcap(AtomicFile& file, const std::vector<SavedTopic>& topics, const SaveOptions&) {
  write_pcap_frames(file, topics);
  file.commit();
}

// ------------------------------------------------------------------ MCAP

/// How long ln bag convert may take: a minute, and a second more per 10000
/// messages and per 32 MiB, but well within the client's wait for the answer
/// (600 s). (It converts about 100000 small messages a second.)
std::chrono::milliseconds conversion_timeout(const std::vector<SavedTopic>& topics) {
  std::uint64_t messages = 0, bytes = 0;
  for (const SavedTopic& topic : topics) {
    messages += sample_count(topic);
    if (topic.samples) bytes += sample_count(topic) * topic.samples->sample_size();
  }
  return std::chrono::seconds(std::min<std::uint64_t>(60 + messages / 10000 + bytes / (32u << 20), 480));
}

void write_mcap(AtomicFile& file, const std::vector<SavedTopic>& topics, const SaveOptions& options) {
  for (const SavedTopic& topic : topics)
    if (topic.only_ts && sample_count(topic) > 0)
      throw RequestError(LNE_REQUEST_FAILED,
                         "MCAP files carry packets, but this logger recorded only timestamps "
                         "(set_only_ts); use raw or mat");
  // The recorder pcap next to the target (never renamed into place: dropped
  // at the end), converted into the target's temporary file.
  AtomicFile pcap(file.filename() + ".pcap");
  write_pcap_frames(pcap, topics);
  pcap.close_written();
  McapConversion conversion;
  conversion.pcap = pcap.temp_path();
  conversion.mcap = file.temp_path();
  conversion.target = file.filename();
  conversion.md_dirs = options.md_dirs;
  conversion.environment = options.environment;
  if (conversion.environment.empty())
    for (char** entry = environ; *entry != nullptr; ++entry) conversion.environment.emplace_back(*entry);
  conversion.timeout = conversion_timeout(topics);
  conversion.cancelled = options.cancelled;
  convert_pcap_to_mcap(conversion);
  file.commit_written();
}

// ------------------------------------------------------------------ MATLAB

#ifdef LN_WITH_MATIO

struct MatVariable {
  std::string name;
  md::Primitive type;
  std::size_t rows;
  std::size_t columns;
  std::vector<unsigned char> data;  // column-major
};

bool mat4_has(md::Primitive type) {
  switch (type) {
    case md::Primitive::Double:
    case md::Primitive::Float:
    case md::Primitive::Int32:
    case md::Primitive::Int16:
    case md::Primitive::UInt16:
    case md::Primitive::UInt8:
      return true;
    default:
      return false;
  }
}

template <typename T>
double element_as_double(const unsigned char* at) {
  T value;
  std::memcpy(&value, at, sizeof value);
  return static_cast<double>(value);
}

double as_double(md::Primitive type, const unsigned char* at) {
  switch (type) {
    case md::Primitive::Double:
      return element_as_double<double>(at);
    case md::Primitive::Float:
      return element_as_double<float>(at);
    case md::Primitive::Char:
    case md::Primitive::Int8:
      return element_as_double<std::int8_t>(at);
    case md::Primitive::UInt8:
      return element_as_double<std::uint8_t>(at);
    case md::Primitive::Int16:
      return element_as_double<std::int16_t>(at);
    case md::Primitive::UInt16:
      return element_as_double<std::uint16_t>(at);
    case md::Primitive::Int32:
      return element_as_double<std::int32_t>(at);
    case md::Primitive::UInt32:
      return element_as_double<std::uint32_t>(at);
    case md::Primitive::Int64:
      return element_as_double<std::int64_t>(at);
    case md::Primitive::UInt64:
      return element_as_double<std::uint64_t>(at);
  }
  return 0;
}

// LN 2.9 names a topic's columns after the fields ("_packet_log_ts",
// "pose_x"); with several topics each is prefixed by the topic name (one
// leading '_' dropped); then a leading '_' moves to the end and '.', '/',
// '[' become '_', ']' is dropped.
std::string matlab_name(const std::string& topic, const std::string& column, bool several_topics) {
  std::string name = column;
  if (several_topics) name = topic + "_" + (name.front() == '_' ? name.substr(1) : name);
  if (name.front() == '_') name = name.substr(1) + "_";
  std::string out;
  for (char c : name) {
    if (c == ']') continue;
    out += (c == '.' || c == '/' || c == '[') ? '_' : c;
  }
  return out;
}

std::vector<MatVariable> matlab_variables(const std::vector<SavedTopic>& topics, bool version4) {
  std::vector<MatVariable> variables;
  std::map<std::string, std::size_t> by_name;  // a later variable of the same name replaces, in place
  for (const SavedTopic& topic : topics) {
    const std::uint64_t rows = sample_count(topic);
    if (rows == 0) continue;
    std::vector<Column> columns = {{"_packet_log_ts", md::Primitive::Double, 1, 0},
                                   {"_packet_source_ts", md::Primitive::Double, 1, 8},
                                   {"_packet_counter", md::Primitive::UInt32, 1, 16}};
    if (!topic.only_ts)
      for (Column column : topic.columns) {
        column.offset += kSampleHeaderSize;
        columns.push_back(column);
      }
    std::vector<MatVariable> made;
    for (const Column& column : columns) {
      const md::Primitive stored = version4 && !mat4_has(column.type) ? md::Primitive::Double : column.type;
      MatVariable variable{matlab_name(topic.name, column.name, topics.size() > 1),
                           stored,
                           column.count == 1 ? 1 : static_cast<std::size_t>(rows),
                           column.count == 1 ? static_cast<std::size_t>(rows) : column.count,
                           {}};
      variable.data.resize(static_cast<std::size_t>(rows) * column.count * md::size_of(stored));
      made.push_back(std::move(variable));
    }
    std::uint64_t row = 0;
    for_each_sample(topic, [&](const unsigned char* sample) {
      for (std::size_t c = 0; c < columns.size(); ++c) {
        const Column& column = columns[c];
        MatVariable& variable = made[c];
        const std::size_t element = md::size_of(column.type);
        const std::size_t stored = md::size_of(variable.type);
        for (std::uint32_t k = 0; k < column.count; ++k) {
          const unsigned char* from = sample + column.offset + k * element;
          unsigned char* to = variable.data.data() + (k * rows + row) * stored;
          if (variable.type == column.type) {
            std::memcpy(to, from, element);
          } else {
            const double value = as_double(column.type, from);
            std::memcpy(to, &value, sizeof value);
          }
        }
      }
      ++row;
    });
    for (MatVariable& variable : made) {
      const auto [it, inserted] = by_name.emplace(variable.name, variables.size());
      if (inserted)
        variables.push_back(std::move(variable));
      else
        variables[it->second] = std::move(variable);
    }
  }
  return variables;
}

struct MatType {
  matio_classes klass;
  matio_types type;
};

MatType mat_type(md::Primitive type) {
  switch (type) {
    case md::Primitive::Double:
      return {MAT_C_DOUBLE, MAT_T_DOUBLE};
    case md::Primitive::Float:
      return {MAT_C_SINGLE, MAT_T_SINGLE};
    case md::Primitive::Char:
    case md::Primitive::Int8:
      return {MAT_C_INT8, MAT_T_INT8};
    case md::Primitive::UInt8:
      return {MAT_C_UINT8, MAT_T_UINT8};
    case md::Primitive::Int16:
      return {MAT_C_INT16, MAT_T_INT16};
    case md::Primitive::UInt16:
      return {MAT_C_UINT16, MAT_T_UINT16};
    case md::Primitive::Int32:
      return {MAT_C_INT32, MAT_T_INT32};
    case md::Primitive::UInt32:
      return {MAT_C_UINT32, MAT_T_UINT32};
    case md::Primitive::Int64:
      return {MAT_C_INT64, MAT_T_INT64};
    case md::Primitive::UInt64:
      return {MAT_C_UINT64, MAT_T_UINT64};
  }
  return {MAT_C_DOUBLE, MAT_T_DOUBLE};
}

// libmatio reports problems through a global log function; keep them for
// the error message instead of letting it print.
std::mutex matio_mutex;
std::string matio_problem;
void keep_matio_message(int, char* message) {
  if (matio_problem.empty() && message != nullptr) matio_problem = message;
}

void write_matlab(AtomicFile& file, const std::vector<SavedTopic>& topics, bool version4) {
  const std::vector<MatVariable> variables = matlab_variables(topics, version4);
  file.check_writable();
  std::lock_guard<std::mutex> lock(matio_mutex);
  Mat_LogInitFunc("ln_manager", keep_matio_message);
  matio_problem.clear();
  mat_t* mat = Mat_CreateVer(file.temp_path().c_str(), nullptr, version4 ? MAT_FT_MAT4 : MAT_FT_MAT5);
  if (mat == nullptr) cannot_write(file.filename(), "libmatio cannot create it: " + matio_problem);
  bool ok = true;
  for (const MatVariable& variable : variables) {
    std::size_t dims[2] = {variable.rows, variable.columns};
    const MatType stored = mat_type(variable.type);
    matvar_t* var = Mat_VarCreate(variable.name.c_str(), stored.klass, stored.type, 2, dims,
                                  const_cast<unsigned char*>(variable.data.data()), MAT_F_DONT_COPY_DATA);
    ok = var != nullptr && Mat_VarWrite(mat, var, MAT_COMPRESSION_NONE) == 0;
    if (var != nullptr) Mat_VarFree(var);
    if (!ok) {
      Mat_Close(mat);
      cannot_write(file.filename(), "libmatio failed on variable '" + variable.name + "': " + matio_problem);
    }
  }
  if (Mat_Close(mat) != 0) cannot_write(file.filename(), "libmatio failed to finish it: " + matio_problem);
  file.commit_written();
}
#else
void write_matlab(AtomicFile& file, const std::vector<SavedTopic>&, bool) {
  cannot_write(file.filename(),
               "this ln_manager was built without libmatio (Debian: libmatio-dev), which writes "
               "MATLAB files");
}
#endif

// ------------------------------------------------------------------ table

struct Format {
  const char* name;
  std::vector<const char*> aliases;     ///< other spellings LN 2.9 accepts
  std::vector<const char*> extensions;  ///< chosen by "auto" for these file name endings
  void (*write)(AtomicFile&, const std::vector<SavedTopic>&, const SaveOptions&);
};

const std::vector<Format>& formats() {
  static const std::vector<Format> table = {
      {"raw", {}, {"raw"}, write_raw},
      {"pcap", {}, {"pcap"}, write_pcap},
      {"mat",
       {"matlab", "matlab5"},
       {"mat", "matlab"},
       [](AtomicFile& file, const std::vector<SavedTopic>& topics, const SaveOptions&) {
         write_matlab(file, topics, false);
       }},
      {"mat4",
       {"matlab4"},
       {},
       [](AtomicFile& file, const std::vector<SavedTopic>& topics, const SaveOptions&) {
         write_matlab(file, topics, true);
       }},
      {"mcap", {}, {"mcap"}, write_mcap},
  };
  return table;
}

std::string format_list() {
  std::string list;
  for (const Format& format : formats()) list += (list.empty() ? "" : ", ") + std::string(format.name);
  return list;
}

const Format& format_named(const std::string& name) {
  for (const Format& format : formats()) {
    if (name == format.name) return format;
    for (const char* alias : format.aliases)
      if (name == alias) return format;
  }
  throw RequestError(LNE_REQUEST_FAILED, "unknown format '" + name + "': ln_core's manager writes " + format_list() +
                                             " (or 'auto': chosen by the file name)");
}

}  // namespace

std::vector<Column> flatten_columns(const md::Definition& definition) {
  std::vector<Column> columns;
  std::uint32_t offset = 0;
  std::function<void(const md::Definition&, const std::string&)> add = [&](const md::Definition& part,
                                                                           const std::string& parent) {
    for (const md::Field& field : part.fields) {
      const std::string name = parent.empty() ? field.name : parent + "_" + field.name;
      if (field.sub != nullptr) {
        for (std::uint32_t i = 0; i < field.count; ++i)
          add(*field.sub, field.count > 1 ? name + "[" + std::to_string(i) + "]" : name);
        continue;
      }
      columns.push_back({name, *field.primitive, field.count, offset});
      offset += field.count * static_cast<std::uint32_t>(md::size_of(*field.primitive));
    }
  };
  add(definition, "");
  return columns;
}

std::string choose_format(const std::string& format, const std::string& filename) {
  if (lower(format) == "pickle")
    throw RequestError(LNE_REQUEST_FAILED,
                       "ln_core's manager cannot write Python pickles (LN 2.9's manager is "
                       "a Python program; this one is native); use one of " +
                           format_list());
  if (format != "auto") return format_named(lower(format)).name;
  const std::string base = filename.substr(filename.find_last_of('/') + 1);
  const std::size_t dot = base.find_last_of('.');
  const std::string extension = dot == std::string::npos ? "" : lower(base.substr(dot + 1));
  for (const Format& candidate : formats())
    for (const char* known : candidate.extensions)
      if (extension == known) return candidate.name;
  throw RequestError(
      LNE_REQUEST_FAILED,
      "format 'auto' cannot tell the format of '" + filename +
          "' from its name (LN 2.9 would write "
          "a Python pickle, which ln_core's native manager cannot); name a file .raw, .pcap, .mat or .mcap, or "
          "pass one of " +
          format_list());
}

void save_log_file(const std::string& filename, const std::string& format, const std::vector<SavedTopic>& topics,
                   const SaveOptions& options) {
  if (filename.empty()) throw RequestError(LNE_REQUEST_FAILED, "manager_save needs a file name");
  const Format& chosen = format_named(format);
  AtomicFile file(filename);
  chosen.write(file, topics, options);
}

}  // namespace ln::manager
