#include "hand.h"

namespace gc {

int8_t segment_parent(uint8_t s) {
    if (s == 0 || s >= kSegments) return -1;
    return (s - 1) % 3 == 0 ? 0 : static_cast<int8_t>(s - 1);
}

void Hand::init(const HandSettings& settings, uint8_t n_imu, const uint8_t* joint_map) {
    s_ = settings;
    n_imu_ = n_imu > kMaxImus ? kMaxImus : n_imu;
    measured_ = 0;
    for (auto& i : imu_of_segment_) i = -1;
    for (uint8_t i = 0; i < n_imu_; ++i) {
        filters_[i].init(s_.filter);
        ref_[i] = identity();
        if (joint_map[i] < kSegments) {
            imu_of_segment_[joint_map[i]] = static_cast<int8_t>(i);
            measured_ |= static_cast<uint16_t>(1u << joint_map[i]);
        }
    }
}

void Hand::reset_pose() {
    for (uint8_t i = 0; i < n_imu_; ++i) {
        filters_[i].reset_from_gravity();
        ref_[i] = filters_[i].quaternion();
    }
}

Quat Hand::corrected(uint8_t segment) const {
    const int8_t i = segment < kSegments ? imu_of_segment_[segment] : -1;
    if (i < 0) return identity();
    return conj(ref_[i]) * filters_[i].quaternion();  // eq. 3.21: q_corr = q_ref^-1 q_est
}

Quat Hand::interpolated_distal(uint8_t s, const Quat corr[kSegments]) const {
    // A finger distal phalanx (third of its chain) whose two parents carry IMUs: eq. 3.3.
    if ((s - 1) % 3 != 2 || imu_of_segment_[s - 1] < 0 || imu_of_segment_[s - 2] < 0) return identity();
    const Quat between = conj(corr[s - 2]) * corr[s - 1];  // intermediate relative to proximal
    const real alpha = twist_angle(between, s_.flexion_axis);
    const real beta = alpha > 0 ? s_.distal_ratio * alpha : 0;
    return from_axis_angle(s_.flexion_axis, beta);
}

void Hand::relative_pose(Quat out[kSegments]) const {
    Quat corr[kSegments];
    for (uint8_t s = 0; s < kSegments; ++s) corr[s] = corrected(s);
    for (uint8_t s = 0; s < kSegments; ++s) {
        if (imu_of_segment_[s] < 0) {
            out[s] = s == 0 ? identity() : interpolated_distal(s, corr);
            if (s != 0) corr[s] = corr[segment_parent(s)] * out[s];  // global, for any child further out
            continue;
        }
        const int8_t p = segment_parent(s);
        out[s] = p < 0 ? corr[s] : normalized(conj(corr[p]) * corr[s]);  // parent-relative (thesis §3.2)
    }
}

}  // namespace gc
