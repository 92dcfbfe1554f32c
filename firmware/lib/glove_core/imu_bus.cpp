#include "imu_bus.h"

#include "mpu9250.h"

namespace gc {

void ImuBus::init(I2cBus* bus, uint8_t n_imu, const uint8_t* channel, const bool* high_address) {
    bus_ = bus;
    n_ = n_imu > kMaxImus ? kMaxImus : n_imu;
    for (uint8_t i = 0; i < n_; ++i) {
        channel_[i] = channel[i];
        address_[i] = high_address[i] ? mpu9250::kAddressHigh : mpu9250::kAddressLow;
        misses_[i] = 0;
        retry_at_ms_[i] = 0;
    }
    ok_mask_ = 0;
    selected_ = kNone;
}

// The TCA9548A keeps its channel: a write only when it changes (thesis §4.2.3). After a failed write the
// channel is unknown, so the next call writes it again.
bool ImuBus::select(uint8_t channel) {
    if (channel > 7) return false;
    if (selected_ == channel) return true;
    const uint8_t mask = static_cast<uint8_t>(1u << channel);
    const bool ok = bus_->write(kMuxAddress, &mask, 1);
    selected_ = ok ? channel : kNone;
    return ok;
}

uint16_t ImuBus::begin() {
    ok_mask_ = 0;
    for (uint8_t i = 0; i < n_; ++i) {
        const bool ok = select(channel_[i]) && mpu9250::configure(*bus_, address_[i]);
        misses_[i] = ok ? 0 : kMissesBeforeFault;
        if (ok) ok_mask_ = static_cast<uint16_t>(ok_mask_ | 1u << i);
    }
    return ok_mask_;
}

void ImuBus::reinit_faulted() {
    for (uint8_t i = 0; i < n_; ++i)
        if (misses_[i] >= kMissesBeforeFault && select(channel_[i]) && mpu9250::configure(*bus_, address_[i]))
            misses_[i] = 0;
}

uint16_t ImuBus::read_all(uint32_t now_ms, int16_t (*raw)[7]) {
    for (uint8_t i = 0; i < n_; ++i) {
        const uint16_t bit = static_cast<uint16_t>(1u << i);
        if (misses_[i] >= kMissesBeforeFault && static_cast<int32_t>(now_ms - retry_at_ms_[i]) < 0) continue;
        if (select(channel_[i]) && mpu9250::read(*bus_, address_[i], raw[i])) {
            misses_[i] = 0;
            ok_mask_ = static_cast<uint16_t>(ok_mask_ | bit);
            continue;
        }
        if (misses_[i] < kMissesBeforeFault) ++misses_[i];  // a miss or two: the previous sample stands in
        if (misses_[i] >= kMissesBeforeFault) {
            ok_mask_ = static_cast<uint16_t>(ok_mask_ & ~bit);
            retry_at_ms_[i] = now_ms + kRetryMs;
        }
    }
    return ok_mask_;
}

double ImuBus::cycle_us(const I2cTiming& timing) const {
    double us = 0;
    for (uint8_t i = 0; i < n_; ++i) {
        const uint8_t before = channel_[i ? i - 1 : n_ - 1];  // cycle after cycle: the last channel stays selected
        if (channel_[i] != before) us += timing.write_us(1);
        us += timing.read_registers_us(mpu9250::kBurstBytes);
    }
    return us;
}

}  // namespace gc
