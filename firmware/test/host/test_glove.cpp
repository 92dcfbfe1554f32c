// The glove controller: boot, calibration, pose/raw/JSON output at its own rate, host commands, faults, the
// button, and no heap allocation while it runs.
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include "check.h"
#include "cobs.h"
#include "glove.h"
#include "helpers.h"
#include "imu_units.h"

using namespace gc;

// ---- allocation counter: armed only around calls into the glove
static int g_allocs = 0;
static bool g_armed = false;
void* operator new(size_t n) {
    if (g_armed) ++g_allocs;
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }

namespace {

struct Capture final : FrameSink {
    static constexpr size_t kCap = 1 << 20;  // 1 MiB: the emulated M7 has 4 MiB of RAM
    uint8_t* buf = static_cast<uint8_t*>(std::malloc(kCap));
    size_t n = 0;
    bool accept = true;
    ~Capture() { std::free(buf); }
    bool write(const uint8_t* d, size_t len) override {
        if (!accept || n + len > kCap) return false;
        std::memcpy(buf + n, d, len);
        n += len;
        return true;
    }
};

struct Frame {
    uint8_t kind = 0;
    uint16_t seq = 0;
    uint32_t t = 0;
    std::vector<uint8_t> p;  // payload
    bool json = false;
};

// Split the captured bytes into frames (COBS chunks) and JSON lines.
std::vector<Frame> parse(const Capture& c, size_t from = 0) {
    std::vector<Frame> out;
    size_t start = from;
    for (size_t i = from; i < c.n; ++i) {
        if (c.buf[i] == '{' && i == start) {  // a JSON line
            size_t e = i;
            while (e < c.n && c.buf[e] != '\n') ++e;
            Frame f;
            f.json = true;
            f.p.assign(c.buf + i, c.buf + e);
            out.push_back(f);
            i = e;
            start = e + 1;
            continue;
        }
        if (c.buf[i] == '\n' && i == start) {  // the '\n' after a binary answer in JSON mode
            start = i + 1;
            continue;
        }
        if (c.buf[i] != 0) continue;
        uint8_t body[1100];
        const long m = cobs_decode(c.buf + start, i - start, body, sizeof body);
        start = i + 1;
        if (m < 12) continue;
        Frame f;
        f.kind = body[1];
        f.seq = static_cast<uint16_t>(body[2] | body[3] << 8);
        f.t = static_cast<uint32_t>(body[4] | body[5] << 8 | body[6] << 16 | static_cast<uint32_t>(body[7]) << 24);
        f.p.assign(body + 8, body + m - 4);
        out.push_back(f);
    }
    return out;
}

int count(const std::vector<Frame>& fs, FrameKind k) {
    int n = 0;
    for (const auto& f : fs) n += f.kind == static_cast<uint8_t>(k);
    return n;
}
bool has_event(const std::vector<Frame>& fs, EventCode e, int arg = -1) {
    for (const auto& f : fs)
        if (f.kind == static_cast<uint8_t>(FrameKind::Event) && f.p[0] == static_cast<uint8_t>(e) &&
            (arg < 0 || f.p[1] == arg))
            return true;
    return false;
}
const Frame* last_of(const std::vector<Frame>& fs, FrameKind k) {
    const Frame* r = nullptr;
    for (const auto& f : fs)
        if (f.kind == static_cast<uint8_t>(k)) r = &f;
    return r;
}

// A still glove: 1 g on z, a small gyro offset, 25 degC.
int16_t g_raw[16][7];
void still(int16_t gyro_z_counts = 8) {
    for (auto& r : g_raw) {
        const int16_t row[7] = {3, -2, 2048, 16, -8, gyro_z_counts, 1335};
        std::memcpy(r, row, sizeof row);
    }
}

struct Rig {
    Capture cap;
    Glove glove;
    uint32_t t = 0, period = 10000;
    explicit Rig(GloveSettings s = settings()) {
        glove.init(s, &cap);
        period = 1000000u / s.sense_rate_hz;
        run_armed([&] { glove.begin(t); });
    }
    static GloveSettings settings() {
        GloveSettings s;
        s.calibration.samples = 50;
        return s;
    }
    template <class F>
    void run_armed(F f) {
        g_armed = true;
        f();
        g_armed = false;
    }
    void cycles(int n, uint16_t ok = 0xFFF) {
        run_armed([&] {
            for (int k = 0; k < n; ++k) glove.sense(t += period, g_raw, ok);
        });
    }
    void command(CommandCode code, uint16_t arg = 0) {
        uint8_t wire[64];
        const size_t n = encode_command(0, 0, Command{code, arg, 0, 0}, wire, sizeof wire);
        run_armed([&] { glove.receive(wire, n, t); });
    }
};

}  // namespace

TEST(boot_calibrates_then_streams_pose) {
    still();
    Rig r;
    auto fs = parse(r.cap);
    CHECK(fs.size() == 3);
    CHECK(has_event(fs, EventCode::Boot) && has_event(fs, EventCode::CalibStart));
    CHECK(fs.size() == 3 && fs[2].kind == static_cast<uint8_t>(FrameKind::Status) && fs[2].p[8] == 1);
    r.cycles(49);
    CHECK(count(parse(r.cap), FrameKind::Pose) == 0);  // no pose while calibrating
    r.cycles(1);
    fs = parse(r.cap);
    CHECK(has_event(fs, EventCode::CalibDone) && has_event(fs, EventCode::PoseReset));
    CHECK(r.glove.calib_state() == CalibState::Done);
    CHECK_NEAR(r.glove.calibration().bias(0).z, 8 * gyro_scale(2000), 1e-7);
    const size_t mark = r.cap.n;
    r.cycles(100);  // 1 s at 100 Hz sensing, 50 Hz output
    fs = parse(r.cap, mark);
    CHECK(count(fs, FrameKind::Pose) == 50);
    CHECK(count(fs, FrameKind::Status) == 1);  // once a second
    const Frame* p = last_of(fs, FrameKind::Pose);
    CHECK(p && p->p.size() == 130 && p->p[0] == 0xBF && p->p[1] == 0x6D);  // measured_mask
    CHECK(p && p->p[2] == 0x00 && p->p[3] == 0x40);                        // palm w = 1.0 (Q14)
    // one sequence counter for all frames, no gaps
    fs = parse(r.cap);
    for (size_t i = 0; i < fs.size(); ++i) CHECK(fs[i].seq == i);
    CHECK(g_allocs == 0);
}

TEST(raw_mode_and_rate_commands) {
    still();
    Rig r;
    r.cycles(50);
    size_t mark = r.cap.n;
    r.command(CommandCode::SetMode, 0);
    auto fs = parse(r.cap, mark);
    CHECK(fs.size() == 1 && fs[0].kind == static_cast<uint8_t>(FrameKind::Status) && fs[0].p[3] == 0);
    mark = r.cap.n;
    r.command(CommandCode::SetRate, 101);  // above the sense rate: ignored, not answered
    r.command(CommandCode::SetRate, 0);
    CHECK(r.cap.n == mark);
    r.command(CommandCode::SetRate, 10);
    r.cycles(95);  // frames 10 ms after the command, then every 100 ms
    fs = parse(r.cap, mark);
    CHECK(fs.size() > 0 && fs[0].kind == static_cast<uint8_t>(FrameKind::Status));
    CHECK(fs.size() > 0 && fs[0].p.size() > 6 && (fs[0].p[6] | fs[0].p[7] << 8) == 10);
    CHECK(count(fs, FrameKind::Raw) == 10);
    const Frame* raw = last_of(fs, FrameKind::Raw);
    CHECK(raw && raw->p.size() == 6 + 12 * 14);
    CHECK(raw && raw->p[0] == 12 && raw->p[1] == 16 && (raw->p[2] | raw->p[3] << 8) == 2000);
    CHECK(raw && (raw->p[10] | raw->p[11] << 8) == 2048);  // IMU 0 az as read
    mark = r.cap.n;
    r.command(CommandCode::GetStatus);
    CHECK(count(parse(r.cap, mark), FrameKind::Status) == 1);
    CHECK(g_allocs == 0);
}

TEST(compact_mode_sends_52_byte_frames) {
    still();
    Rig r;
    r.cycles(50);
    const size_t mark = r.cap.n;
    r.command(CommandCode::SetMode, 3);
    r.cycles(10);
    const auto fs = parse(r.cap, mark);
    CHECK(fs.size() > 0 && fs[0].kind == static_cast<uint8_t>(FrameKind::Status) && fs[0].p[3] == 3);
    CHECK(count(fs, FrameKind::PoseCompact) == 6 && count(fs, FrameKind::Pose) == 0);  // 50 Hz from the switch
    const Frame* c = last_of(fs, FrameKind::PoseCompact);
    CHECK(c && c->p.size() == 38 && c->p[0] == 0x00 && c->p[1] == 0x40);  // palm w = 1.0: the reference pose
    for (size_t i = 8; c && i < 38; ++i) CHECK(c->p[i] == 0);              // every joint angle 0
    CHECK(r.cap.n - mark == 56 + 6 * kPoseCompactWire);                   // the status answer, 6 frames
    CHECK(g_allocs == 0);
}

TEST(silent_imu_is_reported_and_skipped) {
    still();
    Rig r;
    r.cycles(50);
    size_t mark = r.cap.n;
    r.command(CommandCode::SetMode, 0);
    const uint16_t without3 = 0xFFF & ~(1u << 3);
    r.cycles(120, without3);
    auto fs = parse(r.cap, mark);
    CHECK(has_event(fs, EventCode::ImuFault, 3));
    CHECK(r.glove.ok_mask() == without3);
    const Frame* raw = last_of(fs, FrameKind::Raw);
    CHECK(raw && (raw->p[4] | raw->p[5] << 8) == without3);
    bool zeros = raw != nullptr;
    for (int k = 0; raw && k < 14; ++k) zeros = zeros && raw->p[6 + 3 * 14 + k] == 0;
    CHECK(zeros);  // its row is zeros
    const Frame* st = last_of(fs, FrameKind::Status);
    CHECK(st && (st->p[15] | st->p[16] << 8) == without3);
    mark = r.cap.n;
    r.cycles(5);
    fs = parse(r.cap, mark);
    CHECK(has_event(fs, EventCode::ImuRecovered, 3));
    CHECK(!has_event(fs, EventCode::ImuFault));
}

TEST(button_resets_the_reference_pose) {
    still(8);  // the calibrated bias
    Rig r;
    r.cycles(50);
    still(8 + 200);  // turn about z at 200 counts = 12 deg/s for 2 s
    r.cycles(200);
    Quat rel[16];
    r.glove.hand().relative_pose(rel);
    CHECK(testing_helpers::angle_between(rel[0], identity()) > testing_helpers::deg(20));
    still(8);
    const size_t mark = r.cap.n;
    r.run_armed([&] { r.glove.button(r.t); });
    auto fs = parse(r.cap, mark);
    CHECK(fs.size() == 2 && has_event(fs, EventCode::Button) && has_event(fs, EventCode::PoseReset));
    r.glove.hand().relative_pose(rel);
    CHECK(testing_helpers::angle_between(rel[0], identity()) < 1e-4f);
    r.command(CommandCode::ResetPose);
    CHECK(has_event(parse(r.cap, mark), EventCode::PoseReset));
}

TEST(json_mode_sends_lines_only) {
    still();
    Rig r;
    r.cycles(50);
    size_t mark = r.cap.n;
    r.command(CommandCode::SetMode, 2);
    CHECK(r.cap.n > mark && r.cap.buf[r.cap.n - 1] == '\n' && r.cap.buf[r.cap.n - 2] == 0);  // answer + '\n'
    mark = r.cap.n;
    r.cycles(149);  // ~1.5 s (a periodic status would fall due): lines at cycles 1, 2, 4, ..., 148
    auto fs = parse(r.cap, mark);
    int lines = 0;
    for (const auto& f : fs) lines += f.json;
    CHECK(lines == 75 && fs.size() == 75);
    CHECK(!fs.empty() && std::string(fs[0].p.begin(), fs[0].p.end()).rfind("{\"wrists\":{\"w\":1,", 0) == 0);
}

TEST(recalibration_refuses_while_moving) {
    still();
    Rig r;
    r.cycles(50);
    size_t mark = r.cap.n;
    r.command(CommandCode::Recalibrate);
    auto fs = parse(r.cap, mark);
    CHECK(has_event(fs, EventCode::CalibStart));
    CHECK(fs.size() == 2 && fs[1].kind == static_cast<uint8_t>(FrameKind::Status) && fs[1].p[8] == 1);
    CHECK(!r.glove.pose_ready());
    mark = r.cap.n;
    for (int k = 0; k < 300; ++k) {  // 3 s of shaking
        still(k % 2 ? 400 : -400);
        r.cycles(1);
    }
    fs = parse(r.cap, mark);
    int refused = 0;
    for (const auto& f : fs)
        refused += f.kind == static_cast<uint8_t>(FrameKind::Event) && f.p[0] == 8;
    CHECK(refused >= 3 && refused <= 4);  // rate-limited to one a second
    CHECK(r.glove.calib_state() == CalibState::Refused);
    CHECK(count(fs, FrameKind::Pose) == 0);
    still();
    r.cycles(50);
    CHECK(r.glove.calib_state() == CalibState::Done);
    CHECK(r.glove.pose_ready());
}

TEST(output_rate_is_independent_of_sensing) {
    still();
    GloveSettings s = Rig::settings();
    s.sense_rate_hz = 1000;
    s.output_rate_hz = 30;  // thesis §4.2.6: 30 FPS
    s.calibrate_at_boot = false;
    Rig r(s);
    const size_t mark = r.cap.n;
    r.cycles(3000);
    const int poses = count(parse(r.cap, mark), FrameKind::Pose);
    CHECK(poses >= 89 && poses <= 91);
}

TEST(dropped_frames_leave_sequence_gaps) {
    still();
    Rig r;
    r.cycles(50);
    r.cap.accept = false;
    r.cycles(10);
    CHECK(r.glove.dropped_frames() == 5);
    r.cap.accept = true;
    const uint16_t seq_before = r.glove.seq();
    r.cycles(2);
    const auto fs = parse(r.cap);
    CHECK(!fs.empty() && fs.back().seq == seq_before + 0);  // numbered after the dropped ones
}

TEST_MAIN()
