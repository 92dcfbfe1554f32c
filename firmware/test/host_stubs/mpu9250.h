// Host stub of the bolderflight MPU9250 library's API (v5, namespace bfs) as firmware/src/imu.cpp uses it.
// Declarations only, see Arduino.h.
#pragma once

#include <stdint.h>

#include "Wire.h"

namespace bfs {

class Mpu9250 {
public:
    enum I2cAddr : uint8_t { I2C_ADDR_PRIM = 0x68, I2C_ADDR_SEC = 0x69 };
    enum DlpfBandwidth : int8_t {
        DLPF_BANDWIDTH_184HZ = 0x01, DLPF_BANDWIDTH_92HZ = 0x02, DLPF_BANDWIDTH_41HZ = 0x03,
        DLPF_BANDWIDTH_20HZ = 0x04, DLPF_BANDWIDTH_10HZ = 0x05, DLPF_BANDWIDTH_5HZ = 0x06
    };
    enum AccelRange : int8_t { ACCEL_RANGE_2G = 0x00, ACCEL_RANGE_4G = 0x08, ACCEL_RANGE_8G = 0x10,
                               ACCEL_RANGE_16G = 0x18 };
    enum GyroRange : int8_t { GYRO_RANGE_250DPS = 0x00, GYRO_RANGE_500DPS = 0x08, GYRO_RANGE_1000DPS = 0x10,
                              GYRO_RANGE_2000DPS = 0x18 };
    Mpu9250() {}
    void Config(TwoWire* i2c, const I2cAddr addr);
    bool Begin();
    bool ConfigAccelRange(const AccelRange range);
    bool ConfigGyroRange(const GyroRange range);
    bool ConfigSrd(const uint8_t srd);
    bool ConfigDlpfBandwidth(const DlpfBandwidth dlpf);
    bool Read();
    bool new_imu_data() const;
    float accel_x_mps2() const;
    float accel_y_mps2() const;
    float accel_z_mps2() const;
    float gyro_x_radps() const;
    float gyro_y_radps() const;
    float gyro_z_radps() const;
    float die_temp_c() const;
};

}  // namespace bfs
