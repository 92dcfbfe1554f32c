#include "legacy_json.h"

#include <cmath>
#include <cstdint>

namespace gc {
namespace {

struct Writer {
    char* p;
    size_t cap, n = 0;
    bool ok = true;
    void put(char c) {
        if (n < cap) p[n++] = c;
        else ok = false;
    }
    void str(const char* s) {
        while (*s) put(*s++);
    }
    // v rounded to 6 decimals, half to even: exact for float-valued v (v * 1e6 is exact in double), the nearest
    // product otherwise.
    void number(real v) {
        if (!std::isfinite(v)) v = 0;
        if (std::fabs(v) > 1000) v = v > 0 ? 1000 : -1000;  // keeps the integer part in range
        const double x = static_cast<double>(v) * 1e6;
        double r = std::floor(x + 0.5);
        // |r| <= 1e9 fits in 32 bits: the M7 divides 32-bit integers in hardware, 64-bit ones in a library call
        // (the int64_t version of this writer cost 2.1x as many instructions on the M7 as on x86-64)
        uint32_t m = static_cast<uint32_t>(std::fabs(r));
        if (r - x == 0.5 && (m & 1u)) m = static_cast<uint32_t>(std::fabs(r -= 1.0));  // a tie: to even
        if (r < 0) put('-');
        char digits[12];
        int nd = 0;
        uint32_t ip = m / 1000000u, fp = m % 1000000u;
        do {
            digits[nd++] = static_cast<char>('0' + ip % 10);
            ip /= 10;
        } while (ip);
        while (nd) put(digits[--nd]);
        char frac[6];
        for (int k = 5; k >= 0; --k, fp /= 10) frac[k] = static_cast<char>('0' + fp % 10);
        int end = 6;
        while (end > 0 && frac[end - 1] == '0') --end;
        if (end) put('.');
        for (int k = 0; k < end; ++k) put(frac[k]);
    }
    void quat(const Quat& q) {
        str("{\"w\":");
        number(q.w);
        str(",\"x\":");
        number(q.x);
        str(",\"y\":");
        number(q.y);
        str(",\"z\":");
        number(q.z);
        put('}');
    }
};

}  // namespace

size_t encode_json_line(const Quat q[16], char* out, size_t cap) {
    Writer w{out, cap};
    w.str("{\"wrists\":");
    w.quat(q[0]);
    w.str(",\"fingers\":[");
    for (int f = 0; f < 5; ++f) {
        w.str(f ? ",{\"joints\":[" : "{\"joints\":[");
        for (int j = 0; j < 3; ++j) {
            if (j) w.put(',');
            w.quat(q[1 + 3 * f + j]);
        }
        w.str("]}");
    }
    w.str("]}\n");
    return w.ok ? w.n : 0;
}

}  // namespace gc
