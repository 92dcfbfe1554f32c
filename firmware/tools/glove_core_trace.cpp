// glove_core_trace: a fixed run of the whole glove core whose every output is printed exactly, so that two
// builds (the emulated Cortex-M7 and the host: ctest m7_matches_host) can be compared byte for byte.
//
//   glove_core_trace        (no arguments; prints to stdout)
//
// For each output mode (raw, pose, json, compact) one gc::Glove runs 1200 cycles at 200 Hz: still for the
// boot-time gyro calibration, then 12 IMUs moving, with a missing IMU, a saturated sample and a button press.
// The inputs are made with integer arithmetic only (a libm of either side cannot change them). Printed: the
// CRC-32 and length of every frame the glove sends, and every 10 cycles each IMU's filter quaternion as the
// hexadecimal bit pattern of its scalar type (a last-bit difference shows).
#include <cstdio>
#include <cstring>

#include "glove_core.h"

namespace {

using namespace gc;

constexpr int kImus = 12, kCycles = 1200, kStill = 300, kRateHz = 200;

struct PrintSink final : FrameSink {
    uint32_t frames = 0;
    bool write(const uint8_t* data, size_t len) override {
        std::printf("f %08lx %u\n", static_cast<unsigned long>(crc32(data, len)), static_cast<unsigned>(len));
        ++frames;
        return true;
    }
};

// a triangle wave of integers in [-amp, amp] with the given period (cycles) and phase
int32_t triangle(int32_t k, int32_t period, int32_t phase, int32_t amp) {
    const int32_t p = (k + phase) % period;
    const int32_t half = period / 2;
    const int32_t up = p < half ? p : period - p;  // 0 .. half
    return (4 * amp * up) / period - amp;
}

int16_t clamp16(int32_t v) { return static_cast<int16_t>(v > 32767 ? 32767 : (v < -32768 ? -32768 : v)); }

// register counts of IMU i in cycle k: +-16 g (2048 counts/g), +-2000 dps (16.4 counts per deg/s)
void sample(int32_t k, int16_t raw[kImus][7], uint32_t& lcg) {
    for (int32_t i = 0; i < kImus; ++i) {
        lcg = lcg * 1664525u + 1013904223u;
        const int32_t noise = static_cast<int32_t>(lcg >> 29) - 4;  // -4 .. 3 counts
        const bool moving = k >= kStill;
        const int32_t m = moving ? k - kStill : 0;
        const int32_t gx = moving ? triangle(m, 97 + 7 * i, 5 * i, 3000) : 0;
        const int32_t gy = moving ? triangle(m, 131 + 3 * i, 11 * i, 5000 + 300 * i) : 0;
        const int32_t gz = moving ? triangle(m, 173, 13 * i, 1500) : 0;
        const int32_t tilt = moving ? triangle(m, 211, 3 * i, 900) : 0;
        raw[i][0] = clamp16(tilt + noise);
        raw[i][1] = clamp16(-tilt / 2 + noise);
        raw[i][2] = clamp16(2048 - (tilt * tilt) / 4096 + noise);
        raw[i][3] = clamp16(gx + noise);
        raw[i][4] = clamp16(gy - noise);
        raw[i][5] = clamp16(gz + noise);
        raw[i][6] = clamp16(1335 + noise);
    }
    if (k == kStill + 400) raw[4][4] = 32767;  // a saturated gyro
}

template <typename T>
void print_bits(T v) {
    if constexpr (sizeof(T) == 8) {
        uint32_t b[2];  // halves, high first (both targets are little-endian)
        std::memcpy(b, &v, sizeof b);
        std::printf(" %08lx%08lx", static_cast<unsigned long>(b[1]), static_cast<unsigned long>(b[0]));
    } else {
        uint32_t b;
        std::memcpy(&b, &v, sizeof b);
        std::printf(" %08lx", static_cast<unsigned long>(b));
    }
}

void run(Mode mode, const char* name) {
    static Glove glove;  // static: a Glove holds frame buffers, too big for a small stack
    PrintSink sink;
    GloveSettings s;
    s.sense_rate_hz = kRateHz;
    s.output_rate_hz = 100;
    s.mode = mode;
    glove.init(s, &sink);
    std::printf("mode %s\n", name);
    glove.begin(0);
    uint32_t lcg = 12345u;
    int16_t raw[kImus][7];
    for (int32_t k = 0; k < kCycles; ++k) {
        const uint32_t t_us = static_cast<uint32_t>((k + 1) * (1000000 / kRateHz));
        sample(k, raw, lcg);
        if (k == kStill + 700) glove.button(t_us);  // the reset button: a new reference pose
        const uint16_t ok = (k >= kStill + 200 && k < kStill + 230) ? 0xFFF & ~(1u << 7) : 0xFFF;  // IMU 7 away
        glove.sense(t_us, raw, ok);
        if (k % 10 == 9) {
            std::printf("q %ld", static_cast<long>(k));
            for (uint8_t i = 0; i < kImus; ++i) {
                const Quat q = glove.hand().filter(i).quaternion();
                print_bits(q.w), print_bits(q.x), print_bits(q.y), print_bits(q.z);
            }
            std::printf("\n");
        }
    }
    std::printf("end %s: %lu frames, dropped %lu, calibration %d\n", name, static_cast<unsigned long>(sink.frames),
                static_cast<unsigned long>(glove.dropped_frames()), static_cast<int>(glove.calib_state()));
}

}  // namespace

int main() {
    run(Mode::Raw, "raw");
    run(Mode::Pose, "pose");
    run(Mode::Json, "json");
    run(Mode::Compact, "compact");
    return 0;
}
