// Host stub of the few Arduino/Teensyduino declarations firmware/src uses. Declarations only: the
// arduino_layer_check target compiles src/*.cpp against it (no link), to catch type and API slips without a
// Teensy toolchain. Not a simulator; the behaviour is tested in lib/glove_core.
#pragma once

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define HIGH 0x1
#define LOW 0x0
#define INPUT 0x0
#define OUTPUT 0x1

uint32_t micros();
uint32_t millis();
void delay(uint32_t ms);
void pinMode(uint8_t pin, uint8_t mode);
int digitalRead(uint8_t pin);

class usb_serial_class {
public:
    void begin(uint32_t baud);
    int available();
    int read();
    int availableForWrite();
    size_t write(const uint8_t* data, size_t len);
};
extern usb_serial_class Serial;

class HardwareSerial {
public:
    void begin(uint32_t baud);
    int available();
    int read();
    int availableForWrite();
    size_t write(const uint8_t* data, size_t len);
};
extern HardwareSerial Serial1;
