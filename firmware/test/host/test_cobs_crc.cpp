// CRC-32/ISO-HDLC and COBS vectors (docs/protocol.md).
#include <cstring>

#include "check.h"
#include "cobs.h"
#include "crc32.h"
#include "helpers.h"

using namespace gc;

namespace {

bool encodes_to(const uint8_t* in, size_t n, const uint8_t* expect, size_t m) {
    uint8_t out[600];
    const size_t k = cobs_encode(in, n, out, sizeof out);
    if (k != m || std::memcmp(out, expect, m) != 0) return false;
    uint8_t back[600];
    const long d = cobs_decode(out, k, back, sizeof back);
    return d == static_cast<long>(n) && std::memcmp(back, in, n) == 0;
}

}  // namespace

TEST(crc32_check_value) {
    const char* s = "123456789";
    CHECK(crc32(reinterpret_cast<const uint8_t*>(s), 9) == 0xCBF43926u);
    CHECK(crc32(nullptr, 0) == 0u);
    const uint8_t a = 'a';
    CHECK(crc32(&a, 1) == 0xE8B7BE43u);  // zlib.crc32(b"a")
    // chaining as zlib: crc32(b"6789", crc32(b"12345")) == crc32(b"123456789")
    const uint32_t part = crc32(reinterpret_cast<const uint8_t*>(s), 5);
    CHECK(crc32(reinterpret_cast<const uint8_t*>(s) + 5, 4, part) == 0xCBF43926u);
}

TEST(cobs_wikipedia_vectors) {
    {
        const uint8_t in[] = {0x00}, out[] = {0x01, 0x01};
        CHECK(encodes_to(in, 1, out, 2));
    }
    {
        const uint8_t in[] = {0x00, 0x00}, out[] = {0x01, 0x01, 0x01};
        CHECK(encodes_to(in, 2, out, 3));
    }
    {
        const uint8_t in[] = {0x00, 0x11, 0x00}, out[] = {0x01, 0x02, 0x11, 0x01};
        CHECK(encodes_to(in, 3, out, 4));
    }
    {
        const uint8_t in[] = {0x11, 0x22, 0x00, 0x33}, out[] = {0x03, 0x11, 0x22, 0x02, 0x33};
        CHECK(encodes_to(in, 4, out, 5));
    }
    {
        const uint8_t in[] = {0x11, 0x22, 0x33, 0x44}, out[] = {0x05, 0x11, 0x22, 0x33, 0x44};
        CHECK(encodes_to(in, 4, out, 5));
    }
    {
        const uint8_t in[] = {0x11, 0x00, 0x00, 0x00}, out[] = {0x02, 0x11, 0x01, 0x01, 0x01};
        CHECK(encodes_to(in, 4, out, 5));
    }
    {
        const uint8_t out[] = {0x01};
        CHECK(encodes_to(nullptr, 0, out, 1));
    }
}

TEST(cobs_254_byte_blocks) {
    uint8_t in[300], out[300];
    // 01..FE (254 bytes) -> FF 01..FE: a full block at the end takes no trailing code byte
    for (int i = 0; i < 254; ++i) in[i] = static_cast<uint8_t>(i + 1);
    out[0] = 0xFF;
    std::memcpy(out + 1, in, 254);
    CHECK(encodes_to(in, 254, out, 255));
    // 00 01..FE -> 01 FF 01..FE
    uint8_t in2[255];
    in2[0] = 0;
    std::memcpy(in2 + 1, in, 254);
    uint8_t out2[256] = {0x01, 0xFF};
    std::memcpy(out2 + 2, in, 254);
    CHECK(encodes_to(in2, 255, out2, 256));
    // 01..FF (255 bytes) -> FF 01..FE 02 FF
    for (int i = 0; i < 255; ++i) in[i] = static_cast<uint8_t>(i + 1);
    uint8_t out3[257];
    out3[0] = 0xFF;
    std::memcpy(out3 + 1, in, 254);
    out3[255] = 0x02;
    out3[256] = 0xFF;
    CHECK(encodes_to(in, 255, out3, 257));
    // 02..FF 00 -> FF 02..FF 01 01
    for (int i = 0; i < 254; ++i) in[i] = static_cast<uint8_t>(i + 2);
    in[254] = 0;
    uint8_t out4[257];
    out4[0] = 0xFF;
    std::memcpy(out4 + 1, in, 254);
    out4[255] = 0x01;
    out4[256] = 0x01;
    CHECK(encodes_to(in, 255, out4, 257));
}

TEST(cobs_roundtrip_random_and_no_zero_inside) {
    testing_helpers::Rng rng;
    uint8_t in[1100], enc[1200], dec[1100];
    for (int n = 0; n < 300; ++n) {
        const size_t len = static_cast<size_t>((rng.next() + 1.0f) * 540.0f);
        const bool sparse = n % 2;
        for (size_t i = 0; i < len; ++i) {
            const float r = rng.next();
            in[i] = sparse && r > -0.3f ? 0 : static_cast<uint8_t>((r + 1.0f) * 127.9f);
        }
        const size_t k = cobs_encode(in, len, enc, sizeof enc);
        CHECK(k > 0 && k <= cobs_max_encoded(len));
        CHECK(std::memchr(enc, 0, k) == nullptr);
        CHECK(cobs_decode(enc, k, dec, sizeof dec) == static_cast<long>(len));
        CHECK(std::memcmp(in, dec, len) == 0);
    }
}

TEST(cobs_rejects_bad_input_and_small_buffers) {
    uint8_t out[16];
    const uint8_t zero_inside[] = {0x03, 0x11, 0x00};
    CHECK(cobs_decode(zero_inside, 3, out, sizeof out) == -1);
    const uint8_t overrun[] = {0x05, 0x11, 0x22};
    CHECK(cobs_decode(overrun, 3, out, sizeof out) == -1);
    const uint8_t code_zero[] = {0x00};
    CHECK(cobs_decode(code_zero, 1, out, sizeof out) == -1);
    const uint8_t ok[] = {0x05, 0x11, 0x22, 0x33, 0x44};
    CHECK(cobs_decode(ok, 5, out, 3) == -1);  // does not fit
    const uint8_t in[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    CHECK(cobs_encode(in, 8, out, 8) == 0);   // needs 9
    CHECK(cobs_encode(in, 8, out, 9) == 9);
}

TEST_MAIN()
