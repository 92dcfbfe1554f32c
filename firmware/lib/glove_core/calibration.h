// Gyroscope bias calibration with a stillness check (thesis §3.5.3, eq. 3.20).
//
// The bias of each gyro is the mean of `samples` readings taken while the hand rests. If any IMU moves during
// the window (gyro or accelerometer spread too large, or a mean rate no resting MPU9250 shows), the attempt is
// refused and a new one starts at once; the previous biases stay in force until an attempt succeeds.
#pragma once

#include <cstdint>

#include "quaternion.h"

namespace gc {

enum class CalibState : uint8_t { Idle = 0, Running = 1, Done = 2, Refused = 3 };  // docs/protocol.md status

struct CalibrationSettings {
    uint16_t samples = 256;           // thesis: 200 to 300 samples
    real max_gyro_range = real(0.1);      // rad/s (5.7 deg/s): max - min of any gyro axis over the window
    real max_accel_range = real(0.1);     // g: max - min of any accelerometer axis over the window
    real max_bias = real(0.175);          // rad/s (10 deg/s): a larger mean is a slow turn, not a bias
};

enum class CalibEvent : uint8_t { None, Done, Refused };

class GyroCalibration {
public:
    static constexpr uint8_t kMaxImus = 16;

    void init(const CalibrationSettings& settings, uint8_t n_imu);
    void start();   // begin (or restart) an attempt; biases are kept until it succeeds

    // One sensing cycle: gyro (rad/s, raw) and accelerometer (g) of every IMU; bit i of ok_mask is set when IMU i
    // answered. An IMU that answered in fewer than half the cycles keeps its previous bias.
    CalibEvent update(const Vec3* gyro, const Vec3* accel, uint16_t ok_mask);

    CalibState state() const { return state_; }
    bool running() const { return state_ == CalibState::Running || state_ == CalibState::Refused; }
    uint8_t progress() const;  // 0-100 % of the current attempt (100 once done)
    uint16_t refusals() const { return refusals_; }
    Vec3 bias(uint8_t imu) const { return bias_[imu]; }
    void set_bias(uint8_t imu, Vec3 b) { bias_[imu] = b; }
    Vec3 corrected(uint8_t imu, Vec3 gyro_raw) const { return gyro_raw - bias_[imu]; }  // eq. 3.20

private:
    struct Acc {
        Vec3 sum, gmin, gmax, amin, amax;
        uint16_t n = 0;
    };
    void clear();
    static void extend(Vec3& lo, Vec3& hi, Vec3 v, bool first);
    static real spread(Vec3 lo, Vec3 hi);

    CalibrationSettings s_;
    uint8_t n_imu_ = 0;
    CalibState state_ = CalibState::Idle;
    uint16_t cycles_ = 0, refusals_ = 0;
    Acc acc_[kMaxImus];
    Vec3 bias_[kMaxImus];
};

}  // namespace gc
