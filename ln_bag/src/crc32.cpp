#include "crc32.hpp"

#include <zlib.h>

#include <algorithm>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace ln_bag {
namespace {

std::uint32_t zlib_crc32(std::uint32_t running, const std::uint8_t* data, std::size_t size) {
  while (size > 0) {
    const uInt n = static_cast<uInt>(std::min<std::size_t>(size, 1u << 30));
    running = static_cast<std::uint32_t>(::crc32(running, data, n));
    data += n;
    size -= n;
  }
  return running;
}

#if defined(__x86_64__)
// Folding by 4 x 128 bits, then by 128 bits (the constants are x^(512+32), x^(512-32),
// x^(128+32), x^(128-32) mod the bit-reflected polynomial, as in Intel's "Fast CRC
// Computation for Generic Polynomials Using PCLMULQDQ"); the folded 16 bytes have the
// message's remainder, which zlib finishes.
__attribute__((target("pclmul,sse4.1"))) inline __m128i fold(__m128i x, __m128i k, __m128i next) {
  return _mm_xor_si128(_mm_xor_si128(_mm_clmulepi64_si128(x, k, 0x00), _mm_clmulepi64_si128(x, k, 0x11)), next);
}

__attribute__((target("pclmul,sse4.1"))) inline __m128i load(const std::uint8_t* p) {
  return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
}

__attribute__((target("pclmul,sse4.1"))) std::uint32_t clmul_crc32(std::uint32_t running, const std::uint8_t* p,
                                                                   std::size_t n) {
  const __m128i by512 = _mm_set_epi64x(0x1c6e41596, 0x154442bd4);
  const __m128i by128 = _mm_set_epi64x(0x0ccaa009e, 0x1751997d0);
  __m128i x1 = _mm_xor_si128(load(p), _mm_cvtsi32_si128(static_cast<int>(~running)));
  __m128i x2 = load(p + 16), x3 = load(p + 32), x4 = load(p + 48);
  p += 64;
  n -= 64;
  for (; n >= 64; p += 64, n -= 64) {
    x1 = fold(x1, by512, load(p));
    x2 = fold(x2, by512, load(p + 16));
    x3 = fold(x3, by512, load(p + 32));
    x4 = fold(x4, by512, load(p + 48));
  }
  x1 = fold(fold(fold(x1, by128, x2), by128, x3), by128, x4);
  for (; n >= 16; p += 16, n -= 16) x1 = fold(x1, by128, load(p));
  alignas(16) std::uint8_t folded[16];
  _mm_store_si128(reinterpret_cast<__m128i*>(folded), x1);
  // zlib with an all-ones start is the raw remainder of `folded` (inverted as zlib's result is)
  return zlib_crc32(zlib_crc32(0xFFFFFFFFu, folded, 16), p, n);
}

const bool has_clmul = __builtin_cpu_supports("pclmul") && __builtin_cpu_supports("sse4.1");
#endif

}  // namespace

std::uint32_t crc32(std::uint32_t running, const std::uint8_t* data, std::size_t size) {
#if defined(__x86_64__)
  if (has_clmul && size >= 64) return clmul_crc32(running, data, size);
#endif
  return zlib_crc32(running, data, size);
}

std::uint32_t crc32_combine(std::uint32_t first, std::uint32_t second, std::size_t second_size) {
  return static_cast<std::uint32_t>(::crc32_combine(first, second, static_cast<z_off_t>(second_size)));
}

}  // namespace ln_bag
