// Quaternion maths (thesis eq. 3.1, 3.2, 3.6).
#include "check.h"
#include "helpers.h"
#include "quaternion.h"

using namespace gc;
using namespace testing_helpers;

TEST(hamilton_product_follows_eq_3_2) {
    const Quat i{0, 1, 0, 0}, j{0, 0, 1, 0}, k{0, 0, 0, 1};
    const Quat ij = i * j, ji = j * i, kk = k * k;
    CHECK(ij.w == 0 && ij.x == 0 && ij.y == 0 && ij.z == 1);   // ij = k
    CHECK(ji.z == -1);                                         // ji = -k
    CHECK(kk.w == -1 && kk.x == 0 && kk.y == 0 && kk.z == 0);  // k^2 = -1
    const Quat p{0.1f, 0.2f, 0.3f, 0.4f}, q{-0.5f, 0.6f, 0.7f, -0.8f};
    const Quat pq = p * q;  // eq. 3.2 written out
    CHECK_NEAR(pq.w, 0.1 * -0.5 - 0.2 * 0.6 - 0.3 * 0.7 - 0.4 * -0.8, 1e-6);
    CHECK_NEAR(pq.x, 0.1 * 0.6 + 0.2 * -0.5 + 0.3 * -0.8 - 0.4 * 0.7, 1e-6);
    CHECK_NEAR(pq.y, 0.1 * 0.7 - 0.2 * -0.8 + 0.3 * -0.5 + 0.4 * 0.6, 1e-6);
    CHECK_NEAR(pq.z, 0.1 * -0.8 + 0.2 * 0.7 - 0.3 * 0.6 + 0.4 * -0.5, 1e-6);
}

TEST(axis_angle_rotates_vectors_right_handed) {
    const Quat qz = from_axis_angle({0, 0, 1}, deg(90));
    const Vec3 v = rotate(qz, {1, 0, 0});
    CHECK_NEAR(v.x, 0, 1e-6);
    CHECK_NEAR(v.y, 1, 1e-6);
    CHECK_NEAR(v.z, 0, 1e-6);
    const Vec3 w = rotate(from_axis_angle({0, 1, 0}, deg(90)), {1, 0, 0});  // +y turns x towards -z
    CHECK_NEAR(w.z, -1, 1e-6);
    // composition: rotate(p*q, v) == rotate(p, rotate(q, v))
    const Quat p = from_axis_angle({0, 0.6f, 0.8f}, 1.1f), q = from_axis_angle({1, 0, 0}, -0.4f);
    const Vec3 a = rotate(p * q, {0.3f, -0.2f, 0.9f}), b = rotate(p, rotate(q, {0.3f, -0.2f, 0.9f}));
    CHECK_NEAR(a.x, b.x, 1e-6);
    CHECK_NEAR(a.y, b.y, 1e-6);
    CHECK_NEAR(a.z, b.z, 1e-6);
    const Vec3 back = rotate(conj(p), rotate(p, {0.3f, -0.2f, 0.9f}));
    CHECK_NEAR(back.x, 0.3, 1e-6);
}

TEST(from_two_vectors_maps_from_onto_to) {
    Rng rng;
    for (int n = 0; n < 200; ++n) {
        const Vec3 a = rng.vec(2.0f), b = rng.vec(2.0f);
        const Vec3 r = rotate(from_two_vectors(a, b), a * (1.0f / norm(a)));
        const Vec3 bn = b * (1.0f / norm(b));
        CHECK_NEAR(r.x, bn.x, 1e-5);
        CHECK_NEAR(r.y, bn.y, 1e-5);
        CHECK_NEAR(r.z, bn.z, 1e-5);
    }
    const Vec3 r = rotate(from_two_vectors({0, 0, -1}, {0, 0, 1}), {0, 0, -1});  // opposite vectors
    CHECK_NEAR(r.z, 1, 1e-6);
    const Quat same = from_two_vectors({0, 0, 2}, {0, 0, 1});
    CHECK_NEAR(same.w, 1, 1e-7);
}

TEST(roll_pitch_quaternion_is_eq_3_6_zyx) {
    const float roll = 0.4f, pitch = -0.3f;
    const Quat q = from_roll_pitch(roll, pitch);
    const Quat ref = from_axis_angle({0, 1, 0}, pitch) * from_axis_angle({1, 0, 0}, roll);  // Ry(pitch) Rx(roll)
    CHECK(angle_between(q, ref) < 1e-5f);
    CHECK_NEAR(norm(q), 1, 1e-6);
}

TEST(twist_angle_is_signed_rotation_about_axis) {
    const Vec3 y{0, 1, 0};
    CHECK_NEAR(twist_angle(from_axis_angle(y, deg(40)), y), deg(40), 1e-5);
    CHECK_NEAR(twist_angle(from_axis_angle(y, deg(-25)), y), deg(-25), 1e-5);
    CHECK_NEAR(twist_angle(scale(from_axis_angle(y, deg(30)), -1.0f), y), deg(30), 1e-5);  // -q is q
    CHECK_NEAR(twist_angle(from_axis_angle({1, 0, 0}, deg(50)), y), 0, 1e-6);            // pure swing
    const Quat mixed = from_axis_angle({1, 0, 0}, deg(10)) * from_axis_angle(y, deg(60));
    CHECK_NEAR(twist_angle(mixed, y), deg(60), deg(1));
}

TEST(normalized_guards_degenerate_input) {
    const Quat z = normalized(Quat{0, 0, 0, 0});
    CHECK(z.w == 1 && z.x == 0);
    const Quat n = normalized(Quat{NAN, 0, 0, 0});
    CHECK(n.w == 1);
    CHECK_NEAR(norm(normalized(Quat{3, 4, 0, 0})), 1, 1e-7);
}

TEST_MAIN()
