// glove_core_bench: a fixed workload for bench/firmware.py to count instructions with valgrind/callgrind.
//
//   glove_core_bench WHAT CYCLES
//     filter  12 filter updates per cycle (the default, FilterMode::Inertial)
//     filter_thesis  the same with the thesis' filter (FilterMode::Thesis: median filter + eq. 3.4-3.19)
//     pose    parent-relative pose (eq. 3.21, 3.3) + pose frame encoding (CRC, COBS) per cycle
//     cycle   filter + pose: one 12-IMU sensing cycle that also sends a pose frame
//     glove   gc::Glove::sense on register counts with a pose frame every cycle (everything the loop does
//             besides I2C and the serial port); glove_raw, glove_json, glove_compact: the same in the other
//             output modes (a raw frame, a legacy JSON line, a pose_compact frame every cycle)
//     bus     no cycles: the I2C bus time of one sensing cycle (gc::ImuBus::cycle_us) for 12 and 16 IMUs on
//             the thesis' wiring at 100 kHz, 400 kHz and 1 MHz: "bus N_IMU CLOCK_HZ MICROSECONDS"
//     json    parent-relative pose + legacy JSON line per cycle
//     compact parent-relative pose + 20 joint angles + pose_compact frame per cycle
// Inputs are precomputed at start-up, so a run with CYCLES = 0 measures the start-up alone; bench/firmware.py
// subtracts it (callgrind on the host). Prints a checksum so the work cannot be optimised away.
// On the Cortex-M7 (QEMU with -icount shift=0: test/m7/qemu_m7.sh) it also prints the instructions per cycle,
// counted with SysTick around the cycles and scaled by a loop of known length: "m7_instructions_per_cycle X".
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>

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

#if defined(__arm__)
// SysTick, counting down at the core clock: under QEMU's -icount shift=0 one tick is a fixed number of
// instructions (40 on mps2-an500's 25 MHz), measured below with a loop of known length.
volatile uint32_t* const kSysTick = reinterpret_cast<volatile uint32_t*>(0xE000E010u);  // CSR, RVR, CVR
constexpr uint32_t kTickMask = 0xFFFFFFu;

void systick_start() {
    kSysTick[1] = kTickMask;
    kSysTick[2] = 0;
    kSysTick[0] = 5;  // enable, core clock, no interrupt
    while (kSysTick[2] == 0) {
    }
}
uint32_t ticks_since(uint32_t start) { return (start - kSysTick[2]) & kTickMask; }

// exactly 2 instructions per iteration (subs, bne)
__attribute__((noinline)) void spin(uint32_t n) { __asm volatile("1: subs %0, %0, #1\n\tbne 1b" : "+r"(n)); }

double instructions_per_tick() {
    constexpr uint32_t n = 1000000;
    const uint32_t t0 = kSysTick[2];
    spin(n);
    return 2.0 * n / ticks_since(t0);
}
#endif

}  // namespace

namespace {

bool known(const char* what) {
    for (const char* w : {"filter", "filter_thesis", "pose", "cycle", "glove", "glove_raw", "glove_json", "glove_compact", "json",
                          "compact", "bus"})
        if (!std::strcmp(what, w)) return true;
    return false;
}

void print_bus_budget() {
    const uint8_t channel[16] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
    const bool high[16] = {true, false, true, false, true, false, true, false,
                           true, false, true, false, true, false, true, false};
    for (uint8_t n : {uint8_t(12), uint8_t(16)})
        for (uint32_t hz : {100000ul, 400000ul, 1000000ul}) {
            ImuBus imus;
            imus.init(nullptr, n, channel, high);
            std::printf("bus %d %lu %.3f\n", n, static_cast<unsigned long>(hz), imus.cycle_us(I2cTiming{hz}));
        }
}

Mode glove_mode(const char* what) {
    if (!std::strcmp(what, "glove_raw")) return Mode::Raw;
    if (!std::strcmp(what, "glove_json")) return Mode::Json;
    if (!std::strcmp(what, "glove_compact")) return Mode::Compact;
    return Mode::Pose;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3 || !known(argv[1])) {
        std::fprintf(stderr, "usage: glove_core_bench filter|filter_thesis|pose|cycle|glove|glove_raw|glove_json|glove_compact|json|"
                             "compact|bus CYCLES\n");
        return 2;
    }
    const char* what = argv[1];
    const long cycles = std::atol(argv[2]);
    if (!std::strcmp(what, "bus")) {
        print_bus_budget();
        return 0;
    }
    const bool do_filter = !std::strncmp(what, "filter", 6) || !std::strcmp(what, "cycle");
    const bool do_pose = !std::strcmp(what, "pose") || !std::strcmp(what, "cycle");
    const bool do_json = !std::strcmp(what, "json"), do_compact = !std::strcmp(what, "compact");
    const bool do_glove = !std::strncmp(what, "glove", 5);
    make_inputs();

    static Hand hand;
    const uint8_t joint[kN] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};
    HandSettings hs;
    if (!std::strcmp(what, "filter_thesis")) hs.filter = thesis_settings();
    hand.init(hs, kN, joint);
    for (int i = 0; i < kN; ++i)
        for (int k = 0; k < 12; ++k) hand.observe(static_cast<uint8_t>(i), g_accel[k][i]);
    hand.reset_pose();

    static Glove glove;
    NullSink sink;
    GloveSettings gs;
    gs.sense_rate_hz = 1000;
    gs.output_rate_hz = 1000;
    gs.calibrate_at_boot = false;
    gs.mode = glove_mode(what);
    glove.init(gs, &sink);
    glove.begin(0);
    glove.sense(1000, g_raw[0], 0xFFF);  // first cycle: attitude from gravity

    static uint8_t frame[kMaxWire];
    static char line[kMaxJsonLine];
    uint32_t sum = 0;
#if defined(__arm__)
    systick_start();
    const double per_tick = instructions_per_tick();
    const uint32_t t0 = kSysTick[2];
#endif
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
#if defined(__arm__)
    const uint32_t ticks = ticks_since(t0);
    if (cycles > 0)
        std::printf("m7_instructions_per_cycle %.1f (%lu ticks of %.3f instructions)\n", ticks * per_tick / cycles,
                    static_cast<unsigned long>(ticks), per_tick);
#endif
    const Quat q = hand.filter(3).quaternion();
    std::printf("checksum %lu %lu %.6f\n", static_cast<unsigned long>(sum), static_cast<unsigned long>(sink.sum), static_cast<double>(q.w + glove.hand().filter(3).quaternion().w));
    return 0;
}
