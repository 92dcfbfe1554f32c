#include "calibration.h"

#include <cmath>

namespace gc {

void GyroCalibration::init(const CalibrationSettings& settings, uint8_t n_imu) {
    s_ = settings;
    if (s_.samples == 0) s_.samples = 1;
    n_imu_ = n_imu > kMaxImus ? kMaxImus : n_imu;
    state_ = CalibState::Idle;
    refusals_ = 0;
    for (auto& b : bias_) b = Vec3{};
    clear();
}

void GyroCalibration::start() {
    state_ = CalibState::Running;
    refusals_ = 0;
    clear();
}

void GyroCalibration::clear() {
    cycles_ = 0;
    for (auto& a : acc_) a = Acc{};
}

void GyroCalibration::extend(Vec3& lo, Vec3& hi, Vec3 v, bool first) {
    if (first) {
        lo = hi = v;
        return;
    }
    lo = {std::fmin(lo.x, v.x), std::fmin(lo.y, v.y), std::fmin(lo.z, v.z)};
    hi = {std::fmax(hi.x, v.x), std::fmax(hi.y, v.y), std::fmax(hi.z, v.z)};
}

real GyroCalibration::spread(Vec3 lo, Vec3 hi) {
    return std::fmax(hi.x - lo.x, std::fmax(hi.y - lo.y, hi.z - lo.z));
}

CalibEvent GyroCalibration::update(const Vec3* gyro, const Vec3* accel, uint16_t ok_mask) {
    if (!running()) return CalibEvent::None;
    bool moved = false;
    for (uint8_t i = 0; i < n_imu_; ++i) {
        if (!(ok_mask >> i & 1u)) continue;
        Acc& a = acc_[i];
        extend(a.gmin, a.gmax, gyro[i], a.n == 0);
        extend(a.amin, a.amax, accel[i], a.n == 0);
        a.sum = a.sum + gyro[i];
        ++a.n;
        // Stillness; a non-finite reading counts as motion too.
        const real finite = dot(gyro[i], gyro[i]) + dot(accel[i], accel[i]);
        if (!std::isfinite(finite) || !(spread(a.gmin, a.gmax) <= s_.max_gyro_range) ||
            !(spread(a.amin, a.amax) <= s_.max_accel_range))
            moved = true;
    }
    if (moved) {
        ++refusals_;
        state_ = CalibState::Refused;  // reported as "refused", and retried from the next cycle
        clear();
        return CalibEvent::Refused;
    }
    if (++cycles_ < s_.samples) return CalibEvent::None;

    Vec3 mean[kMaxImus];
    for (uint8_t i = 0; i < n_imu_; ++i) {
        const Acc& a = acc_[i];
        mean[i] = a.n ? a.sum * (real(1) / a.n) : Vec3{};
        if (a.n && !(norm(mean[i]) <= s_.max_bias)) moved = true;  // turning slowly but steadily
    }
    if (moved) {
        ++refusals_;
        state_ = CalibState::Refused;
        clear();
        return CalibEvent::Refused;
    }
    for (uint8_t i = 0; i < n_imu_; ++i)
        if (2u * acc_[i].n >= s_.samples) bias_[i] = mean[i];
    state_ = CalibState::Done;
    clear();
    return CalibEvent::Done;
}

uint8_t GyroCalibration::progress() const {
    if (state_ == CalibState::Done) return 100;
    if (!running()) return 0;
    return static_cast<uint8_t>(100u * cycles_ / s_.samples);
}

}  // namespace gc
