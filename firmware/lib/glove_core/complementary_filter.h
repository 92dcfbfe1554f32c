// Quaternion complementary filter with adaptive gain, one per IMU (thesis §3.3-3.5, eq. 3.4-3.19).
//
// Inputs are in the IMU's own axes: gyro in rad/s (bias already removed, eq. 3.20), accelerometer in g
// (specific force: (0, 0, +1) when lying flat and still). The state q maps the sensor frame into a global frame
// whose z axis is "up" (the direction of the specific force at rest); yaw is tracked by the gyro only.
#pragma once

#include <cstdint>

#include "median_filter.h"
#include "quaternion.h"

namespace gc {

struct FilterSettings {
    real static_gain = real(0.005);       // alpha-bar of eq. 3.18, tuned for static conditions (thesis §4.2.4)
    real error_threshold1 = real(0.1);    // t1 of eq. 3.19
    real error_threshold2 = real(0.2);    // t2 of eq. 3.19
    uint8_t median_window = 12;       // accelerometer median buffer (thesis §4.2.2); 1 disables it
};

// Eq. 3.17-3.19: alpha = alpha-bar * f(e_m), e_m = | |a| - g | / g with a in g (so g = 1).
real adaptive_gain(const FilterSettings& s, real accel_norm_g);

class ComplementaryFilter {
public:
    void init(const FilterSettings& settings);

    // Eq. 3.5-3.6: attitude from the gravity direction, yaw = 0. Uses the median-filtered accelerometer when
    // `accel` is omitted (the reset button, thesis §3.5.3). A zero vector leaves the identity.
    void reset_from_gravity();
    void reset_from_gravity(Vec3 accel);

    // Push an accelerometer sample into the median buffer only (while calibrating the gyro).
    void observe(Vec3 accel) { median_.update(accel); }

    // One filter step: eq. 3.4 propagation, then the eq. 3.12-3.16 correction with the eq. 3.17-3.19 gain.
    void update(Vec3 gyro, Vec3 accel, real dt);

    Quat quaternion() const { return q_; }
    void set_quaternion(Quat q) { q_ = normalized(q); }
    real last_gain() const { return gain_; }
    Vec3 filtered_accel() const { return median_.value(); }

private:
    FilterSettings s_;
    MedianFilter3 median_;
    Quat q_;
    real gain_ = 0;
};

}  // namespace gc
