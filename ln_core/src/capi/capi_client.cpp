// ln.h: versions, errors, time and the client itself.
#include <time.h>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <mutex>
#include <set>
#include <string>

#include "capi/capi_support.hpp"

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

// Why the last ln_init* of this thread failed: no client exists to keep
// it (ln_get_error_message(NULL)).
thread_local std::string creation_error;

template <typename Create>
int init_with(ln_client* handle, Create&& create) noexcept {
  if (handle == nullptr) return -LNE_INVALID_PARAMETER;
  *handle = nullptr;
  creation_error.clear();
  return guarded(nullptr, [&] {
    try {
      std::unique_ptr<Client> client = create();
      register_client(client.get());
      *handle = client.release();
      return 0;
    } catch (const std::exception& e) {
      creation_error = e.what();
      throw;
    }
  });
}

}  // namespace

char* creation_error_text() { return creation_error.data(); }

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
  ln::capi::unregister_client(client);
  delete client;
  *clnt = nullptr;
  return 0;
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
  if (clnt_ == nullptr) return ln::capi::creation_error_text();
  Client* client = client_from(clnt_);
  return client != nullptr ? client->errors().text() : nullptr;
}

}  // extern "C"
