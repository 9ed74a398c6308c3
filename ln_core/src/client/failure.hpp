// How the client library reports errors internally: set-up code throws a
// Failure (an LN error code plus the detail for ln_get_error_message); the C
// API turns it into the negative return value. The data path (read, write)
// never throws and returns codes directly.
#pragma once

#include <stdexcept>
#include <string>

namespace ln::clientlib {

class Failure : public std::runtime_error {
 public:
  /// `code` is a positive LNE_* value.
  Failure(int code, const std::string& detail) : std::runtime_error(detail), code_(code) {}
  int code() const noexcept { return code_; }

 private:
  int code_;
};

/// A Failure with code LNE_CHECK_ERRNO that also remembers `sys_errno`, so
/// that ln_format_error() can name it later in this thread (LN 2.9 formats
/// that code as "errno N - text").
Failure errno_failure(int sys_errno, const std::string& what);

/// Records `sys_errno` as the errno behind the next LNE_CHECK_ERRNO of this
/// thread (also sets errno itself, as LN 2.9 leaves it).
void remember_errno(int sys_errno) noexcept;

/// LN's text for an error code (positive or negative); never null. The text
/// for LNE_CHECK_ERRNO names the errno remembered in this thread.
const char* error_text(int code) noexcept;

}  // namespace ln::clientlib
