// TCA9548A I2C multiplexer (thesis §4.2.3): selects one of 8 downstream buses and remembers which one, so a
// read of the second IMU of a pair costs no mux transaction.
#pragma once

#include <Wire.h>
#include <stdint.h>

class I2cMux {
public:
    I2cMux(TwoWire& bus, uint8_t address) : bus_(bus), address_(address) {}
    // True when `channel` is selected. On a bus error the remembered channel is forgotten, so the next call
    // writes the register again instead of trusting a state the mux may not be in.
    bool select(uint8_t channel);
    void forget() { current_ = kNone; }

private:
    static constexpr uint8_t kNone = 0xFF;
    TwoWire& bus_;
    uint8_t address_;
    uint8_t current_ = kNone;
};
