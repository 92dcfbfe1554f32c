// glove_core_bench: a fixed workload for bench/firmware.py to count instructions with valgrind/callgrind.
//
//   glove_core_bench WHAT CYCLES
//     filter  12 complementary-filter updates per cycle (median filter + eq. 3.4-3.19)
//     pose    parent-relative pose (eq. 3.21, 3.3) + pose frame encoding (CRC, COBS) per cycle
//     cycle   filter + pose: one 12-IMU sensing cycle that also sends a pose frame
//     glove   gc::Glove::sense on register counts with a pose frame every cycle (everything the loop does
//             besides I2C and the serial port)
//     json    parent-relative pose + legacy JSON line per cycle
//     compact parent-relative pose + 20 joint angles + pose_compact frame per cycle
// Inputs are precomputed at start-up, so a run with CYCLES = 0 measures the start-up alone; bench/firmware.py
// subtracts it. Prints a checksum so the work cannot be optimised away.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "glove_core.h"

using namespace gc;

namespace {

constexpr int kN = 12, kTable = 64;
Vec3 g_gyro[kTable][kN], g_accel[kTable][kN];
int16_t g_raw[kTable][kN][7];

struct NullSink final : FrameSink {
    uint32_t sum = 0;
    bool write(const uint8_t* d, size_t n) override {
        sum += d[n / 2] + static_cast<uint32_t>(n);
        return true;
    }
};

void make_inputs() {
    for (int k = 0; k < kTable; ++k)
        for (int i = 0; i < kN; ++i) {
            const float t = 0.01f * k + 0.1f * i;
            g_gyro[k][i] = {0.8f * std::sin(t), 0.5f * std::cos(2 * t), 0.3f * std::sin(3 * t)};
            g_accel[k][i] = {0.2f * std::sin(t), 0.1f * std::cos(t), 0.97f + 0.05f * std::sin(5 * t)};
            for (int c = 0; c < 3; ++c) {
                g_raw[k][i][c] = counts_from_g((&g_accel[k][i].x)[c], 16);
                g_raw[k][i][3 + c] = counts_from_rad_s((&g_gyro[k][i].x)[c], 2000);
            }
            g_raw[k][i][6] = 1335;
        }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: glove_core_bench filter|pose|cycle|glove|json|compact CYCLES\n");
        return 2;
    }
    const char* what = argv[1];
    const long cycles = std::atol(argv[2]);
    const bool do_filter = !std::strcmp(what, "filter") || !std::strcmp(what, "cycle");
    const bool do_pose = !std::strcmp(what, "pose") || !std::strcmp(what, "cycle");
    const bool do_glove = !std::strcmp(what, "glove"), do_json = !std::strcmp(what, "json");
    const bool do_compact = !std::strcmp(what, "compact");
    if (!do_filter && !do_pose && !do_glove && !do_json && !do_compact) {
        std::fprintf(stderr, "unknown workload %s\n", what);
        return 2;
    }
    make_inputs();

    static Hand hand;
    const uint8_t joint[kN] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};
    hand.init(HandSettings{}, kN, joint);
    for (int i = 0; i < kN; ++i)
        for (int k = 0; k < 12; ++k) hand.observe(static_cast<uint8_t>(i), g_accel[k][i]);
    hand.reset_pose();

    static Glove glove;
    NullSink sink;
    GloveSettings gs;
    gs.sense_rate_hz = 1000;
    gs.output_rate_hz = 1000;
    gs.calibrate_at_boot = false;
    glove.init(gs, &sink);
    glove.begin(0);
    glove.sense(1000, g_raw[0], 0xFFF);  // first cycle: attitude from gravity

    static uint8_t frame[kMaxWire];
    static char line[kMaxJsonLine];
    uint32_t sum = 0;
    for (long c = 0; c < cycles; ++c) {
        const int k = static_cast<int>(c % kTable);
        if (do_glove) {
            glove.sense(static_cast<uint32_t>(2000 + 1000 * c), g_raw[k], 0xFFF);
            continue;
        }
        if (do_filter)
            for (int i = 0; i < kN; ++i) hand.update(static_cast<uint8_t>(i), g_gyro[k][i], g_accel[k][i], 0.001f);
        if (do_pose || do_json) {
            Quat rel[kSegments];
            hand.relative_pose(rel);
            const size_t n = do_json ? encode_json_line(rel, line, sizeof line)
                                     : encode_pose(static_cast<uint16_t>(c), static_cast<uint32_t>(c), rel,
                                                   hand.measured_mask(), frame, sizeof frame);
            sum += static_cast<uint32_t>(n) + (do_json ? static_cast<uint8_t>(line[n / 2]) : frame[n / 2]);
        }
        if (do_compact) {
            Quat rel[kSegments];
            real angles[kJoints];
            hand.relative_pose(rel);
            joint_angles(rel, angles);
            const size_t n = encode_pose_compact(static_cast<uint16_t>(c), static_cast<uint32_t>(c), rel[0], angles,
                                                 frame, sizeof frame);
            sum += static_cast<uint32_t>(n) + frame[n / 2];
        }
    }
    const Quat q = hand.filter(3).quaternion();
    std::printf("checksum %u %u %.6f\n", sum, sink.sum, static_cast<double>(q.w + glove.hand().filter(3).quaternion().w));
    return 0;
}
