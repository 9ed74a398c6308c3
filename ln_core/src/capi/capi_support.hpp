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
/// Why the last ln_init* of this thread failed (ln_get_error_message(NULL)).
char* creation_error_text();
/// The client behind a handle, or nullptr if it is not a live client.
Client* client_from(ln_client handle);

/// Runs `body` (returning an int >= 0) and maps failures to -LNE_* codes,
/// storing the detail in the client's error slot (when there is a client).
template <typename Body>
int guarded(Client* client, Body&& body) noexcept {
  auto record = [client](int code, const std::string& text) noexcept {
    if (client != nullptr) client->errors().set(text);
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
