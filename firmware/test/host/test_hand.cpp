// Hand model: reference-pose correction (eq. 3.21), distal interpolation (eq. 3.3), parent-relative output.
#include "check.h"
#include <initializer_list>

#include "hand.h"
#include "helpers.h"

using namespace gc;
using namespace testing_helpers;

namespace {

const uint8_t kJoint12[12] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};  // thesis table 4.1
const Vec3 kY{0, 1, 0}, kZ{0, 0, 1};

Hand flat_hand() {
    Hand h;
    h.init(HandSettings{}, 12, kJoint12);
    for (uint8_t i = 0; i < 12; ++i) h.observe(i, {0, 0, 1});
    h.reset_pose();  // references are the identity
    return h;
}

bool same(Quat a, Quat b, float tol = 1e-5f) { return angle_between(a, b) < tol; }

}  // namespace

TEST(parents_match_recorder_skeleton) {
    const int8_t parents[16] = {-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 0, 10, 11, 0, 13, 14};  // skeleton.PARENTS
    for (uint8_t s = 0; s < 16; ++s) CHECK(segment_parent(s) == parents[s]);
}

TEST(measured_mask_of_table_4_1) {
    Hand h;
    h.init(HandSettings{}, 12, kJoint12);
    CHECK(h.measured_mask() == 0x6DBF);  // skeleton.MEASURED_MASK: all but 6, 9, 12, 15
    uint8_t joint16[16];
    for (uint8_t i = 0; i < 16; ++i) joint16[i] = i;
    h.init(HandSettings{}, 16, joint16);
    CHECK(h.measured_mask() == 0xFFFF);
}

TEST(reset_pose_makes_the_reference_pose_eq_3_21) {
    // IMUs strapped on at arbitrary tilts: after the reset the pose is the reference pose, the model's zero pose
    // (recorder/hand/kinematics.py): identity relative to the parent, but the thumb metacarpal's REST.
    Hand h;
    h.init(HandSettings{}, 12, kJoint12);
    Rng rng;
    for (uint8_t i = 0; i < 12; ++i) {
        const Vec3 g = Vec3{0, 0, 1} + rng.vec(0.6f);
        for (int k = 0; k < 12; ++k) h.observe(i, g);
    }
    h.reset_pose();
    Quat rel[16];
    h.relative_pose(rel);
    for (uint8_t s = 0; s < 16; ++s) CHECK(same(rel[s], s == 1 ? kThumbRest : identity()));
}

TEST(mounting_tilt_is_removed_eq_3_21) {
    // Palm IMU mounted 20 deg tilted; the hand then turns 30 deg about the vertical.
    Hand h;
    h.init(HandSettings{}, 12, kJoint12);
    const Quat mount = from_axis_angle({1, 0, 0}, deg(20));
    for (int k = 0; k < 12; ++k) h.observe(0, rotate(conj(mount), kZ));
    h.reset_pose();
    CHECK(same(h.filter(0).quaternion(), mount, 1e-4f));  // eq. 3.5-3.6 found the mounting tilt
    h.filter(0).set_quaternion(from_axis_angle(kZ, deg(30)) * mount);
    const Quat c = h.corrected(0);
    CHECK_NEAR(angle_between(c, identity()), deg(30), 1e-4);
    CHECK(same(c, conj(mount) * from_axis_angle(kZ, deg(30)) * mount, 1e-4f));  // q_ref^-1 q_est
}

TEST(parent_relative_quaternions) {
    Hand h = flat_hand();
    const Quat palm = from_axis_angle(kZ, deg(30));
    const Quat prox = palm * from_axis_angle(kY, deg(40));
    const Quat inter = prox * from_axis_angle(kY, deg(60));
    h.filter(0).set_quaternion(palm);
    h.filter(4).set_quaternion(prox);   // index proximal (segment 4)
    h.filter(5).set_quaternion(inter);  // index intermediate (segment 5)
    for (uint8_t i : {2, 3, 6, 7, 8, 9, 10, 11}) h.filter(i).set_quaternion(palm);  // rigid with the palm
    h.filter(1).set_quaternion(conj(kThumbRest) * palm * kThumbRest);  // the thumb too, seen in its own frame
    Quat rel[16];
    h.relative_pose(rel);
    CHECK(same(rel[0], palm));                              // palm: relative to the reference frame
    CHECK(same(rel[4], from_axis_angle(kY, deg(40))));      // proximal relative to the palm
    CHECK(same(rel[5], from_axis_angle(kY, deg(60))));      // intermediate relative to the proximal
    CHECK(same(rel[6], from_axis_angle(kY, deg(60) * 65.0f / 115.0f)));  // eq. 3.3
    CHECK(same(rel[1], kThumbRest));                        // thumb metacarpal moves with the palm
    CHECK(same(rel[7], identity()));
    CHECK(same(rel[9], identity()));                        // straight middle finger: distal straight
}

TEST(distal_interpolation_eq_3_3) {
    Hand h = flat_hand();
    Quat rel[16];
    // fully curled: 115 deg between proximal and intermediate -> 65 deg distal (thesis figure 3.3)
    h.filter(6).set_quaternion(from_axis_angle(kY, deg(10)));                                // middle proximal
    h.filter(7).set_quaternion(from_axis_angle(kY, deg(10)) * from_axis_angle(kY, deg(115)));
    h.relative_pose(rel);
    CHECK_NEAR(twist_angle(rel[9], kY), deg(65), deg(0.01f));
    // hyperextension (negative angle): the distal stays straight
    h.filter(7).set_quaternion(from_axis_angle(kY, deg(-20)));
    h.relative_pose(rel);
    CHECK(same(rel[9], identity()));
    // only the flexion part counts: a sideways component does not bend the tip
    h.filter(7).set_quaternion(from_axis_angle({1, 0, 0}, deg(15)));
    h.relative_pose(rel);
    CHECK(same(rel[9], identity(), 1e-4f));
}

TEST(joint_angles_invert_the_model) {
    // kinematics: relative = REST Rz(abduction) Ry(flexion); hinges flex only
    Quat rel[16];
    const real mcp_flex = deg(50), mcp_abd = deg(-12), pip = deg(80), cmc_flex = deg(20), cmc_abd = deg(30);
    rel[7] = from_axis_angle(kZ, mcp_abd) * from_axis_angle(kY, mcp_flex);  // middle proximal
    rel[8] = from_axis_angle(kY, pip);                                     // middle intermediate
    rel[1] = kThumbRest * from_axis_angle(kZ, cmc_abd) * from_axis_angle(kY, cmc_flex);
    rel[3] = from_axis_angle(kY, deg(-10));                                // thumb IP
    real a[kJoints];
    joint_angles(rel, a);
    const real expect[kJoints] = {cmc_flex, cmc_abd, 0, deg(-10), 0, 0, 0, 0, mcp_flex, mcp_abd, pip, 0};
    for (int j = 0; j < kJoints; ++j) CHECK_NEAR(a[j], expect[j], 1e-5);
}

TEST(sixteen_imus_measure_the_distal_phalanges) {
    uint8_t joint16[16] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14, 6, 9, 12, 15};
    Hand h;
    h.init(HandSettings{}, 16, joint16);
    for (uint8_t i = 0; i < 16; ++i) h.observe(i, kZ);
    h.reset_pose();
    h.filter(5).set_quaternion(from_axis_angle(kY, deg(90)));  // index intermediate bent 90 deg
    h.filter(12).set_quaternion(from_axis_angle(kY, deg(90)));  // index distal IMU: straight relative to it
    Quat rel[16];
    h.relative_pose(rel);
    CHECK(same(rel[6], identity()));  // measured, not interpolated (would be 51 deg)
}

TEST(unmeasured_segment_follows_its_parent) {
    uint8_t joint[2] = {0, 4};  // palm and index proximal only
    Hand h;
    h.init(HandSettings{}, 2, joint);
    h.observe(0, kZ);
    h.observe(1, kZ);
    h.reset_pose();
    h.filter(0).set_quaternion(from_axis_angle(kZ, deg(45)));
    Quat rel[16];
    h.relative_pose(rel);
    CHECK(same(rel[0], from_axis_angle(kZ, deg(45))));
    CHECK(same(rel[1], kThumbRest));                          // no IMU: its reference orientation
    CHECK(same(rel[4], from_axis_angle(kZ, deg(-45))));       // proximal stayed while the palm turned
    CHECK(same(rel[5], identity()));
}

TEST_MAIN()
