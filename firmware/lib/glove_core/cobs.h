// Consistent Overhead Byte Stuffing (Cheshire & Baker): the encoded bytes contain no 0x00, so 0x00 can delimit
// frames (docs/protocol.md). Overhead: one byte per 254 bytes of input, plus one.
#pragma once

#include <cstddef>
#include <cstdint>

namespace gc {

constexpr size_t cobs_max_encoded(size_t len) { return len + len / 254 + 1; }

// Encode `len` bytes into `out` (no delimiter appended). Returns the encoded length, or 0 when `cap` is too small.
size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t cap);

// Decode one chunk (without its 0x00 delimiter). Returns the decoded length, or -1 for invalid input (a 0x00
// inside, a code byte running past the end) or when `cap` is too small.
long cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t cap);

}  // namespace gc
