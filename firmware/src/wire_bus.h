// gc::I2cBus on Teensyduino's Wire: the core's IMU driver (lib/glove_core/imu_bus.h, mpu9250.h) does the
// talking, this only puts its transactions on the wire. Wire blocks until each transaction is done.
#pragma once

#include <Wire.h>

#include "i2c.h"

class WireBus final : public gc::I2cBus {
public:
    explicit WireBus(TwoWire& wire) : wire_(wire) {}

    bool write(uint8_t address, const uint8_t* data, size_t n) override {
        wire_.beginTransmission(address);
        wire_.write(data, n);
        return wire_.endTransmission() == 0;
    }

    bool read_registers(uint8_t address, uint8_t reg, uint8_t* out, size_t n) override {
        wire_.beginTransmission(address);
        wire_.write(reg);
        if (wire_.endTransmission(false) != 0) return false;  // repeated START, no STOP
        if (wire_.requestFrom(address, static_cast<uint8_t>(n)) != n) return false;
        for (size_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>(wire_.read());
        return true;
    }

private:
    TwoWire& wire_;
};
