// The MPU9250's accelerometer, gyroscope and temperature over I2C (InvenSense MPU-9250 register map, rev 1.6),
// the glove's own driver: configure once, then one 14-byte burst read per sample (ACCEL_XOUT_H .. GYRO_ZOUT_L),
// the least the chip allows for a 6-axis sample. The magnetometer is not used. Works for the MPU9255 and the
// MPU6500 too (same registers; WHO_AM_I 0x73, 0x70).
#pragma once

#include <cstdint>

#include "i2c.h"

namespace gc {
namespace mpu9250 {

constexpr uint8_t kAddressLow = 0x68, kAddressHigh = 0x69;  // AD0 low, high
constexpr uint8_t kSmplrtDiv = 0x19, kConfig = 0x1A, kGyroConfig = 0x1B, kAccelConfig = 0x1C,
                  kAccelConfig2 = 0x1D, kAccelXoutH = 0x3B, kPwrMgmt1 = 0x6B, kPwrMgmt2 = 0x6C, kWhoAmI = 0x75;
constexpr uint8_t kBurstBytes = 14;  // ax ay az temp gx gy gz, big-endian 16-bit

// The glove's settings (thesis §4.2.2): +-16 g, +-2000 dps, 184 Hz low-pass on both, 1 kHz internal rate,
// awake on the gyro's PLL. Register, value: written in this order.
constexpr uint8_t kSettings[][2] = {
    {kPwrMgmt1, 0x01},      // wake up, clock from the gyro PLL
    {kPwrMgmt2, 0x00},      // every axis on
    {kConfig, 0x01},        // DLPF_CFG 1: gyro and temperature 184 Hz, 1 kHz
    {kGyroConfig, 0x18},    // FS_SEL 3: +-2000 dps, DLPF used
    {kAccelConfig, 0x18},   // ACCEL_FS_SEL 3: +-16 g
    {kAccelConfig2, 0x01},  // A_DLPFCFG 1: 184 Hz
    {kSmplrtDiv, 0x00},     // 1 kHz
};

// True when the chip answers as an MPU9250/9255/6500 and holds the settings after writing them (read back).
bool configure(I2cBus& bus, uint8_t address);
// One sample as register counts in the chip's own axes: ax, ay, az, gx, gy, gz, temp (the row of
// gc::Glove::sense and of the raw frame). False when the chip did not answer.
bool read(I2cBus& bus, uint8_t address, int16_t row[7]);
// The 14 burst bytes as that row.
void decode(const uint8_t burst[kBurstBytes], int16_t row[7]);

}  // namespace mpu9250
}  // namespace gc
