// CRC-32/ISO-HDLC (zlib's crc32): reflected polynomial 0xEDB88320, init and xor-out 0xFFFFFFFF.
// Check value of "123456789": 0xCBF43926 (docs/protocol.md).
#pragma once

#include <cstddef>
#include <cstdint>

namespace gc {

// CRC of `len` bytes. Chain calls by passing the previous result as `crc` (start with 0, as zlib).
uint32_t crc32(const uint8_t* data, size_t len, uint32_t crc = 0);

}  // namespace gc
