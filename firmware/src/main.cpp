// Teensy 4.0 glove firmware: 12 (or 16) MPU9250 behind a TCA9548A, a reset button on pin 5, frames out over
// USB serial (docs/protocol.md). Everything but the hardware access is gc::Glove (lib/glove_core), which the
// host build tests; this file reads sensors, the button and the serial port, and keeps the sensing rate.
#include <Arduino.h>
#include <Wire.h>

#include "glove_config.h"
#include "glove_core.h"
#include "i2c_mux.h"
#include "imu.h"

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

I2cMux mux(Wire, kMuxAddress);
Imu imus[kNumImus];
gc::Glove glove;
gc::Debouncer button;
SerialSink sink;
int16_t raw[kNumImus][7];
uint8_t misses[kNumImus];
uint32_t retry_at_ms[kNumImus];
uint16_t ok_mask = 0;
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

// Read every IMU once. A silent IMU costs at most one failed transaction per kRetryMs: after
// kMissesBeforeFault misses in a row it is reported (ok bit clear, the core sends imu_fault) and skipped.
void read_imus() {
    const uint32_t now_ms = millis();
    for (uint8_t i = 0; i < kNumImus; ++i) {
        const uint16_t bit = static_cast<uint16_t>(1u << i);
        const bool faulted = misses[i] >= kMissesBeforeFault;
        if (faulted && static_cast<int32_t>(now_ms - retry_at_ms[i]) < 0) continue;
        if (imus[i].read(raw[i])) {
            misses[i] = 0;
            ok_mask |= bit;
            continue;
        }
        if (misses[i] < kMissesBeforeFault) ++misses[i];  // a miss or two: the previous sample stands in
        if (misses[i] >= kMissesBeforeFault) {
            ok_mask = static_cast<uint16_t>(ok_mask & ~bit);
            retry_at_ms[i] = now_ms + kRetryMs;
        }
    }
}

// An IMU that lost power comes back asleep and needs its configuration again. begin() blocks (the library
// waits after register writes), so it only runs when the hand is held still anyway: on a recalibration.
void reinit_faulted_imus() {
    for (uint8_t i = 0; i < kNumImus; ++i)
        if (misses[i] >= kMissesBeforeFault && imus[i].begin()) misses[i] = 0;
}

}  // namespace

void setup() {
    GLOVE_SERIAL.begin(kSerialBaud);
    Wire.begin();  // Teensy 4.0: SDA 18, SCL 19
    Wire.setClock(kI2cClockHz);
    pinMode(kButtonPin, INPUT);
    button.init(kDebounceMs, kButtonActiveHigh);
    for (uint8_t i = 0; i < kNumImus; ++i) {
        imus[i].config(&Wire, secondary_address(i), &mux, kMuxMap[i]);
        const bool ok = imus[i].begin();
        misses[i] = ok ? 0 : kMissesBeforeFault;
        if (ok) ok_mask = static_cast<uint16_t>(ok_mask | 1u << i);
    }
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
    if (calibrating && !was_calibrating) reinit_faulted_imus();
    was_calibrating = calibrating;

    const uint32_t now = micros();  // fixed-rate sensing; the output rate is the core's business
    if (static_cast<int32_t>(now - next_sense_us) < 0) return;
    const uint32_t period = 1000000u / glove.sense_rate_hz();
    next_sense_us += period;
    if (static_cast<int32_t>(now - next_sense_us) >= 0) next_sense_us = now + period;  // overran: no burst
    read_imus();
    glove.sense(now, raw, ok_mask);
}
