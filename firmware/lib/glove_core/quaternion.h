// Small vector and quaternion maths for the glove core (thesis §3.2, eq. 3.1-3.2).
//
// Convention: Hamilton quaternions q = (w, x, y, z). A segment's orientation q maps vectors from the sensor
// (body) frame into the global frame: v_G = q v_L q*. Header-only, no allocation, no Eigen.
//
// Scalar type: double by default, as the thesis' Eigen code (Vector3d); the Teensy 4.0's Cortex-M7 has a
// double-precision FPU. -DGLOVE_CORE_FLOAT builds the core in float (tested as well; it drifts ~1e-5 from a
// double reference over 10 s at 1 kHz, double stays ~1e-12 away).
#pragma once

#include <cmath>

namespace gc {

#ifdef GLOVE_CORE_FLOAT
using real = float;
#else
using real = double;
#endif

struct Vec3 {
    real x = 0, y = 0, z = 0;
};

// sin, cos and atan2 evaluated in double and rounded to real. In a float build the M7 (newlib) and the host
// (glibc) differ in the last bit of sinf and atan2f (ctest m7_matches_host_f32 saw it in the JSON mode's distal
// phalanges); their double versions agree far below a float's last bit, so the rounded results agree.
inline real sin_d(real x) { return static_cast<real>(std::sin(static_cast<double>(x))); }
inline real cos_d(real x) { return static_cast<real>(std::cos(static_cast<double>(x))); }
inline real atan2_d(real y, real x) {
    return static_cast<real>(std::atan2(static_cast<double>(y), static_cast<double>(x)));
}

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, real s) { return {a.x * s, a.y * s, a.z * s}; }
inline real dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline real norm(Vec3 a) { return std::sqrt(dot(a, a)); }

struct Quat {
    real w = 1, x = 0, y = 0, z = 0;
};

inline Quat identity() { return {1, 0, 0, 0}; }
inline Quat conj(Quat q) { return {q.w, -q.x, -q.y, -q.z}; }
inline real dot(Quat a, Quat b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }
inline real norm(Quat q) { return std::sqrt(dot(q, q)); }
inline Quat scale(Quat q, real s) { return {q.w * s, q.x * s, q.y * s, q.z * s}; }

// Unit quaternion in the direction of q; identity for a zero or non-finite q.
inline Quat normalized(Quat q) {
    const real n = norm(q);
    if (!(n > real(1e-12)) || !std::isfinite(n)) return identity();
    return scale(q, 1 / n);
}

// Eq. 3.2: the Hamilton product pq (apply q, then p).
inline Quat operator*(Quat p, Quat q) {
    return {p.w * q.w - p.x * q.x - p.y * q.y - p.z * q.z,
            p.w * q.x + p.x * q.w + p.y * q.z - p.z * q.y,
            p.w * q.y - p.x * q.z + p.y * q.w + p.z * q.x,
            p.w * q.z + p.x * q.y - p.y * q.x + p.z * q.w};
}

// v rotated by the unit quaternion q: q v q*.
inline Vec3 rotate(Quat q, Vec3 v) {
    const Vec3 u{q.x, q.y, q.z};
    const Vec3 t = cross(u, v) * 2;
    return v + t * q.w + cross(u, t);
}

// Eq. 3.1: rotation by `angle` radians about the unit `axis`.
inline Quat from_axis_angle(Vec3 axis, real angle) {
    const real s = sin_d(angle / 2);
    return {cos_d(angle / 2), axis.x * s, axis.y * s, axis.z * s};
}

// Shortest-arc unit quaternion rotating the direction of `from` onto the direction of `to` (Eigen's
// FromTwoVectors, used by the thesis for eq. 3.13). Opposite vectors: a half turn about an axis normal to `from`.
inline Quat from_two_vectors(Vec3 from, Vec3 to) {
    const real nf = norm(from), nt = norm(to);
    if (!(nf > 0) || !(nt > 0)) return identity();
    const Vec3 a = from * (1 / nf), b = to * (1 / nt);
    const real c = dot(a, b);
    if (c < real(-0.999999)) {
        Vec3 axis = cross(a, Vec3{1, 0, 0});
        if (norm(axis) < real(1e-3)) axis = cross(a, Vec3{0, 1, 0});
        axis = axis * (1 / norm(axis));
        return {0, axis.x, axis.y, axis.z};
    }
    const Vec3 v = cross(a, b);
    return normalized(Quat{1 + c, v.x, v.y, v.z});
}

// Eq. 3.6 with yaw psi = 0 (Tait-Bryan ZYX): roll about x, then pitch about y.
inline Quat from_roll_pitch(real roll, real pitch) {
    const real cr = cos_d(roll / 2), sr = sin_d(roll / 2);
    const real cp = cos_d(pitch / 2), sp = sin_d(pitch / 2);
    return {cr * cp, sr * cp, cr * sp, -sr * sp};
}

// Signed angle of q's rotation about the unit `axis` (the twist of a swing-twist decomposition), in [-pi, pi].
inline real twist_angle(Quat q, Vec3 axis) {
    real p = q.x * axis.x + q.y * axis.y + q.z * axis.z;
    real w = q.w;
    if (w < 0) {
        w = -w;
        p = -p;
    }
    return 2 * atan2_d(p, w);
}

}  // namespace gc
