// Teensy 4.0 glove firmware: 12 (or 16) MPU9250 behind a TCA9548A, a reset button on pin 5, frames out over
// USB serial (docs/protocol.md). Everything but the hardware access is the core (lib/glove_core: gc::Glove, the
// IMU driver gc::ImuBus), which the host and M7 builds test; this file wires the core to Wire, the button pin
// and the serial port, and keeps the sensing rate.
#include <Arduino.h>
#include <Wire.h>

#include "glove_config.h"
#include "glove_core.h"
#include "wire_bus.h"

namespace {

using namespace glove_config;

// Frames go out only when they fit in the serial buffer: a host that stops reading costs frames (the sequence
// numbers show the gap), never a blocked loop.
struct SerialSink final : gc::FrameSink {
    bool write(const uint8_t* data, size_t len) override {
        if (GLOVE_SERIAL.availableForWrite() < static_cast<int>(len)) return false;
        return GLOVE_SERIAL.write(data, len) == len;
    }
};

WireBus bus(Wire);
gc::ImuBus imus;
gc::Glove glove;
gc::Debouncer button;
SerialSink sink;
int16_t raw[kNumImus][7];
uint32_t next_sense_us = 0;
bool was_calibrating = false;

uint32_t glove_id() {
#if defined(__IMXRT1062__)
    return HW_OCOTP_MAC0;  // unique per chip (the Teensy's MAC / serial number source)
#else
    return 0;
#endif
}

gc::GloveSettings settings() {
    gc::GloveSettings s;
    s.n_imu = kNumImus;
    for (uint8_t i = 0; i < kNumImus; ++i) {
        s.mux_map[i] = kMuxMap[i];
        s.joint_map[i] = kJointMap[i];
    }
    s.sense_rate_hz = kSenseRateHz;
    s.output_rate_hz = kOutputRateHz;
    s.mode = static_cast<gc::Mode>(kMode);
    for (uint8_t k = 0; k < 3; ++k) s.firmware[k] = kFirmware[k];
    s.glove_id = glove_id();
    return s;
}

}  // namespace

void setup() {
    GLOVE_SERIAL.begin(kSerialBaud);
    Wire.begin();  // Teensy 4.0: SDA 18, SCL 19
    Wire.setClock(kI2cClockHz);
    pinMode(kButtonPin, INPUT);
    button.init(kDebounceMs, kButtonActiveHigh);
    bool high[kNumImus];
    for (uint8_t i = 0; i < kNumImus; ++i) high[i] = secondary_address(i);
    imus.init(&bus, kNumImus, kMuxMap, high);
    imus.begin();
    glove.init(settings(), &sink);
    glove.begin(micros());  // boot event, status, then the gyro calibration (thesis figure 4.5)
    next_sense_us = micros();
}

void loop() {
    while (GLOVE_SERIAL.available() > 0) {  // host commands (mode, rate, recalibrate, reset pose, status)
        const uint8_t b = static_cast<uint8_t>(GLOVE_SERIAL.read());
        glove.receive(&b, 1, micros());
    }
    if (button.update(digitalRead(kButtonPin) == HIGH, millis())) glove.button(micros());

    const bool calibrating = glove.calibration().running();
    if (calibrating && !was_calibrating) imus.reinit_faulted();  // an IMU that lost power: configure it again
    was_calibrating = calibrating;

    const uint32_t now = micros();  // fixed-rate sensing; the output rate is the core's business
    if (static_cast<int32_t>(now - next_sense_us) < 0) return;
    const uint32_t period = 1000000u / glove.sense_rate_hz();
    next_sense_us += period;
    if (static_cast<int32_t>(now - next_sense_us) >= 0) next_sense_us = now + period;  // overran: no burst
    const uint16_t ok_mask = imus.read_all(millis(), raw);
    glove.sense(now, raw, ok_mask);
}
