// MPU9250 register values <-> units (docs/protocol.md, raw frame). The core fuses exactly what a raw frame
// carries, real(counts) * scale, so a host can re-fuse raw frames and reproduce the glove's filter input:
//   accel_g = counts * (fs_g / 32768),  gyro_rad_s = counts * (fs_dps * (pi / 180 / 32768)).
#pragma once

#include <cmath>
#include <cstdint>

#include "quaternion.h"

namespace gc {

constexpr real kDegToRad = real(0.017453292519943295);
constexpr real kTempSensitivity = real(333.87);  // LSB per degC; degC = counts / 333.87 + 21
constexpr real kTempOffsetC = 21;

inline real accel_scale(uint8_t fs_g) { return static_cast<real>(fs_g) / 32768; }
inline real gyro_scale(uint16_t fs_dps) { return static_cast<real>(fs_dps) * (kDegToRad / 32768); }

// row: (ax, ay, az, gx, gy, gz, temp) counts
inline Vec3 accel_g(const int16_t* row, uint8_t fs_g) {
    const real s = accel_scale(fs_g);
    return {row[0] * s, row[1] * s, row[2] * s};
}
inline Vec3 gyro_rad_s(const int16_t* row, uint16_t fs_dps) {
    const real s = gyro_scale(fs_dps);
    return {row[3] * s, row[4] * s, row[5] * s};
}

// Nearest register value (ties away from zero), saturated; NaN gives 0. Computed in double.
inline int16_t to_counts(double v) {
    if (!(v == v)) return 0;
    const double r = std::round(v);
    return static_cast<int16_t>(r > 32767.0 ? 32767.0 : (r < -32768.0 ? -32768.0 : r));
}
inline int16_t counts_from_g(double g, uint8_t fs_g) { return to_counts(g * 32768.0 / fs_g); }
inline int16_t counts_from_rad_s(double w, uint16_t fs_dps) {
    return to_counts(w * (32768.0 / fs_dps) * (180.0 / 3.14159265358979323846));
}
inline int16_t counts_from_celsius(double c) { return to_counts((c - 21.0) * 333.87); }

}  // namespace gc
