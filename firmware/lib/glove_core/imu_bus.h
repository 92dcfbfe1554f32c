// The glove's IMUs on one I2C bus behind a TCA9548A multiplexer (thesis §4.2.3, table 4.1): which IMU sits on
// which channel and address, one sensing cycle that reads them all, and what a cycle costs on the wire.
//
// A cycle switches the mux once per channel and reads both IMUs behind it (AD0 high, then low) with one
// 14-byte burst each: the fewest bytes the wiring allows. There are no data-ready lines in the thesis' wiring,
// so each read takes the chip's newest sample (it samples at 1 kHz behind a 184 Hz low-pass: at most 1 ms
// old); a FIFO-count read would add ~0.11 ms per IMU, 1.3 ms a cycle, for no gain at this rate.
//
// An IMU that misses kMissesBeforeFault reads in a row is faulted (its ok bit clear: the core sends
// imu_fault) and then costs one read attempt every kRetryMs until it answers again.
#pragma once

#include <cstdint>

#include "i2c.h"
#include "hand.h"  // kMaxImus

namespace gc {

class ImuBus {
public:
    static constexpr uint8_t kMuxAddress = 0x70;  // TCA9548A, A0-A2 low
    static constexpr uint8_t kMissesBeforeFault = 3;
    static constexpr uint32_t kRetryMs = 100;

    // IMU i on mux channel channel[i], at the MPU9250's AD0-high address when high_address[i].
    void init(I2cBus* bus, uint8_t n_imu, const uint8_t* channel, const bool* high_address);
    // Configure every IMU; the ones that do not answer start faulted. Returns the mask of those that did.
    uint16_t begin();
    // Configure the faulted IMUs again (one that lost power comes back asleep): on a recalibration, when the
    // hand is held still anyway.
    void reinit_faulted();
    // One sensing cycle at time now_ms: raw[i] = (ax, ay, az, gx, gy, gz, temp) counts of IMU i. A missed read
    // leaves raw[i] as it was (the previous sample stands in until the IMU is faulted). Returns the ok mask.
    uint16_t read_all(uint32_t now_ms, int16_t (*raw)[7]);

    uint16_t ok_mask() const { return ok_mask_; }
    // The bus time of one cycle (in the steady state, every IMU answering), from the transactions read_all
    // issues: a mux write per change of channel, a 14-byte register read per IMU.
    double cycle_us(const I2cTiming& timing) const;

private:
    bool select(uint8_t channel);

    static constexpr uint8_t kNone = 0xFF;
    I2cBus* bus_ = nullptr;
    uint8_t n_ = 0;
    uint8_t channel_[kMaxImus] = {};
    uint8_t address_[kMaxImus] = {};
    uint8_t misses_[kMaxImus] = {};
    uint32_t retry_at_ms_[kMaxImus] = {};
    uint16_t ok_mask_ = 0;
    uint8_t selected_ = kNone;
};

}  // namespace gc
