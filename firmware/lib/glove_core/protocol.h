// The glove wire protocol, version 1 (docs/protocol.md; Python reference: recorder/protocol/codec.py).
//
//   wire: COBS(body) 0x00      body: version u8 | kind u8 | seq u16 | t_us u32 | payload | crc32 u32
//
// All integers little-endian; CRC-32/ISO-HDLC over version..payload. Encoders write into caller buffers of
// kMaxWire bytes and never allocate. Frames must be byte-identical to recorder.protocol.encode_frame.
#pragma once

#include <cstddef>
#include <cstdint>

#include "quaternion.h"

namespace gc {

constexpr uint8_t kProtocolVersion = 1;
constexpr size_t kMaxBody = 1024;
constexpr size_t kMaxWire = kMaxBody + kMaxBody / 254 + 2;  // COBS overhead + the 0x00 delimiter
constexpr size_t kPoseWire = 144;                            // body 142 bytes
constexpr size_t kPoseCompactWire = 52;                      // body 50 bytes
constexpr uint8_t kPoseQuats = 16;
constexpr uint8_t kJointAngles = 20;                         // recorder/hand/kinematics.py JOINTS
constexpr int16_t kAngleMissing = -2048;                     // pose_compact: "no value" (NaN)
constexpr uint8_t kMaxRawImus = 16;

enum class FrameKind : uint8_t {
    Pose = 0x01, Raw = 0x02, Status = 0x03, Event = 0x04, PoseCompact = 0x05, Command = 0x10,
};
enum class Mode : uint8_t { Raw = 0, Pose = 1, Json = 2, Compact = 3 };
enum class EventCode : uint8_t {
    Boot = 1, Button = 2, PoseReset = 3, ImuFault = 4, ImuRecovered = 5,
    CalibStart = 6, CalibDone = 7, CalibRefused = 8,
};
enum class CommandCode : uint8_t { SetMode = 1, SetRate = 2, Recalibrate = 3, ResetPose = 4, GetStatus = 5 };
constexpr uint8_t kClockHostMonotonic = 0x01;  // status clock_flags bit 0

struct StatusInfo {
    uint8_t firmware[3] = {0, 0, 0};
    Mode mode = Mode::Pose;
    uint16_t sense_rate_hz = 0;
    uint16_t output_rate_hz = 0;
    uint8_t calib_state = 0;      // gc::CalibState
    uint8_t calib_progress = 0;   // 0-100 %
    uint8_t clock_flags = 0;
    uint32_t glove_id = 0;
    uint16_t imu_ok_mask = 0;
    uint8_t n_imu = 0;
    const uint8_t* mux_map = nullptr;    // n_imu entries
    const uint8_t* joint_map = nullptr;  // n_imu entries
};

struct Command {
    CommandCode code = CommandCode::GetStatus;
    uint16_t arg = 0;  // mode for SetMode, Hz for SetRate
    uint16_t seq = 0;
    uint32_t t_us = 0;
};

// Q14 fixed point of one quaternion component: round-half-even(v * 16384), saturated to int16 (numpy's rint).
int16_t q14(real v);
// A joint angle as the 12-bit field of pose_compact frames: round-half-even(rad * 1800 / pi) in 0.1 degree,
// saturated to +-2047 (+-204.7 degrees); NaN gives kAngleMissing.
int16_t deci_degrees(real angle_rad);

// ---- frame encoders: each returns the bytes written to `out` (COBS body + 0x00), 0 if `cap` is too small
size_t encode_pose(uint16_t seq, uint32_t t_us, const Quat q[kPoseQuats], uint16_t measured_mask, uint8_t* out,
                   size_t cap);
// data: n_imu rows of (ax, ay, az, gx, gy, gz, temp) register values; n_imu 1..16.
// palm: the palm's quaternion (Q14 as in pose frames); angles: the 20 joint angles in radians, JOINTS order.
size_t encode_pose_compact(uint16_t seq, uint32_t t_us, Quat palm, const real angles[kJointAngles], uint8_t* out,
                           size_t cap);
size_t encode_raw(uint16_t seq, uint32_t t_us, const int16_t (*data)[7], uint8_t n_imu, uint8_t accel_fs_g,
                  uint16_t gyro_fs_dps, uint16_t ok_mask, uint8_t* out, size_t cap);
size_t encode_status(uint16_t seq, uint32_t t_us, const StatusInfo& s, uint8_t* out, size_t cap);
size_t encode_event(uint16_t seq, uint32_t t_us, EventCode code, uint8_t arg, uint8_t* out, size_t cap);
size_t encode_command(uint16_t seq, uint32_t t_us, const Command& c, uint8_t* out, size_t cap);

// Decode one host -> glove chunk (without the 0x00). False for anything not a valid version-1 command frame
// with exactly the payload its code takes (as recorder.protocol.codec._decode_command).
bool decode_command(const uint8_t* chunk, size_t len, Command* out);

// Splits the host's byte stream at 0x00 and decodes commands; overlong garbage is dropped up to the next 0x00.
class CommandReader {
public:
    // Feed one byte; true when it completed a valid command (then read command()).
    bool feed(uint8_t byte);
    const Command& command() const { return cmd_; }
    uint32_t rejected() const { return rejected_; }  // chunks that were not valid commands

private:
    static constexpr size_t kMaxChunk = 64;  // commands are at most 15 bytes on the wire
    uint8_t buf_[kMaxChunk];
    size_t len_ = 0;
    bool overflow_ = false;
    uint32_t rejected_ = 0;
    Command cmd_;
};

// Keeps the device's frame counter ("one counter for all frames a device sends", wrapping at 65536).
class Encoder {
public:
    size_t pose(uint32_t t_us, const Quat q[kPoseQuats], uint16_t mask, uint8_t* out, size_t cap) {
        return bump(encode_pose(seq_, t_us, q, mask, out, cap));
    }
    size_t pose_compact(uint32_t t_us, Quat palm, const real angles[kJointAngles], uint8_t* out, size_t cap) {
        return bump(encode_pose_compact(seq_, t_us, palm, angles, out, cap));
    }
    size_t raw(uint32_t t_us, const int16_t (*data)[7], uint8_t n, uint8_t afs, uint16_t gfs, uint16_t ok,
               uint8_t* out, size_t cap) {
        return bump(encode_raw(seq_, t_us, data, n, afs, gfs, ok, out, cap));
    }
    size_t status(uint32_t t_us, const StatusInfo& s, uint8_t* out, size_t cap) {
        return bump(encode_status(seq_, t_us, s, out, cap));
    }
    size_t event(uint32_t t_us, EventCode code, uint8_t arg, uint8_t* out, size_t cap) {
        return bump(encode_event(seq_, t_us, code, arg, out, cap));
    }
    uint16_t seq() const { return seq_; }
    void set_seq(uint16_t seq) { seq_ = seq; }

private:
    size_t bump(size_t n) {
        if (n) ++seq_;
        return n;
    }
    uint16_t seq_ = 0;
};

}  // namespace gc
