#include "loggers.hpp"
#include "common.hpp"

#include <nanobind/stl/string.h>

#include <cstdint>
#include <string>

namespace nb = nanobind;
using namespace nb::literals;

namespace lnpy {
namespace {

/// Logger contents owned by Python: a download is copied at once (the
/// library replaces a logger's download with its next one), a file is
/// loaded into its own.
class LoggerData {
 public:
  LoggerData(ln_logger_data owned, nb::object ln_error) : data_(owned), ln_error_(std::move(ln_error)) {}
  ~LoggerData() { ln_logger_data_deinit(&data_); }
  LoggerData(const LoggerData&) = delete;
  LoggerData& operator=(const LoggerData&) = delete;

  static LoggerData* load(const std::string& filename, nb::object ln_error) {
    ln_logger_data data = nullptr;
    const int ret = without_gil([&] { return ln_logger_data_load(&data, filename.c_str()); });
    if (ret < 0) raise_ln_error(ln_error, ret, "logger_data.load('" + filename + "')", nullptr);
    return new LoggerData(data, std::move(ln_error));
  }

  void save(const std::string& filename) {
    const int ret = without_gil([&] { return ln_logger_data_save(data_, filename.c_str()); });
    if (ret < 0) raise_ln_error(ln_error_, ret, "logger_data.save('" + filename + "')", nullptr);
  }

  /// The topics as dicts: the fields of ln.h's logger_topic, the samples as bytes.
  nb::list topics() {
    unsigned int count = 0;
    int ret = ln_logger_data_get_info(data_, &count);
    if (ret < 0) raise_ln_error(ln_error_, ret, "logger_data.topics", nullptr);
    nb::list out;
    for (unsigned int i = 0; i < count; ++i) {
      logger_topic* topic = nullptr;
      ret = ln_logger_data_get_topic(data_, i, &topic);
      if (ret < 0) raise_ln_error(ln_error_, ret, "logger_data.topics", nullptr);
      nb::dict d;
      d["name"] = topic->name;
      d["log_size"] = topic->log_size;
      d["divisor"] = topic->divisor;
      d["n_samples"] = topic->n_samples;
      d["sample_size"] = topic->sample_size;
      d["md_name"] = topic->md_name;
      d["md"] = topic->md;
      const auto size = static_cast<Py_ssize_t>(std::uint64_t{topic->n_samples} * topic->sample_size);
      d["samples"] = nb::steal(PyBytes_FromStringAndSize(
          topic->samples != nullptr ? reinterpret_cast<const char*>(topic->samples) : "", size));
      out.append(d);
    }
    return out;
  }

 private:
  ln_logger_data data_;
  nb::object ln_error_;
};

class Logger {
 public:
  Logger(nb::object client, ln_logger handle, std::string name, WithClient with_client, nb::object ln_error)
      : client_(std::move(client)),
        handle_(handle),
        name_(std::move(name)),
        with_client_(with_client),
        ln_error_(std::move(ln_error)) {}

  const std::string& name() const { return name_; }

  void add_topic(const std::string& topic, std::uint64_t log_size, unsigned int divisor) {
    call("add_topic('" + topic + "')",
         [&] { return ln_logger_add_topic64(handle_, topic.c_str(), log_size, divisor); });
  }
  void clear_topics() {
    call("clear_topics", [&] { return ln_logger_clear_topics(handle_); });
  }
  void set_only_ts(bool only_ts) {
    call("set_only_ts", [&] { return ln_logger_set_only_ts(handle_, only_ts ? 1 : 0); });
  }
  void enable() {
    call("enable", [&] { return ln_logger_enable(handle_); });
  }
  void disable() {
    call("disable", [&] { return ln_logger_disable(handle_); });
  }
  void manager_save(const std::string& filename, const std::string& format) {
    call("manager_save('" + filename + "')",
         [&] { return ln_logger_manager_save(handle_, filename.c_str(), format.c_str()); });
  }
  LoggerData* download(bool direct) {
    ln_logger_data copy = nullptr;
    call(direct ? "direct_download" : "download", [&] {
      ln_logger_data data = nullptr;
      const int ret = direct ? ln_logger_direct_download(handle_, &data) : ln_logger_download(handle_, &data);
      return ret < 0 ? ret : ln_logger_data_copy(data, &copy);
    });
    return new LoggerData(copy, ln_error_);
  }

 private:
  /// Runs `body` (an ln_logger_* call) without the GIL while the client is open.
  template <typename Body>
  void call(const std::string& what, Body&& body) {
    with_client_(client_, [&](ln_client client) {
      const int ret = without_gil([&] { return body(); });
      if (ret < 0) raise_ln_error(ln_error_, ret, "logger '" + name_ + "'." + what, client);
    });
  }

  nb::object client_;  // keeps the native client alive as long as its logger
  ln_logger handle_;
  std::string name_;
  WithClient with_client_;
  nb::object ln_error_;
};

}  // namespace

void register_loggers(nb::module_& module, WithClient with_client) {
  nb::object ln_error = module.attr("LNError");
  nb::class_<LoggerData>(module, "LoggerData")
      .def_static(
          "load", [ln_error](const std::string& filename) { return LoggerData::load(filename, ln_error); },
          "filename"_a, nb::rv_policy::take_ownership)
      .def("save", &LoggerData::save, "filename"_a)
      .def("topics", &LoggerData::topics);
  nb::class_<Logger>(module, "Logger")
      .def_prop_ro("name", &Logger::name)
      .def("add_topic", &Logger::add_topic, "topic_name"_a, "log_size"_a, "divisor"_a = 1)
      .def("clear_topics", &Logger::clear_topics)
      .def("set_only_ts", &Logger::set_only_ts, "only_ts"_a)
      .def("enable", &Logger::enable)
      .def("disable", &Logger::disable)
      .def("manager_save", &Logger::manager_save, "filename"_a, "format"_a = "auto")
      .def(
          "download", [](Logger& self) { return self.download(false); }, nb::rv_policy::take_ownership)
      .def(
          "direct_download", [](Logger& self) { return self.download(true); }, nb::rv_policy::take_ownership);
  module.def(
      "get_logger",
      [with_client, ln_error](nb::object client, const std::string& name) {
        ln_logger handle = nullptr;
        with_client(client, [&](ln_client native) {
          const int ret = ln_client_get_logger(native, &handle, name.c_str());
          if (ret < 0) raise_ln_error(ln_error, ret, "get_logger('" + name + "')", native);
        });
        return new Logger(client, handle, name, with_client, ln_error);
      },
      "client"_a, "name"_a, nb::rv_policy::take_ownership,
      "The client's logger of that name (links_and_nodes.client.get_logger() wraps it).");
}

}  // namespace lnpy
