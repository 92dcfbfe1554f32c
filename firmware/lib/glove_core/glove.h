// The glove's behaviour without its hardware: sensing cycles, calibration, faults, host commands, the button,
// and the frames it sends (docs/protocol.md). The Arduino layer (firmware/src) only reads sensors, pins and the
// serial port and calls into this class; the host build runs the very same code (tools/glove_core_cli.cpp).
#pragma once

#include <cstddef>
#include <cstdint>

#include "calibration.h"
#include "hand.h"
#include "legacy_json.h"
#include "protocol.h"

namespace gc {

// Where frames go (USB serial, a UART, a file). Returns false when the frame was dropped (e.g. a full buffer).
class FrameSink {
public:
    virtual bool write(const uint8_t* data, size_t len) = 0;

protected:
    ~FrameSink() = default;
};

struct GloveSettings {
    uint8_t n_imu = 12;
    // Thesis table 4.1: TCA9548A channel and hand segment of each IMU.
    uint8_t mux_map[kMaxImus] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5};
    uint8_t joint_map[kMaxImus] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};
    uint16_t sense_rate_hz = 100;     // sensing and filtering (fixed rate)
    uint16_t output_rate_hz = 50;     // frames out (independent, thesis §4.2.6); 1 .. sense rate
    Mode mode = Mode::Pose;
    uint8_t accel_fs_g = 16;          // MPU9250 full scales used by the glove
    uint16_t gyro_fs_dps = 2000;
    uint8_t firmware[3] = {1, 0, 0};
    uint32_t glove_id = 0;
    uint8_t clock_flags = 0;
    uint32_t status_period_us = 1000000;
    real max_dt_s = real(0.05);           // longest gap integrated in one filter step
    bool calibrate_at_boot = true;    // false: start filtering at once with zero gyro bias
    HandSettings hand;
    CalibrationSettings calibration;
};

class Glove {
public:
    void init(const GloveSettings& settings, FrameSink* sink);
    void begin(uint32_t t_us);  // boot event, status, then the gyro calibration (if calibrate_at_boot)

    // One sensing cycle at device time t_us: raw[i] = (ax, ay, az, gx, gy, gz, temp) counts of IMU i; bit i of
    // ok_mask clear when IMU i did not answer (its row is ignored). Sends whatever frames fall due.
    void sense(uint32_t t_us, const int16_t (*raw)[7], uint16_t ok_mask);
    void receive(const uint8_t* data, size_t len, uint32_t t_us);  // bytes from the host (commands)
    void button(uint32_t t_us);                                    // a debounced press of the reset button

    Mode mode() const { return mode_; }
    uint16_t sense_rate_hz() const { return s_.sense_rate_hz; }
    uint16_t output_rate_hz() const { return output_rate_; }
    uint16_t ok_mask() const { return ok_mask_; }
    bool pose_ready() const { return pose_ready_; }
    CalibState calib_state() const { return calib_.state(); }
    const GyroCalibration& calibration() const { return calib_; }
    const Hand& hand() const { return hand_; }
    uint32_t dropped_frames() const { return dropped_; }
    uint16_t seq() const { return enc_.seq(); }

private:
    void handle(const Command& c, uint32_t t_us);
    void reset_pose(uint32_t t_us);
    void event(EventCode code, uint8_t arg, uint32_t t_us);
    void status(uint32_t t_us, bool answer);
    void output(uint32_t t_us);
    void send(size_t n, bool binary_answer = false);
    static bool due(uint32_t t_us, uint32_t& next, uint32_t period);

    GloveSettings s_;
    FrameSink* sink_ = nullptr;
    Encoder enc_;
    CommandReader reader_;
    Hand hand_;
    GyroCalibration calib_;
    Mode mode_ = Mode::Pose;
    uint16_t output_rate_ = 50;
    uint16_t ok_mask_ = 0, all_mask_ = 0;
    bool pose_ready_ = false, started_ = false;
    uint32_t next_output_ = 0, next_status_ = 0, last_refusal_event_ = 0;
    uint16_t refusals_seen_ = 0;
    uint32_t last_t_[kMaxImus] = {};
    uint16_t has_last_t_ = 0;
    uint32_t dropped_ = 0;
    int16_t raw_[kMaxImus][7] = {};
    union {
        uint8_t frame_[kMaxWire];
        char line_[kMaxJsonLine];
    };
};

}  // namespace gc
