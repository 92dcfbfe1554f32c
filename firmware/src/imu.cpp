#include "imu.h"

#include <math.h>

namespace {

constexpr float kG = 9.80665f;              // the library's g (m/s^2 per g)
constexpr float kAccelLsbPerG = 32768.0f / 16.0f;
constexpr float kGyroLsbPerRad = 32768.0f / 2000.0f * 57.29577951308232f;
constexpr float kTempLsbPerC = 333.87f;

int16_t counts(float v) {
    const float r = roundf(v);
    return static_cast<int16_t>(r > 32767.0f ? 32767.0f : (r < -32768.0f ? -32768.0f : r));
}

}  // namespace

void Imu::config(TwoWire* bus, bool secondary_address, I2cMux* mux, uint8_t channel) {
    dev_.Config(bus, secondary_address ? bfs::Mpu9250::I2C_ADDR_SEC : bfs::Mpu9250::I2C_ADDR_PRIM);
    mux_ = mux;
    channel_ = channel;
}

bool Imu::begin() {
    if (!mux_->select(channel_)) return false;
    return dev_.Begin() && dev_.ConfigAccelRange(bfs::Mpu9250::ACCEL_RANGE_16G) &&
           dev_.ConfigGyroRange(bfs::Mpu9250::GYRO_RANGE_2000DPS) &&
           dev_.ConfigDlpfBandwidth(bfs::Mpu9250::DLPF_BANDWIDTH_184HZ) && dev_.ConfigSrd(0);
}

bool Imu::read(int16_t row[7]) {
    if (!mux_->select(channel_)) {
        mux_->forget();
        return false;
    }
    if (!dev_.Read()) return false;
    // The library returns (y, x, -z) of the chip's axes in m/s^2 and rad/s: back to register counts.
    row[0] = counts(dev_.accel_y_mps2() / kG * kAccelLsbPerG);
    row[1] = counts(dev_.accel_x_mps2() / kG * kAccelLsbPerG);
    row[2] = counts(-dev_.accel_z_mps2() / kG * kAccelLsbPerG);
    row[3] = counts(dev_.gyro_y_radps() * kGyroLsbPerRad);
    row[4] = counts(dev_.gyro_x_radps() * kGyroLsbPerRad);
    row[5] = counts(-dev_.gyro_z_radps() * kGyroLsbPerRad);
    row[6] = counts((dev_.die_temp_c() - 21.0f) * kTempLsbPerC + 21.0f);  // the library's formula inverted
    return true;
}
