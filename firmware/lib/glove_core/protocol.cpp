#include "protocol.h"

#include <cmath>

#include "cobs.h"
#include "crc32.h"

namespace gc {
namespace {

// Little-endian body writer over a fixed buffer; `ok` turns false on overflow.
struct Body {
    uint8_t b[kMaxBody];
    size_t n = 0;
    bool ok = true;
    void u8(uint8_t v) {
        if (n < kMaxBody) b[n++] = v;
        else ok = false;
    }
    void u16(uint16_t v) {
        u8(static_cast<uint8_t>(v & 0xFFu));
        u8(static_cast<uint8_t>(v >> 8));
    }
    void u32(uint32_t v) {
        u16(static_cast<uint16_t>(v & 0xFFFFu));
        u16(static_cast<uint16_t>(v >> 16));
    }
    void i16(int16_t v) { u16(static_cast<uint16_t>(v)); }
    void quat(Quat q) {  // w, x, y, z in Q14
        i16(q14(q.w));
        i16(q14(q.x));
        i16(q14(q.y));
        i16(q14(q.z));
    }
};

void header(Body& b, FrameKind kind, uint16_t seq, uint32_t t_us) {
    b.u8(kProtocolVersion);
    b.u8(static_cast<uint8_t>(kind));
    b.u16(seq);
    b.u32(t_us);
}

// Append the CRC, COBS-encode into `out` and add the delimiter.
size_t finish(Body& b, uint8_t* out, size_t cap) {
    b.u32(crc32(b.b, b.n));
    if (!b.ok || cap < 1) return 0;
    const size_t n = cobs_encode(b.b, b.n, out, cap - 1);
    if (n == 0) return 0;
    out[n] = 0x00;
    return n + 1;
}

uint16_t rd16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t rd32(const uint8_t* p) { return rd16(p) | static_cast<uint32_t>(rd16(p + 2)) << 16; }

// Nearest integer, ties to even (numpy.rint); exact for the doubles these encoders see.
double round_half_even(double x) {
    double r = std::floor(x + 0.5);
    if (r - x == 0.5 && std::fmod(r, 2.0) != 0.0) r -= 1.0;
    return r;
}

}  // namespace

int16_t q14(real v) {
    const double x = static_cast<double>(v) * 16384.0;  // exact
    if (!(x == x)) return 0;
    const double r = round_half_even(x);
    if (r > 32767.0) return 32767;
    if (r < -32768.0) return -32768;
    return static_cast<int16_t>(r);
}

int16_t deci_degrees(real angle_rad) {
    const double x = static_cast<double>(angle_rad) * (1800.0 / 3.14159265358979323846);  // as 1800 / numpy.pi
    if (!(x == x)) return kAngleMissing;
    const double r = round_half_even(x);
    if (r > 2047.0) return 2047;
    if (r < -2047.0) return -2047;
    return static_cast<int16_t>(r);
}

size_t encode_pose(uint16_t seq, uint32_t t_us, const Quat q[kPoseQuats], uint16_t mask, uint8_t* out,
                   size_t cap) {
    Body b;
    header(b, FrameKind::Pose, seq, t_us);
    b.u16(mask);
    for (uint8_t i = 0; i < kPoseQuats; ++i) b.quat(q[i]);
    return finish(b, out, cap);
}

size_t encode_pose_compact(uint16_t seq, uint32_t t_us, Quat palm, const real angles[kJointAngles], uint8_t* out,
                           size_t cap) {
    Body b;
    header(b, FrameKind::PoseCompact, seq, t_us);
    b.quat(palm);
    for (uint8_t j = 0; j < kJointAngles; j += 2) {  // two 12-bit fields in three bytes: u24 = a | b << 12
        const uint32_t lo = static_cast<uint16_t>(deci_degrees(angles[j])) & 0xFFFu;
        const uint32_t hi = static_cast<uint16_t>(deci_degrees(angles[j + 1])) & 0xFFFu;
        const uint32_t v = lo | hi << 12;
        b.u8(static_cast<uint8_t>(v & 0xFFu));
        b.u8(static_cast<uint8_t>(v >> 8 & 0xFFu));
        b.u8(static_cast<uint8_t>(v >> 16));
    }
    return finish(b, out, cap);
}

size_t encode_raw(uint16_t seq, uint32_t t_us, const int16_t (*data)[7], uint8_t n_imu, uint8_t accel_fs_g,
                  uint16_t gyro_fs_dps, uint16_t ok_mask, uint8_t* out, size_t cap) {
    if (n_imu < 1 || n_imu > kMaxRawImus) return 0;
    Body b;
    header(b, FrameKind::Raw, seq, t_us);
    b.u8(n_imu);
    b.u8(accel_fs_g);
    b.u16(gyro_fs_dps);
    b.u16(ok_mask);
    for (uint8_t i = 0; i < n_imu; ++i)
        for (uint8_t k = 0; k < 7; ++k) b.i16(data[i][k]);
    return finish(b, out, cap);
}

size_t encode_status(uint16_t seq, uint32_t t_us, const StatusInfo& s, uint8_t* out, size_t cap) {
    if (s.n_imu > kMaxRawImus || (s.n_imu && (!s.mux_map || !s.joint_map))) return 0;
    Body b;
    header(b, FrameKind::Status, seq, t_us);
    for (uint8_t v : s.firmware) b.u8(v);
    b.u8(static_cast<uint8_t>(s.mode));
    b.u16(s.sense_rate_hz);
    b.u16(s.output_rate_hz);
    b.u8(s.calib_state);
    b.u8(s.calib_progress);
    b.u8(s.clock_flags);
    b.u32(s.glove_id);
    b.u16(s.imu_ok_mask);
    b.u8(s.n_imu);
    for (uint8_t i = 0; i < s.n_imu; ++i) b.u8(s.mux_map[i]);
    for (uint8_t i = 0; i < s.n_imu; ++i) b.u8(s.joint_map[i]);
    return finish(b, out, cap);
}

size_t encode_event(uint16_t seq, uint32_t t_us, EventCode code, uint8_t arg, uint8_t* out, size_t cap) {
    Body b;
    header(b, FrameKind::Event, seq, t_us);
    b.u8(static_cast<uint8_t>(code));
    b.u8(arg);
    return finish(b, out, cap);
}

size_t encode_command(uint16_t seq, uint32_t t_us, const Command& c, uint8_t* out, size_t cap) {
    Body b;
    header(b, FrameKind::Command, seq, t_us);
    b.u8(static_cast<uint8_t>(c.code));
    if (c.code == CommandCode::SetRate) b.u16(c.arg);
    if (c.code == CommandCode::SetMode) b.u8(static_cast<uint8_t>(c.arg));
    return finish(b, out, cap);
}

bool decode_command(const uint8_t* chunk, size_t len, Command* out) {
    uint8_t body[32];
    const long n = cobs_decode(chunk, len, body, sizeof body);
    if (n < 8 + 1 + 4) return false;  // header, code, CRC
    const size_t pn = static_cast<size_t>(n) - 12;  // payload bytes
    if (rd32(body + n - 4) != crc32(body, static_cast<size_t>(n) - 4)) return false;
    if (body[0] != kProtocolVersion || body[1] != static_cast<uint8_t>(FrameKind::Command)) return false;
    const uint8_t* p = body + 8;
    Command c;
    c.seq = rd16(body + 2);
    c.t_us = rd32(body + 4);
    switch (p[0]) {
        case static_cast<uint8_t>(CommandCode::SetMode):
            if (pn != 2 || p[1] > static_cast<uint8_t>(Mode::Compact)) return false;
            c.arg = p[1];
            break;
        case static_cast<uint8_t>(CommandCode::SetRate):
            if (pn != 3) return false;
            c.arg = rd16(p + 1);
            break;
        case static_cast<uint8_t>(CommandCode::Recalibrate):
        case static_cast<uint8_t>(CommandCode::ResetPose):
        case static_cast<uint8_t>(CommandCode::GetStatus):
            if (pn != 1) return false;
            break;
        default:
            return false;
    }
    c.code = static_cast<CommandCode>(p[0]);
    *out = c;
    return true;
}

bool CommandReader::feed(uint8_t byte) {
    if (byte != 0x00) {
        if (len_ < kMaxChunk) buf_[len_++] = byte;
        else overflow_ = true;
        return false;
    }
    const bool empty = len_ == 0 && !overflow_;
    const bool ok = !overflow_ && len_ > 0 && decode_command(buf_, len_, &cmd_);
    if (!ok && !empty) ++rejected_;
    len_ = 0;
    overflow_ = false;
    return ok;
}

}  // namespace gc
