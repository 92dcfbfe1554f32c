#include "cobs.h"

namespace gc {

size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out, size_t cap) {
    if (cap < cobs_max_encoded(len)) return 0;
    size_t code_at = 0, o = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < len; ++i) {
        if (in[i] != 0) {
            out[o++] = in[i];
            ++code;
        }
        if (in[i] == 0 || code == 0xFF) {
            out[code_at] = code;
            code = 1;
            code_at = o++;
            // A full 254-byte block at the very end needs no trailing code byte (as Python's cobs module).
            if (in[i] != 0 && i + 1 == len) return o - 1;
        }
    }
    out[code_at] = code;
    return o;
}

long cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t cap) {
    size_t i = 0, o = 0;
    while (i < len) {
        const uint8_t code = in[i++];
        if (code == 0 || i + code - 1 > len) return -1;
        for (uint8_t k = 1; k < code; ++k) {
            if (in[i] == 0 || o >= cap) return -1;
            out[o++] = in[i++];
        }
        if (code != 0xFF && i < len) {
            if (o >= cap) return -1;
            out[o++] = 0;
        }
    }
    return static_cast<long>(o);
}

}  // namespace gc
