#include "hand.h"

#include <cmath>

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

Quat Hand::interpolated_distal(uint8_t s, const Quat rel[kSegments]) const {
    // A finger distal phalanx (third of its chain) whose two parents carry IMUs: eq. 3.3 from the flexion of the
    // intermediate relative to the proximal.
    if ((s - 1) % 3 != 2 || imu_of_segment_[s - 1] < 0 || imu_of_segment_[s - 2] < 0) return s_.reference[s];
    const real alpha = twist_angle(rel[s - 1], s_.flexion_axis);
    const real beta = alpha > 0 ? s_.distal_ratio * alpha : 0;
    return s_.reference[s] * from_axis_angle(s_.flexion_axis, beta);
}

void Hand::relative_pose(Quat out[kSegments]) const {
    // corr[s]: the rotation of segment s since the reference pose, in its reference frame (eq. 3.21). With G the
    // segments' orientations, G[s] = G0[s] corr[s] and G0[s] = G0[parent] reference[s], so the parent-relative
    // orientation is conj(corr[parent]) reference[s] corr[s] (the palm's parent: the reference frame).
    Quat corr[kSegments];
    for (uint8_t s = 0; s < kSegments; ++s) {
        const int8_t p = segment_parent(s);
        const Quat parent = p < 0 ? identity() : corr[p];
        if (imu_of_segment_[s] >= 0) {
            corr[s] = corrected(s);
            out[s] = normalized(conj(parent) * s_.reference[s] * corr[s]);
            continue;
        }
        out[s] = s == 0 ? s_.reference[0] : interpolated_distal(s, out);
        corr[s] = conj(s_.reference[s]) * parent * out[s];  // for any child further out
    }
}

void joint_angles(const Quat rel[kSegments], real out[kJoints]) {
    for (uint8_t s = 1; s < kSegments; ++s) {
        const Quat r = s == 1 ? conj(kThumbRest) * rel[s] : rel[s];
        const int chain = (s - 1) / 3, link = (s - 1) % 3;  // chain 0 thumb .. 4 pinky; link 0 its base
        const int first = 4 * chain;
        // R = Rz(a) Ry(f): R[2,0] = -sin f, R[2,2] = cos f, R[0,1] = -sin a, R[1,1] = cos a
        out[first + (link == 0 ? 0 : link + 1)] =
            atan2_d(-2 * (r.x * r.z - r.w * r.y), 1 - 2 * (r.x * r.x + r.y * r.y));
        if (link == 0) out[first + 1] = atan2_d(-2 * (r.x * r.y - r.w * r.z), 1 - 2 * (r.x * r.x + r.z * r.z));
    }
}

}  // namespace gc
