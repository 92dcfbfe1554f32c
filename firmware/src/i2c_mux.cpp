#include "i2c_mux.h"

bool I2cMux::select(uint8_t channel) {
    if (channel > 7) return false;
    if (current_ == channel) return true;  // thesis §4.2.3: skip the transmission when already there
    bus_.beginTransmission(address_);
    bus_.write(static_cast<uint8_t>(1u << channel));
    const bool ok = bus_.endTransmission() == 0;
    current_ = ok ? channel : kNone;
    return ok;
}
