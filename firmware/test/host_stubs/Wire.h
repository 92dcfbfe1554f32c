// Host stub of Teensyduino's Wire (declarations only, see Arduino.h).
#pragma once

#include <stddef.h>
#include <stdint.h>

class TwoWire {
public:
    void begin();
    void setClock(uint32_t hz);
    void beginTransmission(uint8_t address);
    size_t write(uint8_t data);
    size_t write(const uint8_t* data, size_t quantity);
    uint8_t endTransmission(uint8_t sendStop);
    uint8_t endTransmission();
    uint8_t requestFrom(uint8_t address, uint8_t quantity);
    int read();
};
extern TwoWire Wire;
