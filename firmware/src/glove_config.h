// Build-time configuration of the glove (thesis §4.1-4.2, table 4.1). The portable behaviour lives in
// lib/glove_core; this file only says how the hardware is wired.
#pragma once

#include <stdint.h>

#ifndef GLOVE_N_IMU
#define GLOVE_N_IMU 12  // 12 as the thesis; 16 adds the four finger distal phalanges on mux channels 6 and 7
#endif
#ifndef GLOVE_SERIAL
#define GLOVE_SERIAL Serial  // USB serial; Serial1 for a true UART on pins 0/1
#endif
#ifndef GLOVE_MODE
#define GLOVE_MODE 1  // output at boot: 0 raw, 1 pose, 2 json, 3 compact (52-byte frames: the UART build's)
#endif

namespace glove_config {

constexpr uint8_t kNumImus = GLOVE_N_IMU;
constexpr uint8_t kButtonPin = 5;           // button to 3.3 V, 10 kOhm from the pin to GND (figure 4.1)
constexpr bool kButtonActiveHigh = true;    // pressed reads HIGH (Button<HIGH>); false for a button to GND
constexpr uint32_t kDebounceMs = 50;        // thesis: Button<HIGH> rstBtn(5), 50 ms
constexpr uint32_t kI2cClockHz = 400000;    // MPU9250 I2C fast mode (the datasheet's maximum)
constexpr uint32_t kSerialBaud = 115200;    // ignored by USB serial; the line rate of Serial1
// Sensing as fast as the bus allows, with room for the core and Wire's own time in each period (README,
// test/host/test_imu_bus.cpp): 12 burst reads of 14 bytes and 6 mux switches at 400 kHz take 4.92 ms (at most
// 203 cycles a second), 16 reads and 8 switches 6.56 ms (152 a second).
constexpr uint16_t sense_rate_hz(uint8_t n_imu) { return n_imu > 12 ? 140 : 190; }
constexpr uint16_t kSenseRateHz = sense_rate_hz(kNumImus);
constexpr uint16_t kOutputRateHz = 50;
constexpr uint8_t kMode = GLOVE_MODE;       // the host's set_mode changes it
constexpr uint8_t kFirmware[3] = {1, 0, 0};

#if GLOVE_N_IMU == 12
// Table 4.1: IMU i on mux channel kMuxMap[i], strapped to hand segment kJointMap[i].
constexpr uint8_t kMuxMap[kNumImus] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5};
constexpr uint8_t kJointMap[kNumImus] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14};
#elif GLOVE_N_IMU == 16
// The two spare channels carry the finger distal phalanges (segments 6, 9, 12, 15): no interpolation needed.
constexpr uint8_t kMuxMap[kNumImus] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
constexpr uint8_t kJointMap[kNumImus] = {0, 1, 2, 3, 4, 5, 7, 8, 10, 11, 13, 14, 6, 9, 12, 15};
#else
#error "GLOVE_N_IMU must be 12 or 16"
#endif

// Table 4.1: the first IMU of each pair has its AD0 pin high (SECONDARY address), the second low (PRIMARY).
constexpr bool secondary_address(uint8_t imu) { return imu % 2 == 0; }

}  // namespace glove_config
