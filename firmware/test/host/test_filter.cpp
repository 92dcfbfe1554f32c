// The glove's filter in its two modes: Inertial (the default: the accelerometer low-passed in an almost-inertial
// frame, docs/fusion.md) and Thesis (the complementary filter with adaptive gain of thesis eq. 3.4-3.19 and the
// accelerometer median filter).
#include <utility>

#include "check.h"
#include "complementary_filter.h"
#include "helpers.h"

using namespace gc;
using namespace testing_helpers;

namespace {

// Specific force (g) a still sensor with orientation q measures: the global "up" seen in the sensor frame.
Vec3 gravity_in_body(Quat q) { return rotate(conj(q), {0, 0, 1}); }

float tilt_error(Quat est, Quat truth) {  // angle between the true and estimated "up" directions
    const Vec3 a = rotate(est, gravity_in_body(truth));
    return std::acos(std::fmin(1.0f, a.z));
}

}  // namespace

TEST(adaptive_gain_follows_eq_3_19) {
    const FilterSettings s;  // thesis values: 0.005, 0.1, 0.2
    CHECK_NEAR(adaptive_gain(s, 1.0f), 0.005, 1e-9);
    CHECK_NEAR(adaptive_gain(s, 1.1f), 0.005, 1e-7);   // e_m = t1: full gain
    CHECK_NEAR(adaptive_gain(s, 0.95f), 0.005, 1e-9);
    CHECK_NEAR(adaptive_gain(s, 1.15f), 0.0025, 1e-6); // halfway between the thresholds
    CHECK_NEAR(adaptive_gain(s, 0.85f), 0.0025, 1e-6); // |a| below g counts the same
    CHECK_NEAR(adaptive_gain(s, 1.19f), 0.0005, 1e-6);
    CHECK(adaptive_gain(s, 1.2f) == 0.0f);             // e_m >= t2: no correction
    CHECK(adaptive_gain(s, 3.0f) == 0.0f);
    CHECK(adaptive_gain(s, 0.0f) == 0.0f);             // free fall
    CHECK(adaptive_gain(s, NAN) == 0.0f);
    // (t2 - e)/t1 of eq. 3.19 and our (t2 - e)/(t2 - t1) agree for the thesis thresholds
    for (float e = 0.1f; e < 0.2f; e += 0.01f) CHECK_NEAR(adaptive_gain(s, 1.0f + e), 0.005 * (0.2 - e) / 0.1, 1e-6);
    // continuous at both thresholds for other settings too
    FilterSettings o = thesis_settings();
    o.error_threshold1 = 0.05f;
    o.error_threshold2 = 0.3f;
    CHECK_NEAR(adaptive_gain(o, 1.0501f), o.static_gain, 1e-5);
    CHECK_NEAR(adaptive_gain(o, 1.2999f), 0.0, 1e-5);
}

TEST(initial_attitude_from_gravity_eq_3_5) {
    ComplementaryFilter f;
    f.init(thesis_settings());
    Rng rng;
    for (int n = 0; n < 100; ++n) {
        const Quat truth = normalized(Quat{rng.next(), rng.next(), rng.next(), rng.next()});
        f.reset_from_gravity(gravity_in_body(truth) * 1.3f);  // magnitude does not matter
        CHECK(tilt_error(f.quaternion(), truth) < 1e-3f);
        const Vec3 up = rotate(f.quaternion(), gravity_in_body(truth));
        CHECK_NEAR(up.z, 1.0, 1e-5);
    }
    f.reset_from_gravity({0, 0, 1});
    CHECK_NEAR(f.quaternion().w, 1, 1e-7);  // flat: identity, yaw 0
}

TEST(gyro_integrates_known_rotations_eq_3_4) {
    // 1 rad/s about each axis for 1 s at 1 kHz, gravity consistent with the motion: ends 1 rad about that axis.
    const Vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (const Vec3& axis : axes) {
        ComplementaryFilter f;
        f.init(thesis_settings());
        const float dt = 0.001f;
        for (int k = 1; k <= 1000; ++k) {
            const Quat truth = from_axis_angle(axis, k * dt);
            f.update(axis, gravity_in_body(truth), dt);
        }
        const Quat expect = from_axis_angle(axis, 1.0f);
        CHECK(angle_between(f.quaternion(), expect) < deg(0.5f));
    }
}

TEST(accelerometer_corrects_tilt_and_leaves_heading) {
    // Start 10 deg off in roll at a heading of 180 deg; a still sensor must converge back to the true tilt
    // while the heading stays. (Multiplying the correction from the right, as the thesis' listing, diverges.)
    const Quat truth = from_axis_angle({0, 0, 1}, deg(180));
    ComplementaryFilter f;
    f.init(thesis_settings());
    f.set_quaternion(truth * from_axis_angle({1, 0, 0}, deg(10)));
    const float e0 = tilt_error(f.quaternion(), truth);
    for (int k = 0; k < 1000; ++k) f.update({0, 0, 0}, gravity_in_body(truth), 0.001f);
    const float e1 = tilt_error(f.quaternion(), truth);
    CHECK_NEAR(e0, deg(10), deg(0.01f));
    // gain 0.005 per step: 1000 steps leave (1 - 0.005)^1000 = 0.7 % of the error
    CHECK(e1 < deg(0.1f));
    CHECK(angle_between(f.quaternion(), truth) < deg(0.2f));  // heading untouched
}

TEST(correction_rate_is_the_static_gain) {
    // One step removes alpha = 0.005 of a small tilt error (eq. 3.14 LERP).
    ComplementaryFilter f;
    f.init(thesis_settings());
    f.set_quaternion(from_axis_angle({1, 0, 0}, deg(2)));
    f.update({0, 0, 0}, {0, 0, 1}, 0.001f);
    CHECK_NEAR(tilt_error(f.quaternion(), identity()), deg(2) * 0.995, deg(0.0005f));
    CHECK_NEAR(f.last_gain(), 0.005, 1e-9);
}

TEST(linear_acceleration_switches_correction_off) {
    // |a| = 1.5 g (e_m = 0.5 >= t2): the filter must trust the gyro only and not tilt towards the fake gravity.
    ComplementaryFilter f;
    f.init(thesis_settings());
    for (int k = 0; k < 500; ++k) f.update({0, 0, 0}, {1.5f * std::sin(0.5f), 0, 1.5f * std::cos(0.5f)}, 0.001f);
    CHECK(f.last_gain() == 0.0f);
    CHECK(angle_between(f.quaternion(), identity()) < 1e-6f);
    // Same direction at 1 g: the filter does tilt towards it.
    for (int k = 0; k < 500; ++k) f.update({0, 0, 0}, {std::sin(0.5f), 0, std::cos(0.5f)}, 0.001f);
    CHECK(angle_between(f.quaternion(), identity()) > deg(2));
}

TEST(median_filter_rejects_spikes) {
    ComplementaryFilter f;
    f.init(thesis_settings());
    for (int k = 0; k < 12; ++k) f.update({0, 0, 0}, {0, 0, 1}, 0.001f);
    // A 12-sample buffer with 5 spikes still has a median of (0, 0, 1): no correction happens.
    for (int k = 0; k < 5; ++k) f.update({0, 0, 0}, {0.9f, 0, 0.2f}, 0.001f);
    const Vec3 m = f.filtered_accel();
    CHECK_NEAR(m.x, 0, 1e-7);
    CHECK_NEAR(m.z, 1, 1e-7);
    CHECK(angle_between(f.quaternion(), identity()) < 1e-6f);
}

TEST(median_of_even_and_partial_buffers) {
    MedianFilter3 m;
    m.init(12);
    CHECK(m.value().x == 0.0f);
    m.update({1, 0, 0});
    CHECK(m.value().x == 1.0f);
    m.update({4, 0, 0});
    CHECK(m.value().x == 2.5f);                        // two samples: mean of the middle pair
    m.update({2, 0, 0});
    CHECK(m.value().x == 2.0f);
    for (int k = 0; k < 20; ++k) m.update({static_cast<float>(k), -static_cast<float>(k), 0});
    CHECK(m.count() == 12);
    CHECK(m.value().x == 13.5f);                       // last 12 of 0..19 are 8..19
    CHECK(m.value().y == -13.5f);
    MedianFilter3 one;
    one.init(1);
    one.update({3, 0, 0});
    CHECK(one.update({7, 0, 0}).x == 7.0f);            // window 1: no filtering
    m.update({NAN, 0, 0});                             // ignored: the window is not poisoned
    CHECK(m.value().x == 13.5f && m.count() == 12);
    MedianFilter3 big;
    big.init(200);                                     // clamped to the buffer
    for (int k = 0; k < 40; ++k) big.update({1, 1, 1});
    CHECK(big.count() == MedianFilter3::kMaxWindow);
}

TEST(running_median_equals_a_sorted_window) {
    // Against a brute-force median of the last `window` samples, for every window size and partial windows.
    Rng rng;
    for (uint8_t window = 1; window <= MedianFilter3::kMaxWindow; ++window) {
        MedianFilter3 m;
        m.init(window);
        real hist[200][3];
        for (int k = 0; k < 200; ++k) {
            const Vec3 v = rng.vec(1.0f);
            // repeated values too: ties must be removed one at a time
            hist[k][0] = k % 7 == 0 ? real(0.5) : v.x;
            hist[k][1] = std::round(v.y * 4) / 4;
            hist[k][2] = v.z;
            const Vec3 got = m.update({hist[k][0], hist[k][1], hist[k][2]});
            const int n = k + 1 < window ? k + 1 : window;
            for (int a = 0; a < 3; ++a) {
                real s[MedianFilter3::kMaxWindow];
                for (int i = 0; i < n; ++i) s[i] = hist[k - i][a];
                for (int i = 1; i < n; ++i)
                    for (int j = i; j > 0 && s[j - 1] > s[j]; --j) std::swap(s[j - 1], s[j]);
                const real med = n % 2 ? s[n / 2] : (s[n / 2 - 1] + s[n / 2]) / 2;
                const real g = a == 0 ? got.x : (a == 1 ? got.y : got.z);
                CHECK(g == med);
            }
        }
    }
}

TEST(quaternion_stays_normalised) {
    for (const FilterSettings& s : {thesis_settings(), FilterSettings{}}) {
        ComplementaryFilter f;
        f.init(s);
        Rng rng;
        for (int k = 0; k < 20000; ++k) f.update(rng.vec(8.0f), Vec3{0, 0, 1} + rng.vec(0.3f), 0.002f);
        CHECK_NEAR(norm(f.quaternion()), 1, 1e-5);
    }
}

// ---------------------------------------------------------------------------------------- FilterMode::Inertial

namespace {

ComplementaryFilter inertial(real tau = 4, real ramp = 3) {
    FilterSettings s;
    s.tau_s = tau;
    s.ramp = ramp;
    ComplementaryFilter f;
    f.init(s);
    return f;
}

}  // namespace

TEST(inertial_is_the_default_mode) {
    CHECK(FilterSettings{}.mode == FilterMode::Inertial);
    CHECK(thesis_settings().mode == FilterMode::Thesis);
}

TEST(exp_half_is_the_rotation_exponential) {
    // Against from_axis_angle for angles per step up to 0.3 rad (dt/2 |omega| = 0.15): the Taylor series to
    // |h|^4 misses |h|^6 / 720 of the cosine.
    Rng rng;
    for (int n = 0; n < 200; ++n) {
        const Vec3 axis = rng.vec(1.0f);
        const real len = norm(axis);
        if (len < real(0.1)) continue;
        const Vec3 u = axis * (1 / len);
        const real angle = real(0.3) * (rng.next() + 1) / 2;
        const Quat want = from_axis_angle(u, angle);
        const Quat got = exp_half(u * (angle / 2));
        CHECK(angle_between(normalized(got), want) < 1e-6f);
        CHECK_NEAR(norm(got), 1, 2e-6);
    }
}

TEST(inertial_gyro_integrates_known_rotations) {
    // 3 rad/s about each axis for 1 s at 1 kHz with gravity consistent with the motion: ends 3 rad about it.
    const Vec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (const Vec3& axis : axes) {
        ComplementaryFilter f = inertial();
        f.reset_from_gravity({0, 0, 1});
        const float dt = 0.001f;
        for (int k = 1; k <= 1000; ++k) f.update(axis * 3, gravity_in_body(from_axis_angle(axis, 3 * k * dt)), dt);
        CHECK(angle_between(f.quaternion(), from_axis_angle(axis, 3.0f)) < deg(0.05f));
    }
}

TEST(inertial_corrects_tilt_and_leaves_heading) {
    // Start 10 deg off in roll at a heading of 180 deg: a still sensor converges to the true tilt at the pace
    // of the low-pass (three stages of 4 s) and the heading stays.
    const Quat truth = from_axis_angle({0, 0, 1}, deg(180));
    ComplementaryFilter f = inertial();
    f.set_quaternion(truth * from_axis_angle({1, 0, 0}, deg(10)));
    CHECK_NEAR(tilt_error(f.quaternion(), truth), deg(10), deg(0.01f));
    for (int k = 0; k < 1000; ++k) f.update({0, 0, 0}, gravity_in_body(truth), 0.01f);  // 10 s
    const float e10 = tilt_error(f.quaternion(), truth);
    for (int k = 0; k < 5000; ++k) f.update({0, 0, 0}, gravity_in_body(truth), 0.01f);  // 60 s
    CHECK(e10 < deg(9) && e10 > deg(1));  // a low-pass, not a jump
    CHECK(tilt_error(f.quaternion(), truth) < deg(0.05f));
    CHECK(angle_between(f.quaternion(), truth) < deg(0.1f));  // the correction is about horizontal axes
}

TEST(inertial_rejects_linear_acceleration_of_a_turning_hand) {
    // The hand turns about the vertical at 1 rad/s and shakes along the world x axis with 0.5 g at 1 Hz: in the
    // IMU's axes the shaking turns, in I it does not, and averages out. Tilt error stays below 0.3 deg; the
    // thesis filter at 1 kHz, fed the same, tilts by several degrees whenever its gate lets the shaking in.
    const real dt = real(0.001);
    ComplementaryFilter f = inertial(), t;
    t.init(thesis_settings());
    const Quat tilt = from_axis_angle({1, 0, 0}, deg(20));
    f.reset_from_gravity(gravity_in_body(tilt));
    t.reset_from_gravity(gravity_in_body(tilt));
    float worst = 0, worst_thesis = 0;
    for (int k = 1; k <= 60000; ++k) {
        const real s = k * dt;
        const Quat truth = from_axis_angle({0, 0, 1}, s) * tilt;
        const Vec3 world{real(0.5) * std::sin(2 * kPi * s), 0, 1};  // specific force in the world
        const Vec3 a = rotate(conj(truth), world);
        const Vec3 w = rotate(conj(tilt), Vec3{0, 0, 1});  // body rate of a turn about the world vertical
        f.update(w, a, dt);
        t.update(w, a, dt);
        if (s > 20) {
            worst = std::fmax(worst, tilt_error(f.quaternion(), truth));
            worst_thesis = std::fmax(worst_thesis, tilt_error(t.quaternion(), truth));
        }
    }
    CHECK(worst < deg(0.3f));
    CHECK(worst_thesis > deg(1));
}

TEST(inertial_ramp_follows_a_gyro_bias_without_lag) {
    // An uncorrected bias of 0.01 rad/s about x on a still IMU: I drifts steadily. With the ramp term the tilt
    // error dies out; a plain low-pass (ramp 0) lags by the bias times its delay, 3 tau = 12 s: 6.9 deg.
    const Vec3 bias{real(0.01), 0, 0};
    ComplementaryFilter f = inertial(), plain = inertial(4, 0);
    f.reset_from_gravity({0, 0, 1});
    plain.reset_from_gravity({0, 0, 1});
    for (int k = 0; k < 30000; ++k) {  // 300 s at 100 Hz
        f.update(bias, {0, 0, 1}, real(0.01));
        plain.update(bias, {0, 0, 1}, real(0.01));
    }
    CHECK(tilt_error(f.quaternion(), identity()) < deg(0.05f));
    CHECK_NEAR(tilt_error(plain.quaternion(), identity()), 0.12, 0.005);
}

TEST(inertial_observe_averages_and_reset_uses_the_low_pass) {
    ComplementaryFilter f = inertial();
    f.observe({0, 0, 1});
    f.observe({real(0.2), 0, real(0.98)});
    f.observe({real(-0.05), 0, 1});
    const Vec3 m = f.filtered_accel();
    CHECK_NEAR(m.x, 0.05, 1e-6);
    CHECK_NEAR(m.z, (1 + 0.98 + 1) / 3.0, 1e-6);
    f.reset_from_gravity();  // the button: eq. 3.5-3.6 from the mean of the samples observed
    ComplementaryFilter g = inertial();
    g.reset_from_gravity(m);
    CHECK(angle_between(f.quaternion(), g.quaternion()) < 1e-6f);
    // after motion, the reset takes the low-passed gravity in the IMU's axes now, with yaw 0
    const Quat truth = from_axis_angle({0, 1, 0}, deg(30));
    for (int k = 1; k <= 500; ++k)
        f.update({0, deg(30) / 5, 0}, gravity_in_body(from_axis_angle({0, 1, 0}, deg(30) * k / 500)), 0.01f);
    for (int k = 0; k < 6000; ++k) f.update({0, 0, 0}, gravity_in_body(truth), 0.01f);
    f.reset_from_gravity();
    CHECK(tilt_error(f.quaternion(), truth) < deg(0.05f));
    CHECK(angle_between(f.quaternion(), truth) < deg(0.05f));  // yaw 0: truth has none
    // the next observation starts a new mean
    f.observe({0, 0, 1});
    CHECK_NEAR(f.filtered_accel().x, 0, 1e-6);
}

TEST(inertial_survives_degenerate_input) {
    ComplementaryFilter f = inertial();
    f.reset_from_gravity({0, 0, 0});  // no gravity: identity
    CHECK(angle_between(f.quaternion(), identity()) < 1e-6f);
    for (int k = 0; k < 100; ++k) f.update({0, 0, 0}, {0, 0, 0}, 0.01f);  // free fall: no correction
    CHECK(angle_between(f.quaternion(), identity()) < 1e-6f);
    f.update({1, 0, 0}, {0, 0, -1}, 10.0f);  // a long gap (dt / tau > 1) and gravity upside down
    CHECK_NEAR(norm(f.quaternion()), 1, 1e-5);
}

TEST_MAIN()
