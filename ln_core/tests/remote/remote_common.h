// Shared by the remote transfer test programs: the payload pattern.
#pragma once
#include <stddef.h>
#include <stdint.h>

// Byte i of the padding of packet (epoch, seq).
static inline uint8_t remote_pattern(uint32_t epoch, uint32_t seq, size_t i) {
  return (uint8_t)(epoch * 131u + seq * 7u + (uint32_t)i * 13u + (uint32_t)(i >> 8));
}
