// Glue between the extern "C" functions of ln.h and the C++ client core:
// handle checks, and turning exceptions into -LNE_* codes plus the detail
// text for ln_get_error_message(). Nothing may escape into C callers.
#pragma once

#include <cstdlib>
#include <cstring>
#include <new>
#include <string>

#include "client/c_api.hpp"
#include "client/client.hpp"
#include "client/failure.hpp"
#include "protocol/wire.hpp"
#include "transport/shm_segment.hpp"

namespace ln::capi {

using clientlib::Client;
using clientlib::Failure;

/// Records `client` as alive (ln_init) or gone (ln_deinit), so that stale or
/// foreign client handles are refused instead of followed.
void register_client(Client* client);
void unregister_client(Client* client);
/// The client behind a handle, or nullptr if it is not a live client.
Client* client_from(ln_client handle);

/// Runs `body` (returning an int >= 0) and maps failures to -LNE_* codes,
/// storing the detail in `slot` (when there is one).
template <typename Body>
int guarded_into(clientlib::ErrorSlot* slot, Body&& body) noexcept {
  auto record = [slot](int code, const std::string& text) noexcept {
    if (slot != nullptr) slot->set(text);
    return -code;
  };
  try {
    return body();
  } catch (const Failure& failure) {
    return record(failure.code(), failure.what());
  } catch (const protocol::ProtocolError& error) {
    return record(LNE_GOT_INVALID_RESPONSE, std::string("malformed answer from the ln_manager: ") + error.what());
  } catch (const transport::ShmError& error) {
    return record(LNE_SHM_READ_ERROR, error.what());
  } catch (const std::bad_alloc&) {
    return record(LNE_NO_MEM, "out of memory");
  } catch (const std::exception& error) {
    return record(LNE_INTERNAL_ERROR, error.what());
  } catch (...) {
    return record(LNE_INTERNAL_ERROR, "unexpected exception");
  }
}

/// guarded_into() the client's error slot (when there is a client).
template <typename Body>
int guarded(Client* client, Body&& body) noexcept {
  return guarded_into(client != nullptr ? &client->errors() : nullptr, std::forward<Body>(body));
}

/// The detail of this thread's last failed call that has no client (ln_init*,
/// ln_logger_data_*; "" when the last such call succeeded): what
/// ln_get_error_message(NULL) returns.
clientlib::ErrorSlot& clientless_errors() noexcept;

/// Runs `body()` for a call without client; the detail of a failure goes to
/// clientless_errors().
template <typename Body>
int clientless(Body&& body) noexcept {
  clientless_errors().clear();
  return guarded_into(&clientless_errors(), std::forward<Body>(body));
}

/// A malloc()ed copy for strings the caller frees. Throws bad_alloc.
inline char* malloc_copy(const std::string& text) {
  char* copy = static_cast<char*>(std::malloc(text.size() + 1));
  if (copy == nullptr) throw std::bad_alloc();
  std::memcpy(copy, text.c_str(), text.size() + 1);
  return copy;
}

/// Fails with LNE_INVALID_PARAMETER when a required argument is missing.
inline void require(bool present, const char* what) {
  if (!present) throw Failure(LNE_INVALID_PARAMETER, std::string(what) + " must not be NULL");
}

}  // namespace ln::capi
