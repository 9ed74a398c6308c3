// The detail text behind a client's last failure (ln_get_error_message).
#pragma once

#include <cstring>
#include <mutex>
#include <string>

namespace ln::clientlib {

class ErrorSlot {
 public:
  /// Keeps `text` (cut to the buffer size). Thread-safe.
  void set(const std::string& text) noexcept { set(text.data(), text.size()); }
  void set(const char* text) noexcept { set(text, std::strlen(text)); }
  void set(const char* text, std::size_t size) noexcept {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::size_t n = size < sizeof(text_) - 1 ? size : sizeof(text_) - 1;
    std::memcpy(text_, text, n);
    text_[n] = '\0';
  }
  void clear() noexcept { set(std::string()); }
  /// The buffer stays at this address for the client's lifetime; its
  /// content changes with the next failure (as documented in ln.h).
  char* text() noexcept { return text_; }

 private:
  std::mutex mutex_;
  char text_[4096] = {};
};

}  // namespace ln::clientlib
