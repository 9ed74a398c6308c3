// SHA-256 (FIPS 180-4): LN names definition versions by this digest.
#pragma once

#include <string>
#include <string_view>

namespace ln::md {

/// Lower-case hex digest of `data`.
std::string sha256_hex(std::string_view data);

}  // namespace ln::md
