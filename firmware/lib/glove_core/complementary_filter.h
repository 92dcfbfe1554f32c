// The glove's orientation filter, one per IMU: gyro integration corrected towards gravity (a complementary
// filter), in one of two modes.
//
// FilterMode::Inertial (the default, docs/fusion.md "inertial"): the accelerometer is low-passed in an almost
// inertial frame, where a hand's back-and-forth linear acceleration averages out, and the tilt follows that
// low-passed gravity (the idea of Laidig & Seel's VQF, 2023). Its Python twin is recorder/fusion/kernels.py
// inertial_step: the same operations in the same order, so a double build gives the same bits
// (tests/test_fusion_firmware.py). A step calls no libm function but sqrt.
//
// FilterMode::Thesis: the thesis' quaternion complementary filter with adaptive gain (§3.3-3.5, eq. 3.4-3.19),
// what the glove ran until issue 13; its twin is recorder/fusion/complementary.py.
//
// Inputs are in the IMU's own axes: gyro in rad/s (bias already removed, eq. 3.20), accelerometer in g
// (specific force: (0, 0, +1) when lying flat and still). The state q maps the sensor frame into a global frame
// whose z axis is "up" (the direction of the specific force at rest); yaw is tracked by the gyro only.
#pragma once

#include <cstdint>

#include "median_filter.h"
#include "quaternion.h"

namespace gc {

enum class FilterMode : uint8_t { Inertial = 0, Thesis = 1 };

struct FilterSettings {
    FilterMode mode = FilterMode::Inertial;
    // Inertial: time constant of each of the three low-pass stages, and the ramp term (3: a steady drift of the
    // gyro integration is followed without lag; 0: a plain low-pass). Chosen leave-one-trial-out on the BROAD
    // recordings (docs/fusion.md).
    real tau_s = real(4);
    real ramp = real(3);
    // Thesis:
    real static_gain = real(0.005);       // alpha-bar of eq. 3.18, tuned for static conditions (thesis §4.2.4)
    real error_threshold1 = real(0.1);    // t1 of eq. 3.19
    real error_threshold2 = real(0.2);    // t2 of eq. 3.19
    uint8_t median_window = 12;       // accelerometer median buffer (thesis §4.2.2); 1 disables it
};

// The thesis' settings (FilterMode::Thesis with its gain, thresholds and median buffer).
FilterSettings thesis_settings();

// Eq. 3.17-3.19: alpha = alpha-bar * f(e_m), e_m = | |a| - g | / g with a in g (so g = 1).
real adaptive_gain(const FilterSettings& s, real accel_norm_g);

// Eq. 3.5-3.6 (yaw 0) from a gravity vector without trigonometric functions (half angles of vectors and sqrt
// only: every FPU rounds them alike); the identity for a zero vector. The same attitude as
// from_roll_pitch(atan2(ay, az), atan2(-ax, sqrt(ay^2 + az^2))) to rounding.
Quat attitude_from_gravity(Vec3 a);

// exp of the rotation whose half-angle vector is h (= dt/2 * omega): cos|h| and sin|h|/|h| by their Taylor
// series to |h|^4, then not normalised. Exact to ~1e-10 for |h| < 0.1 rad, and the same bits on every FPU.
Quat exp_half(Vec3 h);

class ComplementaryFilter {
public:
    void init(const FilterSettings& settings);

    // Eq. 3.5-3.6: attitude from the gravity direction, yaw = 0. Without `accel`: from the filter's own
    // estimate of gravity (Inertial: the low-passed accelerometer; Thesis: the median-filtered one), the reset
    // button (thesis §3.5.3). A zero vector leaves the identity.
    void reset_from_gravity();
    void reset_from_gravity(Vec3 accel);

    // See an accelerometer sample without filtering (while the gyro is calibrated): Inertial averages the
    // samples seen since the last update into its low-pass, Thesis pushes it into the median buffer.
    void observe(Vec3 accel);

    // One filter step.
    void update(Vec3 gyro, Vec3 accel, real dt);

    Quat quaternion() const { return q_; }
    void set_quaternion(Quat q);  // Inertial: the low-pass then holds this attitude's gravity
    // Inertial: the low-pass weight of the last step (dt / tau); Thesis: alpha of eq. 3.14.
    real last_gain() const { return gain_; }
    Vec3 filtered_accel() const;  // the filter's gravity estimate in the IMU's axes

private:
    void update_thesis(Vec3 gyro, Vec3 accel, real dt);
    void update_inertial(Vec3 gyro, Vec3 accel, real dt);
    Vec3 inertial_gravity() const { return y_[2] + (y_[1] - y_[2]) * s_.ramp; }  // in the frame of q_g
    void set_inertial(Quat qc);

    FilterSettings s_;
    Quat q_;
    real gain_ = 0;
    // Thesis
    MedianFilter3 median_;
    // Inertial: q = q_c (x) q_g; y_ the three low-pass stages of the accelerometer in the frame of q_g
    Quat qg_, qc_;
    Vec3 y_[3];
    uint16_t observed_ = 0;  // samples observed since the last update
};

}  // namespace gc
