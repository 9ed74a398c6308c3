// CRC-32 (IEEE 802.3, as zlib's crc32() and MCAP use it), with carry-less
// multiplication (PCLMULQDQ) where the CPU has it: about twice zlib's speed
// here, which is what a recorder checksumming every chunk needs.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ln_bag {

/// crc32(running, data, size) as zlib computes it (running 0 to start).
std::uint32_t crc32(std::uint32_t running, const std::uint8_t* data, std::size_t size);
/// The CRC of A then B from crc32(A), crc32(B) and B's size (zlib's crc32_combine).
std::uint32_t crc32_combine(std::uint32_t first, std::uint32_t second, std::size_t second_size);

}  // namespace ln_bag
