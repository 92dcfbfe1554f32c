// Shared helpers of the host unit tests.
#pragma once

#include <cmath>
#include <cstdint>

#include "quaternion.h"

namespace testing_helpers {

constexpr float kPi = 3.14159265358979f;
inline float deg(float d) { return d * kPi / 180.0f; }

// Angle in radians between two orientations (sign of the quaternion ignored).
inline float angle_between(gc::Quat a, gc::Quat b) {
    const float d = std::fabs(gc::dot(gc::normalized(a), gc::normalized(b)));
    return 2.0f * std::acos(d > 1.0f ? 1.0f : d);
}

// Deterministic uniform noise in [-1, 1] (xorshift32), so tests do not depend on <random>'s implementation.
struct Rng {
    uint32_t s = 2463534242u;
    float next() {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        return static_cast<float>(s) / 2147483648.0f - 1.0f;
    }
    gc::Vec3 vec(float scale) { return {next() * scale, next() * scale, next() * scale}; }
};

}  // namespace testing_helpers
