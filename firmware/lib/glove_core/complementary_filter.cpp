#include "complementary_filter.h"

#include <cmath>

namespace gc {

real adaptive_gain(const FilterSettings& s, real accel_norm_g) {
    const real em = std::fabs(accel_norm_g - 1);  // eq. 3.17, accelerometer in g (so g = 1)
    if (!(em < s.error_threshold2)) return 0;     // eq. 3.19, e_m >= t2 (and NaN)
    if (em <= s.error_threshold1) return s.static_gain;
    // Eq. 3.19 writes (t2 - e_m) / t1, which is continuous only when t2 = 2 t1 (the thesis' 0.1 / 0.2);
    // (t2 - e_m) / (t2 - t1) is the same value there and stays continuous for other thresholds.
    return s.static_gain * (s.error_threshold2 - em) / (s.error_threshold2 - s.error_threshold1);
}

void ComplementaryFilter::init(const FilterSettings& settings) {
    s_ = settings;
    median_.init(settings.median_window);
    q_ = identity();
    gain_ = 0;
}

void ComplementaryFilter::reset_from_gravity() { reset_from_gravity(median_.value()); }

void ComplementaryFilter::reset_from_gravity(Vec3 a) {
    if (!(norm(a) > 0)) {
        q_ = identity();
        return;
    }
    // Eq. 3.5 (the thesis' listing anglesFromGravity): the rotation about x is atan2(ay, az), the one about y
    // is atan2(-ax, sqrt(ay^2 + az^2)). Eq. 3.5 calls them theta and phi, eq. 3.6 uses them as roll and pitch.
    const real roll = std::atan2(a.y, a.z);
    const real pitch = std::atan2(-a.x, std::sqrt(a.y * a.y + a.z * a.z));
    q_ = from_roll_pitch(roll, pitch);  // eq. 3.6 with yaw = 0
}

void ComplementaryFilter::update(Vec3 gyro, Vec3 accel, real dt) {
    const Vec3 a = median_.update(accel);  // thesis §4.2.2: the median-filtered accelerometer

    // Eq. 3.4, attitude propagation: q_w = q + dt/2 * q (x) (0, omega).
    const real h = dt / 2, hx = h * gyro.x, hy = h * gyro.y, hz = h * gyro.z;
    const Quat& q = q_;
    const Quat qw = normalized(Quat{q.w - hx * q.x - hy * q.y - hz * q.z,
                                    q.x + hx * q.w - hy * q.z + hz * q.y,
                                    q.y + hx * q.z + hy * q.w - hz * q.x,
                                    q.z - hx * q.y + hy * q.x + hz * q.w});

    const real an = norm(a);
    gain_ = adaptive_gain(s_, an);  // eq. 3.17-3.19
    if (gain_ <= 0) {  // no trustworthy gravity: gyro only
        q_ = qw;
        return;
    }
    // Eq. 3.12: the measured gravity direction in the global frame, predicted with q_w.
    const Vec3 gp = rotate(qw, a * (1 / an));
    // Eq. 3.13: the delta rotation between the predicted gravity g_p and the global gravity (0, 0, 1). As in the
    // thesis' listing it takes g_p onto (0, 0, 1): it is a correction in the global frame.
    const Quat dq = from_two_vectors(gp, Vec3{0, 0, 1});
    // Eq. 3.14-3.15: LERP with the identity by the gain, normalised.
    const real k = gain_, k1 = 1 - gain_;
    const Quat dqn = normalized(Quat{k1 + k * dq.w, k * dq.x, k * dq.y, k * dq.z});
    // Eq. 3.16 composes q_w (x) dq in Valenti's global->local convention. q here is local->global (eq. 3.4,
    // eq. 3.12), so the same global-frame correction multiplies from the left. The thesis' listing multiplies
    // from the right, which corrects about the wrong axis once the heading is not zero (test_filter checks it).
    q_ = normalized(dqn * qw);
}

}  // namespace gc
