// The I2C bus as the IMU driver uses it (firmware/src/wire_bus.h on the Teensy, an I2C bus model in the host
// tests), and what its transactions cost on the wire: bits at the configured clock plus the START, repeated
// START, STOP and bus-free times of the I2C specification (NXP UM10204, table 10) for the clock's mode.
#pragma once

#include <cstddef>
#include <cstdint>

namespace gc {

class I2cBus {
public:
    // START, address+W, the bytes, STOP. False when a byte was not acknowledged.
    virtual bool write(uint8_t address, const uint8_t* data, size_t n) = 0;
    // START, address+W, register, repeated START, address+R, n bytes read (the last one NACKed), STOP.
    virtual bool read_registers(uint8_t address, uint8_t reg, uint8_t* out, size_t n) = 0;

protected:
    ~I2cBus() = default;
};

struct I2cTiming {
    uint32_t clock_hz = 400000;
    // the specification's minima, in microseconds: fast mode (<= 400 kHz) or fast-mode plus (<= 1 MHz)
    double start_us() const { return clock_hz > 400000 ? 0.26 : 0.6; }           // tHD;STA
    double restart_us() const { return clock_hz > 400000 ? 0.52 : 1.2; }         // tSU;STA + tHD;STA
    double stop_us() const { return clock_hz > 400000 ? 0.26 + 0.5 : 0.6 + 1.3; }  // tSU;STO + tBUF
    double bits_us(size_t bits) const { return static_cast<double>(bits) * 1e6 / clock_hz; }
    // a write of n bytes: 9 clocks per byte (8 data + acknowledge), the address byte included
    double write_us(size_t n) const { return start_us() + bits_us(9 * (1 + n)) + stop_us(); }
    // a register read of n bytes: address+W, register, repeated START, address+R, n bytes
    double read_registers_us(size_t n) const {
        return start_us() + bits_us(9 * 2) + restart_us() + bits_us(9 * (1 + n)) + stop_us();
    }
};

}  // namespace gc
