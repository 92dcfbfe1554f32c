// Gyro bias calibration with a stillness check (thesis §3.5.3, eq. 3.20).
#include "calibration.h"
#include "check.h"
#include "helpers.h"

using namespace gc;
using namespace testing_helpers;

namespace {

constexpr uint8_t kN = 12;
const Vec3 kBias{0.02f, -0.035f, 0.011f};  // rad/s, typical MPU9250 zero-rate offsets (1-2 deg/s)

CalibEvent feed(GyroCalibration& c, Rng& rng, int cycles, Vec3 gyro_offset = {}, uint16_t ok = 0xFFF) {
    CalibEvent last = CalibEvent::None;
    for (int k = 0; k < cycles && last == CalibEvent::None; ++k) {
        Vec3 g[kN], a[kN];
        for (uint8_t i = 0; i < kN; ++i) {
            g[i] = kBias + gyro_offset + rng.vec(0.004f) + Vec3{0.001f * i, 0, 0};  // per-IMU bias
            a[i] = Vec3{0, 0, 1} + rng.vec(0.01f);
        }
        last = c.update(g, a, ok);
    }
    return last;
}

}  // namespace

TEST(still_hand_gives_the_mean_rate_as_bias) {
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    CHECK(c.state() == CalibState::Idle);
    c.start();
    CHECK(c.state() == CalibState::Running);
    Rng rng;
    CHECK(feed(c, rng, 255) == CalibEvent::None);
    CHECK(c.progress() == 99);
    CHECK(feed(c, rng, 1) == CalibEvent::Done);
    CHECK(c.state() == CalibState::Done);
    CHECK(c.progress() == 100);
    for (uint8_t i = 0; i < kN; ++i) {
        CHECK_NEAR(c.bias(i).x, kBias.x + 0.001 * i, 5e-4);
        CHECK_NEAR(c.bias(i).y, kBias.y, 5e-4);
        CHECK_NEAR(c.bias(i).z, kBias.z, 5e-4);
    }
    const Vec3 w = c.corrected(3, Vec3{1, 1, 1});  // eq. 3.20
    CHECK_NEAR(w.y, 1 - c.bias(3).y, 1e-7);
}

TEST(a_jolt_refuses_and_the_retry_succeeds) {
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    c.start();
    Rng rng;
    CHECK(feed(c, rng, 100) == CalibEvent::None);
    Vec3 g[kN], a[kN];
    for (uint8_t i = 0; i < kN; ++i) {
        g[i] = kBias;
        a[i] = {0, 0, 1};
    }
    g[7] = Vec3{0.5f, 0, 0};  // one finger moves
    CHECK(c.update(g, a, 0xFFF) == CalibEvent::Refused);
    CHECK(c.state() == CalibState::Refused);
    CHECK(c.refusals() == 1);
    CHECK(c.progress() == 0);
    CHECK(c.running());
    CHECK(c.bias(0).x == 0.0f);  // nothing adopted from the refused attempt
    CHECK(feed(c, rng, 400) == CalibEvent::Done);
    CHECK_NEAR(c.bias(0).y, kBias.y, 5e-4);
}

TEST(tilting_the_hand_refuses) {
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    c.start();
    Rng rng;
    feed(c, rng, 50);
    Vec3 g[kN], a[kN];
    for (uint8_t i = 0; i < kN; ++i) {
        g[i] = kBias;
        a[i] = {0, 0, 1};
    }
    a[0] = {0.2f, 0, 0.98f};  // the palm tilted by 11 deg with the gyro noise-free: the accelerometer tells
    CHECK(c.update(g, a, 0xFFF) == CalibEvent::Refused);
}

TEST(a_slow_steady_turn_is_not_a_bias) {
    // 0.3 rad/s about the vertical: no spread in gyro or accelerometer, but no MPU9250 has such an offset.
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    c.start();
    Rng rng;
    CHECK(feed(c, rng, 300, Vec3{0, 0, 0.3f}) == CalibEvent::Refused);
    CHECK(c.bias(0).z == 0.0f);
}

TEST(noise_below_the_limits_is_accepted) {
    CalibrationSettings s;
    s.max_gyro_range = 0.02f;  // tighter than the default; noise of +-0.004 rad/s still passes
    GyroCalibration c;
    c.init(s, kN);
    c.start();
    Rng rng;
    CHECK(feed(c, rng, 300) == CalibEvent::Done);
    s.max_gyro_range = 0.005f;  // now the same noise (range up to 0.008) is "motion"
    c.init(s, kN);
    c.start();
    CHECK(feed(c, rng, 300) == CalibEvent::Refused);
}

TEST(silent_imu_keeps_its_previous_bias) {
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    c.set_bias(5, Vec3{0.1f, 0.1f, 0.1f});
    c.start();
    Rng rng;
    CHECK(feed(c, rng, 300, {}, static_cast<uint16_t>(0xFFF & ~(1u << 5))) == CalibEvent::Done);
    CHECK(c.bias(5).x == 0.1f);                 // never answered: old bias kept
    CHECK_NEAR(c.bias(4).y, kBias.y, 5e-4);     // the others calibrated
}

TEST(non_finite_reading_is_motion) {
    GyroCalibration c;
    c.init(CalibrationSettings{}, kN);
    c.start();
    Vec3 g[kN], a[kN];
    for (uint8_t i = 0; i < kN; ++i) {
        g[i] = kBias;
        a[i] = {0, 0, 1};
    }
    c.update(g, a, 0xFFF);
    g[2].x = NAN;
    CHECK(c.update(g, a, 0xFFF) == CalibEvent::Refused);
}

TEST(restart_after_done) {
    GyroCalibration c;
    CalibrationSettings s;
    s.samples = 10;
    c.init(s, kN);
    c.start();
    Rng rng;
    CHECK(feed(c, rng, 10) == CalibEvent::Done);
    CHECK(!c.running());
    CHECK(feed(c, rng, 10) == CalibEvent::None);  // idle once done: updates are ignored
    c.start();
    CHECK(c.progress() == 0);
    CHECK(feed(c, rng, 10) == CalibEvent::Done);
}

TEST_MAIN()
