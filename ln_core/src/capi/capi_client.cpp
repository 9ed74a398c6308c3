// ln.h: versions, errors, time and the client itself.
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstring>
#include <mutex>
#include <set>
#include <string>

#include "capi/capi_support.hpp"
#include "parameters/provider.hpp"

namespace ln::capi {
namespace {

std::mutex& live_clients_mutex() {
  static std::mutex mutex;
  return mutex;
}

std::set<Client*>& live_clients() {
  static std::set<Client*> clients;
  return clients;
}

// The detail of this thread's last failed call without a client (ln_init*,
// ln_logger_data_*): no client exists to keep it (ln_get_error_message(NULL)).
thread_local clientlib::ErrorSlot clientless_slot;

template <typename Create>
int init_with(ln_client* handle, Create&& create) noexcept {
  if (handle == nullptr) return -LNE_INVALID_PARAMETER;
  *handle = nullptr;
  return clientless([&] {
    std::unique_ptr<Client> client = create();
    register_client(client.get());
    *handle = client.release();
    return 0;
  });
}

}  // namespace

clientlib::ErrorSlot& clientless_errors() noexcept { return clientless_slot; }

void register_client(Client* client) {
  std::lock_guard<std::mutex> lock(live_clients_mutex());
  live_clients().insert(client);
}

void unregister_client(Client* client) {
  std::lock_guard<std::mutex> lock(live_clients_mutex());
  live_clients().erase(client);
}

Client* client_from(ln_client handle) {
  auto* client = static_cast<Client*>(handle);
  std::lock_guard<std::mutex> lock(live_clients_mutex());
  return live_clients().count(client) != 0 ? client : nullptr;
}

}  // namespace ln::capi

using ln::capi::client_from;
using ln::capi::guarded;
using ln::clientlib::Client;

extern "C" {

int ln_get_library_version(void) { return LN_LIBRARY_VERSION; }

const char* ln_format_error(int ret) { return ln::clientlib::error_text(ret); }

double ln_get_time(void) {
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  return static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
}

double ln_get_monotonic_time(void) {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
}

void ln_sleep_seconds(double seconds) {
  if (!(seconds > 0)) return;
  timespec remaining{};
  remaining.tv_sec = static_cast<time_t>(std::min(seconds, 1e9));
  remaining.tv_nsec = static_cast<long>((seconds - std::floor(seconds)) * 1e9);
  while (::nanosleep(&remaining, &remaining) != 0 && errno == EINTR) {
  }
}

int ln_init(ln_client* clnt, const char* client_name, int argc, char** argv) {
  return ln::capi::init_with(clnt, [&] { return Client::create(client_name, argc, argv); });
}

int ln_init_to_manager(ln_client* clnt, const char* client_name, const char* ln_manager) {
  return ln::capi::init_with(clnt, [&] { return Client::create_to_manager(client_name, ln_manager); });
}

int ln_client_get_name(ln_client clnt, char** name) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  if (name == nullptr) return -LNE_INVALID_PARAMETER;
  *name = const_cast<char*>(client->name());
  return 0;
}

int ln_deinit(ln_client* clnt) {
  if (clnt == nullptr) return -LNE_INVALID_PARAMETER;
  Client* client = client_from(*clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  ln::paramcore::client_closing(*clnt);  // its parameter services, while it can still release them
  ln::capi::unregister_client(client);
  delete client;
  *clnt = nullptr;
  return 0;
}

// LN 2.9's client settings: "debug" (level), "reconnect_interval" (seconds),
// the Windows-only "win32_*" timings (accepted, without effect here, as in
// LN 2.9 on Linux) and "__LN_CPP_WRAPPER_VERSION" (its C++ wrapper's
// version check; needs no client).
int ln_client_set_float_parameter(ln_client clnt, const char* name, float value) {
  if (name != nullptr && std::strcmp(name, "__LN_CPP_WRAPPER_VERSION") == 0) return 0;
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    ln::capi::require(name != nullptr, "name");
    const std::string setting = name;
    if (setting == "debug") {
      client->set_debug_level(std::isfinite(value) ? static_cast<int>(value) : 0);
    } else if (setting == "reconnect_interval") {
      if (!(value > 0) || !std::isfinite(value) || value > 3600)
        throw ln::clientlib::Failure(
            LNE_INVALID_PARAMETER,
            "reconnect_interval must be between 0 and 3600 seconds, not " + std::to_string(value));
      client->set_reconnect_interval(std::chrono::milliseconds(std::max(1L, std::lround(value * 1000.0))));
    } else if (setting != "win32_async_ping_timeout" && setting != "win32_async_ping_interval" &&
               setting != "win32_wait_for_service_request_timeout") {
      throw ln::clientlib::Failure(LNE_UNKNOWN_PARAMETER,
                                   "unknown client setting '" + setting +
                                       "' (debug, reconnect_interval, win32_async_ping_timeout, "
                                       "win32_async_ping_interval, win32_wait_for_service_request_timeout)");
    }
    return 0;
  });
}

void ln_debug(ln_client clnt_, const char* format, ...) {
  Client* client = client_from(clnt_);
  if (client == nullptr || format == nullptr || !client->debugging()) return;
  va_list args;
  va_start(args, format);
  client->vdebug(format, args);
  va_end(args);
}

int ln_ping(ln_client clnt, double timeout, double* rtt) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  return guarded(client, [&] {
    const double measured = client->ping(timeout);
    if (rtt != nullptr) *rtt = measured;
    return 0;
  });
}

int ln_client_set_thread_safe(ln_client clnt, int enable) {
  (void)enable;  // set-up calls are always serialised internally
  return client_from(clnt) != nullptr ? 0 : -LNE_CLIENT_NOT_INITIALIZED;
}

int ln_get_remaining_args(ln_client clnt, unsigned int* n_args, char** args_ptr) {
  Client* client = client_from(clnt);
  if (client == nullptr) return -LNE_CLIENT_NOT_INITIALIZED;
  if (n_args != nullptr) *n_args = static_cast<unsigned int>(client->remaining_args().size());
  if (args_ptr != nullptr) *args_ptr = const_cast<char*>(client->remaining_args_block().data());
  return 0;
}

char* ln_get_error_message(ln_client clnt_) {
  Client* client = clnt_ != nullptr ? client_from(clnt_) : nullptr;
  return client != nullptr ? client->errors().text() : ln::capi::clientless_errors().text();
}

}  // extern "C"
