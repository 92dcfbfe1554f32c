// glove_core_cli: the host-built glove core as a command-line tool, for cross-language golden tests
// (tests/test_firmware.py) and "firmware in the loop" (synthetic IMU data -> the glove's exact code -> bytes).
//
//   glove_core_cli run [options] SAMPLES.bin      run the glove (gc::Glove) on recorded/synthetic IMU samples
//   glove_core_cli pose|compact|raw|status|event|json   encode records read from stdin (formats below)
//   glove_core_cli angles                         16 relative quaternions -> 20 joint angles (gc::joint_angles)
//   glove_core_cli command                        decode a host byte stream from stdin, one line per chunk
//
// SAMPLES.bin: little-endian float32, sample-major; for every sample, for every IMU: gx gy gz (rad/s, the IMU's
// axes) then ax ay az (g, specific force: +1 on z lying flat). 24 bytes per IMU per sample. A NaN anywhere in an
// IMU's six values means that IMU did not answer in that cycle. The values are quantised to MPU9250 register
// counts at +-16 g / +-2000 dps (as the real glove reads them) before the core sees them; temperature 25 degC.
//
// With --stamped every sample starts with u32 t_us, the device time of that cycle (the emulator passes the
// host's CLOCK_MONOTONIC in microseconds), and a u8 of flags; otherwise t_us = t0 + (k + 1) * 1e6 / sense rate for sample k.
//
// run options:
//   --n-imu N            IMUs per sample (12; 16 uses the 16-IMU layout)       --sense-rate HZ  (1000)
//   --output-rate HZ     (100)                                       --mode pose|raw|json|compact (pose)
//   --calib-samples N    gyro calibration length at boot; 0 = none (256)       --t0 US  first sample time (0)
//   --filter inertial|thesis   the orientation filter (FilterMode; inertial)
//   --rx FILE            host bytes: records of u32 cycle, u16 length, bytes; delivered before that cycle
//   --button K           press the reset button before cycle K (repeatable)
//   --trace FILE         after each cycle: n_imu x (w, x, y, z) float64 global filter quaternions
//   --trace-pose FILE    after each cycle: 16 x (w, x, y, z) float64 parent-relative pose
//   --glove-id ID        --clock-host (status clock_flags bit 0)      --out FILE (default stdout)
//   --live               SAMPLES.bin may be "-" (stdin): frames are flushed after every cycle, and with
//   --rx-fifo PATH       host bytes are read from this FIFO (non-blocking) before every cycle. For running
//                        the compiled core as the emulator's firmware: samples in, frames out, commands back.
//   --stamped            every sample record starts with u32 t_us (see above) and u8 flags (bit 0: the reset
//                        button was pressed before this cycle)
//   --ack-fd FD          after each cycle (its frames flushed) write one byte to file descriptor FD: a driver
//                        that waits for it knows every frame of that cycle is readable (FirmwareCore's sync)
//
// Encoder record formats (stdin, little-endian, repeated):
//   pose:   u16 seq, u32 t_us, u16 measured_mask, 64 x float32 (16 quaternions w, x, y, z)
//   compact: u16 seq, u32 t_us, 4 x float32 palm quaternion, 20 x float32 joint angles (rad)
//   raw:    u16 seq, u32 t_us, u8 n_imu, u8 accel_fs_g, u16 gyro_fs_dps, u16 ok_mask, 16 x 7 x int16
//   status: u16 seq, u32 t_us, 3 x u8 firmware, u8 mode, u16 sense, u16 output, u8 calib_state,
//           u8 calib_progress, u8 clock_flags, u32 glove_id, u16 ok_mask, u8 n_imu, 16 x u8 mux, 16 x u8 joint
//   event:  u16 seq, u32 t_us, u8 code, u8 arg
//   json:   64 x float32
// angles: 64 x float64 in (16 quaternions), 20 x float64 out (radians).
// command output: "code arg seq t_us" per valid command, "reject" per invalid chunk.
#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "glove_core.h"

namespace {

using namespace gc;

[[noreturn]] void die(const char* msg, const char* arg = "") {
    std::fprintf(stderr, "glove_core_cli: %s%s\n", msg, arg);
    std::exit(2);
}

bool read_exact(FILE* f, void* p, size_t n) { return std::fread(p, 1, n, f) == n; }

struct Reader {  // little-endian fields out of one record
    const uint8_t* p;
    uint8_t u8() { return *p++; }
    uint16_t u16() {
        const uint16_t v = static_cast<uint16_t>(p[0] | p[1] << 8);
        p += 2;
        return v;
    }
    uint32_t u32() {
        const uint32_t lo = u16();
        return lo | static_cast<uint32_t>(u16()) << 16;
    }
    float f32() {
        const uint32_t v = u32();
        float f;
        std::memcpy(&f, &v, 4);
        return f;
    }
};

struct FileSink final : FrameSink {
    FILE* f;
    explicit FileSink(FILE* file) : f(file) {}
    bool write(const uint8_t* d, size_t n) override { return std::fwrite(d, 1, n, f) == n; }
};

int encode_records(const char* kind) {
    size_t rec = 0;
    if (!std::strcmp(kind, "pose")) rec = 8 + 256;
    else if (!std::strcmp(kind, "compact")) rec = 6 + 96;
    else if (!std::strcmp(kind, "raw")) rec = 12 + 16 * 7 * 2;
    else if (!std::strcmp(kind, "status")) rec = 6 + 18 + 32;
    else if (!std::strcmp(kind, "event")) rec = 8;
    else if (!std::strcmp(kind, "json")) rec = 256;
    else die("unknown command ", kind);
    std::vector<uint8_t> buf(rec);
    uint8_t out[kMaxWire];
    char line[kMaxJsonLine];
    while (read_exact(stdin, buf.data(), rec)) {
        Reader r{buf.data()};
        size_t n = 0;
        if (!std::strcmp(kind, "json")) {
            Quat q[16];
            for (auto& c : q) c = {r.f32(), r.f32(), r.f32(), r.f32()};
            n = encode_json_line(q, line, sizeof line);
            std::fwrite(line, 1, n, stdout);
            continue;
        }
        const uint16_t seq = r.u16();
        const uint32_t t = r.u32();
        if (!std::strcmp(kind, "pose")) {
            const uint16_t mask = r.u16();
            Quat q[16];
            for (auto& c : q) c = {r.f32(), r.f32(), r.f32(), r.f32()};
            n = encode_pose(seq, t, q, mask, out, sizeof out);
        } else if (!std::strcmp(kind, "compact")) {
            const Quat palm{r.f32(), r.f32(), r.f32(), r.f32()};
            real angles[kJointAngles];
            for (auto& a : angles) a = r.f32();
            n = encode_pose_compact(seq, t, palm, angles, out, sizeof out);
        } else if (!std::strcmp(kind, "raw")) {
            const uint8_t n_imu = r.u8(), afs = r.u8();
            const uint16_t gfs = r.u16(), ok = r.u16();
            int16_t d[16][7];
            for (auto& row : d)
                for (auto& v : row) v = static_cast<int16_t>(r.u16());
            n = encode_raw(seq, t, d, n_imu, afs, gfs, ok, out, sizeof out);
        } else if (!std::strcmp(kind, "status")) {
            StatusInfo s;
            uint8_t mux[16], joint[16];
            for (auto& v : s.firmware) v = r.u8();
            s.mode = static_cast<Mode>(r.u8());
            s.sense_rate_hz = r.u16();
            s.output_rate_hz = r.u16();
            s.calib_state = r.u8();
            s.calib_progress = r.u8();
            s.clock_flags = r.u8();
            s.glove_id = r.u32();
            s.imu_ok_mask = r.u16();
            s.n_imu = r.u8();
            for (auto& v : mux) v = r.u8();
            for (auto& v : joint) v = r.u8();
            s.mux_map = mux;
            s.joint_map = joint;
            n = encode_status(seq, t, s, out, sizeof out);
        } else {
            const uint8_t code = r.u8(), arg = r.u8();
            n = encode_event(seq, t, static_cast<EventCode>(code), arg, out, sizeof out);
        }
        if (n == 0) die("record could not be encoded");
        std::fwrite(out, 1, n, stdout);
    }
    return 0;
}

int joint_angles_of_poses() {
    double in[64];
    while (read_exact(stdin, in, sizeof in)) {
        Quat q[kSegments];
        for (int s = 0; s < kSegments; ++s) q[s] = {in[4 * s], in[4 * s + 1], in[4 * s + 2], in[4 * s + 3]};
        real a[kJoints];
        joint_angles(q, a);
        double out[kJoints];
        for (int j = 0; j < kJoints; ++j) out[j] = a[j];
        std::fwrite(out, 8, kJoints, stdout);
    }
    return 0;
}

int decode_commands() {
    CommandReader reader;
    uint32_t rejected = 0;
    int c;
    while ((c = std::fgetc(stdin)) != EOF) {
        if (reader.feed(static_cast<uint8_t>(c))) {
            const Command& k = reader.command();
            std::printf("%u %u %u %u\n", static_cast<unsigned>(k.code), k.arg, k.seq, k.t_us);
        } else if (reader.rejected() != rejected) {
            rejected = reader.rejected();
            std::printf("reject\n");
        }
    }
    return 0;
}

struct RxRecord {
    uint32_t cycle;
    std::vector<uint8_t> bytes;
};

int run(int argc, char** argv) {
    GloveSettings s;
    s.sense_rate_hz = 1000;
    s.output_rate_hz = 100;
    s.calibration.samples = 256;
    const char *input = nullptr, *rx_path = nullptr, *trace_path = nullptr, *pose_path = nullptr, *out_path = nullptr;
    const char* fifo_path = nullptr;
    bool live = false, stamped = false;
    int ack_fd = -1;
    uint32_t t0 = 0;
    std::vector<long> buttons;
    for (int i = 0; i < argc; ++i) {
        const char* a = argv[i];
        auto val = [&]() -> const char* {
            if (i + 1 >= argc) die("missing value for ", a);
            return argv[++i];
        };
        if (!std::strcmp(a, "--n-imu")) s.n_imu = static_cast<uint8_t>(std::atoi(val()));
        else if (!std::strcmp(a, "--sense-rate")) s.sense_rate_hz = static_cast<uint16_t>(std::atoi(val()));
        else if (!std::strcmp(a, "--output-rate")) s.output_rate_hz = static_cast<uint16_t>(std::atoi(val()));
        else if (!std::strcmp(a, "--calib-samples")) s.calibration.samples = static_cast<uint16_t>(std::atoi(val()));
        else if (!std::strcmp(a, "--filter")) {
            const char* f = val();
            if (!std::strcmp(f, "thesis")) s.hand.filter = thesis_settings();
            else if (std::strcmp(f, "inertial")) die("--filter must be inertial or thesis, not ", f);
        } else if (!std::strcmp(a, "--t0")) t0 = static_cast<uint32_t>(std::strtoul(val(), nullptr, 0));
        else if (!std::strcmp(a, "--rx")) rx_path = val();
        else if (!std::strcmp(a, "--button")) buttons.push_back(std::atol(val()));
        else if (!std::strcmp(a, "--trace")) trace_path = val();
        else if (!std::strcmp(a, "--trace-pose")) pose_path = val();
        else if (!std::strcmp(a, "--glove-id")) s.glove_id = static_cast<uint32_t>(std::strtoul(val(), nullptr, 0));
        else if (!std::strcmp(a, "--clock-host")) s.clock_flags = kClockHostMonotonic;
        else if (!std::strcmp(a, "--out")) out_path = val();
        else if (!std::strcmp(a, "--live")) live = true;
        else if (!std::strcmp(a, "--rx-fifo")) fifo_path = val();
        else if (!std::strcmp(a, "--stamped")) stamped = true;
        else if (!std::strcmp(a, "--ack-fd")) ack_fd = std::atoi(val());
        else if (!std::strcmp(a, "--mode")) {
            const char* m = val();
            const char* names[] = {"raw", "pose", "json", "compact"};  // Mode values 0..3
            int found = -1;
            for (int k = 0; k < 4; ++k)
                if (!std::strcmp(m, names[k])) found = k;
            if (found < 0) die("bad mode ", m);
            s.mode = static_cast<Mode>(found);
        } else if (a[0] == '-' && a[1] != '\0') die("unknown option ", a);
        else input = a;
    }
    if (!input) die("run needs an input file");
    if (s.n_imu < 1 || s.n_imu > 16) die("--n-imu must be 1..16");
    if (s.sense_rate_hz < 1) die("--sense-rate must be >= 1");
    if (s.n_imu == 16) {  // spare mux channels 6 and 7 carry the four finger distal phalanges
        const uint8_t mux[16] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
        const uint8_t joint[16] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14, 6, 9, 12, 15};
        std::memcpy(s.mux_map, mux, 16);
        std::memcpy(s.joint_map, joint, 16);
    }
    s.calibrate_at_boot = s.calibration.samples > 0;

    std::vector<RxRecord> rx;
    if (rx_path) {
        FILE* f = std::fopen(rx_path, "rb");
        if (!f) die("cannot open ", rx_path);
        uint8_t head[6];
        while (read_exact(f, head, 6)) {
            Reader r{head};
            RxRecord rec{r.u32(), std::vector<uint8_t>(r.u16())};
            if (!rec.bytes.empty() && !read_exact(f, rec.bytes.data(), rec.bytes.size())) die("truncated --rx");
            rx.push_back(std::move(rec));
        }
        std::fclose(f);
    }
    FILE* in = std::strcmp(input, "-") ? std::fopen(input, "rb") : stdin;
    if (!in) die("cannot open ", input);
    int fifo = -1;
    if (fifo_path) {  // O_RDWR: the FIFO stays open (no EOF) whether or not a writer is attached
        fifo = ::open(fifo_path, O_RDWR | O_NONBLOCK);
        if (fifo < 0) die("cannot open ", fifo_path);
    }
    FILE* out = out_path ? std::fopen(out_path, "wb") : stdout;
    FILE* trace = trace_path ? std::fopen(trace_path, "wb") : nullptr;
    FILE* pose = pose_path ? std::fopen(pose_path, "wb") : nullptr;
    if (!out || (trace_path && !trace) || (pose_path && !pose)) die("cannot open an output file");

    FileSink sink(out);
    static Glove glove;  // large: keep it off the stack
    glove.init(s, &sink);
    if (!stamped) glove.begin(t0);
    std::vector<float> sample(6u * s.n_imu);
    int16_t raw[16][7] = {};
    uint8_t stamp[5];
    for (long k = 0; (!stamped || read_exact(in, stamp, 5)) && read_exact(in, sample.data(), sample.size() * 4);
         ++k) {
        // t_us = t0 + k * 1e6 / rate, rounded, or the sample's own stamp; wraps at 2^32 as micros() does
        const uint32_t t = stamped ? Reader{stamp}.u32()
                                   : t0 + static_cast<uint32_t>(std::llround(static_cast<double>(k + 1) * 1e6 /
                                                                             s.sense_rate_hz));
        if (k == 0 && stamped) glove.begin(t);
        for (const RxRecord& r : rx)
            if (r.cycle == static_cast<uint32_t>(k)) glove.receive(r.bytes.data(), r.bytes.size(), t);
        for (long b : buttons)
            if (b == k) glove.button(t);
        if (stamped && (stamp[4] & 1u)) glove.button(t);
        uint8_t host[256];
        for (ssize_t got; fifo >= 0 && (got = ::read(fifo, host, sizeof host)) > 0;)
            glove.receive(host, static_cast<size_t>(got), t);
        uint16_t ok = 0;
        for (uint8_t i = 0; i < s.n_imu; ++i) {
            const float* v = &sample[6u * i];
            bool finite = true;
            for (int c = 0; c < 6; ++c) finite = finite && std::isfinite(v[c]);
            if (!finite) continue;
            ok = static_cast<uint16_t>(ok | 1u << i);
            for (int c = 0; c < 3; ++c) {
                raw[i][c] = counts_from_g(v[3 + c], s.accel_fs_g);
                raw[i][3 + c] = counts_from_rad_s(v[c], s.gyro_fs_dps);
            }
            raw[i][6] = counts_from_celsius(25.0f);
        }
        glove.sense(t, raw, ok);
        if (live) std::fflush(out);
        if (ack_fd >= 0) {
            const uint8_t one = 1;
            if (::write(ack_fd, &one, 1) != 1) die("cannot write --ack-fd");
        }
        if (trace)
            for (uint8_t i = 0; i < s.n_imu; ++i) {
                const Quat q = glove.hand().filter(i).quaternion();
                const double w[4] = {q.w, q.x, q.y, q.z};
                std::fwrite(w, 8, 4, trace);
            }
        if (pose) {
            Quat rel[16];
            glove.hand().relative_pose(rel);
            for (const Quat& q : rel) {
                const double w[4] = {q.w, q.x, q.y, q.z};
                std::fwrite(w, 8, 4, pose);
            }
        }
    }
    if (in != stdin) std::fclose(in);
    if (fifo >= 0) ::close(fifo);
    if (trace) std::fclose(trace);
    if (pose) std::fclose(pose);
    if (out != stdout) std::fclose(out);
    else std::fflush(stdout);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) die("usage: glove_core_cli run|pose|compact|raw|status|event|json|angles|command ...");
    if (!std::strcmp(argv[1], "run")) return run(argc - 2, argv + 2);
    if (!std::strcmp(argv[1], "command")) return decode_commands();
    if (!std::strcmp(argv[1], "angles")) return joint_angles_of_poses();
    return encode_records(argv[1]);
}
