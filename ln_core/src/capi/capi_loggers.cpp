// ln.h: topic loggers (ln_client_get_logger, ln_logger_*) and logger data
// (ln_logger_data_*). The work is in client/loggers.hpp and
// client/logger_data.hpp; the manager records (manager/loggers.hpp).
#include <utility>

#include "capi/capi_support.hpp"
#include "client/loggers.hpp"

using ln::capi::client_from;
using ln::capi::clientless;
using ln::capi::guarded;
using ln::capi::require;
using ln::clientlib::Client;
using ln::clientlib::ClientLoggers;
using ln::clientlib::Failure;
using ln::clientlib::Logger;
using ln::clientlib::LoggerData;

namespace {

/// Runs `body(logger)` for a live logger handle, its failures recorded on
/// the logger's client.
template <typename Body>
int with_logger(ln_logger handle, Body&& body) noexcept {
  if (!Logger::alive(handle)) return -LNE_INVALID_PARAMETER;
  Logger* logger = static_cast<Logger*>(handle);
  return guarded(&logger->client(), [&] { return body(*logger); });
}

LoggerData& live_data(ln_logger_data handle) {
  if (!LoggerData::alive(handle))
    throw Failure(LNE_INVALID_PARAMETER,
                  "not a logger data handle (or one that was freed or replaced by a later "
                  "download)");
  return *static_cast<LoggerData*>(handle);
}

}  // namespace

extern "C" {

int ln_client_get_logger(ln_client clnt, ln_logger* logger, const char* logger_name) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    require(logger != nullptr, "logger");
    require(logger_name != nullptr, "logger_name");
    auto loggers = std::static_pointer_cast<ClientLoggers>(
        client->part_state("loggers", [client] { return std::make_shared<ClientLoggers>(*client); }));
    *logger = loggers->get(logger_name);
    return 0;
  });
}

int ln_logger_add_topic(ln_logger logger, const char* topic_name, unsigned int log_size, unsigned int divisor) {
  return ln_logger_add_topic64(logger, topic_name, log_size, divisor);
}

int ln_logger_add_topic64(ln_logger logger, const char* topic_name, uint64_t log_size, unsigned int divisor) {
  return with_logger(logger, [&](Logger& it) {
    require(topic_name != nullptr, "topic_name");
    it.add_topic(topic_name, log_size, divisor);
    return 0;
  });
}

int ln_logger_clear_topics(ln_logger logger) {
  return with_logger(logger, [](Logger& it) {
    it.clear_topics();
    return 0;
  });
}

int ln_logger_set_only_ts(ln_logger logger, int only_ts) {
  return with_logger(logger, [&](Logger& it) {
    it.set_only_ts(only_ts != 0);
    return 0;
  });
}

int ln_logger_enable(ln_logger logger) {
  return with_logger(logger, [](Logger& it) {
    it.enable();
    return 0;
  });
}

int ln_logger_disable(ln_logger logger) {
  return with_logger(logger, [](Logger& it) {
    it.disable();
    return 0;
  });
}

int ln_logger_download(ln_logger logger, ln_logger_data* logger_data) {
  return with_logger(logger, [&](Logger& it) {
    require(logger_data != nullptr, "logger_data");
    *logger_data = it.download();
    return 0;
  });
}

int ln_logger_direct_download(ln_logger logger, ln_logger_data* logger_data) {
  return with_logger(logger, [&](Logger& it) {
    require(logger_data != nullptr, "logger_data");
    *logger_data = it.direct_download();
    return 0;
  });
}

int ln_logger_manager_save(ln_logger logger, const char* filename, const char* format) {
  return with_logger(logger, [&](Logger& it) {
    require(filename != nullptr, "filename");
    it.manager_save(filename, format != nullptr ? format : "auto");
    return 0;
  });
}

int ln_logger_data_save(ln_logger_data logger_data, const char* filename) {
  return clientless([&] {
    require(filename != nullptr, "filename");
    live_data(logger_data).save(filename);
    return 0;
  });
}

int ln_logger_data_load(ln_logger_data* logger_data, const char* filename) {
  return clientless([&] {
    require(logger_data != nullptr, "logger_data");
    require(filename != nullptr, "filename");
    *logger_data = LoggerData::load(filename).release();
    return 0;
  });
}

int ln_logger_data_deinit(ln_logger_data* logger_data) {
  return clientless([&] {
    require(logger_data != nullptr, "logger_data");
    LoggerData& data = live_data(*logger_data);
    if (!data.loaded())
      throw Failure(LNE_INVALID_PARAMETER,
                    "downloaded logger data belongs to its logger; only data from "
                    "ln_logger_data_load() is freed with ln_logger_data_deinit()");
    delete &data;
    *logger_data = nullptr;
    return 0;
  });
}

int ln_logger_data_copy(ln_logger_data logger_data, ln_logger_data* copy) {
  return clientless([&] {
    require(copy != nullptr, "copy");
    *copy = live_data(logger_data).copy().release();
    return 0;
  });
}

int ln_logger_data_get_info(ln_logger_data logger_data, unsigned int* n_topics) {
  return clientless([&] {
    require(n_topics != nullptr, "n_topics");
    *n_topics = static_cast<unsigned int>(live_data(logger_data).size());
    return 0;
  });
}

int ln_logger_data_get_topic(ln_logger_data logger_data, unsigned int topic_id, logger_topic** topic) {
  return clientless([&] {
    require(topic != nullptr, "topic");
    LoggerData& data = live_data(logger_data);
    logger_topic* found = data.topic(topic_id);
    if (found == nullptr)
      throw Failure(LNE_TOPIC_ID_OUT_OF_RANGE, "topic id " + std::to_string(topic_id) +
                                                   " is out of range: the "
                                                   "data has " +
                                                   std::to_string(data.size()) + " topic(s)");
    *topic = found;
    return 0;
  });
}

}  // extern "C"
