#include "complementary_filter.h"

#include <cmath>

namespace gc {

FilterSettings thesis_settings() {
    FilterSettings s;
    s.mode = FilterMode::Thesis;
    return s;
}

real adaptive_gain(const FilterSettings& s, real accel_norm_g) {
    const real em = std::fabs(accel_norm_g - 1);  // eq. 3.17, accelerometer in g (so g = 1)
    if (!(em < s.error_threshold2)) return 0;     // eq. 3.19, e_m >= t2 (and NaN)
    if (em <= s.error_threshold1) return s.static_gain;
    // Eq. 3.19 writes (t2 - e_m) / t1, which is continuous only when t2 = 2 t1 (the thesis' 0.1 / 0.2);
    // (t2 - e_m) / (t2 - t1) is the same value there and stays continuous for other thresholds.
    return s.static_gain * (s.error_threshold2 - em) / (s.error_threshold2 - s.error_threshold1);
}

Quat attitude_from_gravity(Vec3 a) {
    const real r = std::sqrt(a.y * a.y + a.z * a.z), n = std::sqrt(a.x * a.x + r * r);
    if (!(n > 0)) return identity();
    // roll = atan2(ay, az): (cos, sin) of roll / 2 is the direction of (r + az, ay), or of (|ay|, +-(r - az)) when
    // az < 0, where r + az loses its digits (the same direction: the half angle of a vector; -0 for ay = -0 as
    // atan2). Gravity along x (r = 0): roll 0.
    real cr = 1, sr = 0;
    if (r > 0) {
        const bool neg = std::signbit(a.y);
        const real u = a.z >= 0 ? r + a.z : std::fabs(a.y), v = a.z >= 0 ? a.y : (neg ? a.z - r : r - a.z);
        const real k = 1 / std::sqrt(u * u + v * v);
        cr = u * k;
        sr = v * k;
    }
    // pitch = atan2(-ax, r), within +-90 deg: the direction of (n + r, -ax), never degenerate.
    const real u = n + r, v = -a.x, k = 1 / std::sqrt(u * u + v * v);
    const real cp = u * k, sp = v * k;
    return {cr * cp, sr * cp, cr * sp, -sr * sp};  // eq. 3.6 with yaw 0, as from_roll_pitch
}

Quat exp_half(Vec3 h) {
    const real t = h.x * h.x + h.y * h.y + h.z * h.z;  // |h|^2
    const real c = 1 - t * (real(0.5) - t * (real(1) / 24));
    const real s = 1 - t * (real(1) / 6 - t * (real(1) / 120));
    return {c, s * h.x, s * h.y, s * h.z};
}

void ComplementaryFilter::init(const FilterSettings& settings) {
    s_ = settings;
    median_.init(settings.median_window);
    q_ = identity();
    gain_ = 0;
    set_inertial(identity());
}

void ComplementaryFilter::set_inertial(Quat qc) {
    qc_ = qc;
    qg_ = identity();
    const Vec3 up = rotate(conj(qc), Vec3{0, 0, 1});  // gravity of this attitude in the IMU's axes
    for (Vec3& y : y_) y = up;
    observed_ = 0;
}

void ComplementaryFilter::set_quaternion(Quat q) {
    q_ = normalized(q);
    set_inertial(q_);
}

Vec3 ComplementaryFilter::filtered_accel() const {
    if (s_.mode == FilterMode::Thesis) return median_.value();
    return rotate(conj(qg_), inertial_gravity());
}

void ComplementaryFilter::observe(Vec3 accel) {
    if (s_.mode == FilterMode::Thesis) {
        median_.update(accel);
        return;
    }
    const Vec3 a = rotate(qg_, accel);
    if (observed_ < 65535) ++observed_;
    const real n = static_cast<real>(observed_);
    const Vec3 m{y_[0].x + (a.x - y_[0].x) / n, y_[0].y + (a.y - y_[0].y) / n, y_[0].z + (a.z - y_[0].z) / n};
    for (Vec3& y : y_) y = m;  // the mean of the samples observed since the last update
}

void ComplementaryFilter::reset_from_gravity() {
    if (s_.mode == FilterMode::Thesis) {
        reset_from_gravity(median_.value());
        return;
    }
    // The low-pass is kept, re-expressed in the new almost-inertial frame: the IMU's own axes at this moment.
    for (Vec3& y : y_) y = rotate(conj(qg_), y);
    qg_ = identity();
    observed_ = 0;
    qc_ = attitude_from_gravity(inertial_gravity());
    q_ = normalized(qc_ * qg_);
}

void ComplementaryFilter::reset_from_gravity(Vec3 a) {
    if (s_.mode == FilterMode::Inertial) {
        for (Vec3& y : y_) y = a;  // the low-pass restarts at this sample, in the IMU's axes
        qg_ = identity();
        reset_from_gravity();
        return;
    }
    if (!(norm(a) > 0)) {
        q_ = identity();
        return;
    }
    // Eq. 3.5 (the thesis' listing anglesFromGravity): the rotation about x is atan2(ay, az), the one about y
    // is atan2(-ax, sqrt(ay^2 + az^2)). Eq. 3.5 calls them theta and phi, eq. 3.6 uses them as roll and pitch.
    const real roll = atan2_d(a.y, a.z);
    const real pitch = atan2_d(-a.x, std::sqrt(a.y * a.y + a.z * a.z));
    q_ = from_roll_pitch(roll, pitch);  // eq. 3.6 with yaw = 0
}

void ComplementaryFilter::update(Vec3 gyro, Vec3 accel, real dt) {
    if (s_.mode == FilterMode::Thesis)
        update_thesis(gyro, accel, dt);
    else
        update_inertial(gyro, accel, dt);
}

void ComplementaryFilter::update_inertial(Vec3 gyro, Vec3 accel, real dt) {
    // 1. The gyro alone: q_g from the IMU's axes into the almost-inertial frame I.
    const real h = dt / 2;
    qg_ = normalized(qg_ * exp_half(Vec3{h * gyro.x, h * gyro.y, h * gyro.z}));
    // 2-3. The accelerometer in I through three first-order low-pass stages.
    const Vec3 a = rotate(qg_, accel);
    real k = dt / s_.tau_s;
    if (k > 1) k = 1;
    gain_ = k;
    real* y0 = &y_[0].x;
    real* y1 = &y_[1].x;
    real* y2 = &y_[2].x;
    const real* ai = &a.x;
    for (int c = 0; c < 3; ++c) {
        y0[c] = y0[c] + k * (ai[c] - y0[c]);
        y1[c] = y1[c] + k * (y0[c] - y1[c]);
        y2[c] = y2[c] + k * (y1[c] - y2[c]);
    }
    observed_ = 0;
    // 4-5. The low-passed gravity in the world; q_c turns it onto (0, 0, 1) entirely, about a horizontal axis.
    const Vec3 e = rotate(qc_, inertial_gravity());
    const real n = norm(e);
    if (n > 0 && std::isfinite(n)) {
        const Vec3 u = e * (1 / n);
        if (1 + u.z > real(1e-6)) qc_ = normalized(normalized(Quat{1 + u.z, u.y, -u.x, 0}) * qc_);
    }
    // 6.
    q_ = normalized(qc_ * qg_);
}

void ComplementaryFilter::update_thesis(Vec3 gyro, Vec3 accel, real dt) {
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
