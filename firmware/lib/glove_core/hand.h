// The thesis hand model (§3.1, §4.2.4): 16 segments, one complementary filter per IMU, the reference-pose
// correction (eq. 3.21), distal interpolation (eq. 3.3) and the global -> parent-relative conversion.
//
// Segments (recorder/hand/skeleton.py): 0 palm; 1-3 thumb metacarpal, proximal, distal; then index, middle,
// ring, pinky as proximal, intermediate, distal (4-6, 7-9, 10-12, 13-15). Parent of segment s is s-1 inside a
// chain, the palm for the chain bases (1, 4, 7, 10, 13), the glove's reference frame for the palm.
//
// Frames and joint angles are those of recorder/hand/kinematics.py: a segment's orientation relative to its
// parent is REST[s] Rz(abduction) Ry(flexion), REST the identity but for the thumb metacarpal (kThumbRest). The
// reference pose (calibration, the button, reset_pose) is taken as the model's zero pose unless
// HandSettings::reference says otherwise: hand flat, fingers straight and together, thumb relaxed beside them.
#pragma once

#include <cstdint>

#include "complementary_filter.h"
#include "quaternion.h"

namespace gc {

constexpr uint8_t kSegments = 16;
constexpr uint8_t kMaxImus = 16;
constexpr uint8_t kJoints = 20;  // kinematics.JOINTS: thumb CMC flex, CMC abd, MCP, IP; per finger MCP flex, abd, PIP, DIP
// kinematics.REST[1]: the thumb metacarpal's frame on the palm at zero joint angles (yaw 40, tilt 15, roll -70 deg).
constexpr Quat kThumbRest{real(0.7375598677397128), real(-0.5709435150228974), real(-0.09402370913031675),
                          real(0.3481213671615886)};
int8_t segment_parent(uint8_t segment);  // -1 for the palm

struct HandSettings {
    FilterSettings filter;
    // Eq. 3.3: distal angle = 65/115 x the angle between proximal and intermediate, none when that is negative.
    real distal_ratio = real(65) / 115;
    // Flexion axis in the reference-corrected segment frame: IMU x along the finger towards the tip, z out of the
    // back of the hand, so curling the finger is a positive rotation about +y.
    Vec3 flexion_axis{0, 1, 0};
    // Parent-relative orientation of every segment in the reference pose: the model's zero pose by default.
    Quat reference[kSegments] = {Quat{}, kThumbRest};
};

// The 20 joint angles (radians, kinematics.JOINTS order) of 16 parent-relative quaternions, exactly as
// kinematics.joint_angles_from_relative: r = REST^-1 q per segment decomposed as Rz(abduction) Ry(flexion);
// hinges keep the flexion only.
void joint_angles(const Quat rel[kSegments], real angles[kJoints]);

class Hand {
public:
    // joint_map[i]: the segment IMU i is strapped to (thesis table 4.1).
    void init(const HandSettings& settings, uint8_t n_imu, const uint8_t* joint_map);

    ComplementaryFilter& filter(uint8_t imu) { return filters_[imu]; }
    const ComplementaryFilter& filter(uint8_t imu) const { return filters_[imu]; }
    void update(uint8_t imu, Vec3 gyro, Vec3 accel, real dt) { filters_[imu].update(gyro, accel, dt); }
    void observe(uint8_t imu, Vec3 accel) { filters_[imu].observe(accel); }

    // Thesis §3.5.3 reset: every filter restarts from its (median-filtered) gravity, eq. 3.5-3.6, and that
    // attitude becomes the segment's reference q_ref of eq. 3.21.
    void reset_pose();

    // Segments carrying an IMU: bit s set (the pose frame's measured_mask).
    uint16_t measured_mask() const { return measured_; }

    // The 16 parent-relative quaternions sent in pose frames and JSON lines: eq. 3.21 corrected orientations
    // placed on the reference pose (conj(corr[parent]) reference[s] corr[s]), eq. 3.3 for finger distal phalanges
    // without an IMU, the reference orientation for any other segment without one.
    void relative_pose(Quat out[kSegments]) const;

    // The eq. 3.21 corrected orientation of a segment (q_ref^-1 q_est); identity without an IMU.
    Quat corrected(uint8_t segment) const;

private:
    Quat interpolated_distal(uint8_t segment, const Quat rel[kSegments]) const;

    HandSettings s_;
    uint8_t n_imu_ = 0;
    int8_t imu_of_segment_[kSegments];
    uint16_t measured_ = 0;
    ComplementaryFilter filters_[kMaxImus];
    Quat ref_[kMaxImus];
};

}  // namespace gc
