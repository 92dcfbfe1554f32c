// One MPU9250 behind the mux, read with the bolderflight library (thesis §4.2.2). The library rotates its
// outputs into its own z-down frame and scales them to SI units; read() undoes that, so the core and raw frames
// see the chip's register values in the chip's own axes (docs/protocol.md, raw frame).
#pragma once

#include <stdint.h>

#include "i2c_mux.h"
#include "mpu9250.h"

class Imu {
public:
    void config(TwoWire* bus, bool secondary_address, I2cMux* mux, uint8_t channel);
    // Configure +-16 g, +-2000 dps, 184 Hz DLPF, 1 kHz internal rate. Blocks for a while (the library waits
    // after each register write): call it from setup() or a recalibration, never every cycle.
    bool begin();
    // One sample as register counts: ax, ay, az, gx, gy, gz, temp. False when the IMU did not answer or had no
    // new sample (the caller decides when misses become a fault).
    bool read(int16_t row[7]);

private:
    bfs::Mpu9250 dev_;
    I2cMux* mux_ = nullptr;
    uint8_t channel_ = 0;
};
