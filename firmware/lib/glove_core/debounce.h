// Software debounce of the reset button (thesis §4.1: no capacitor; a press counts once, when the level after a
// rising edge has stayed stable for a minimum time, 50 ms in the thesis' Button<HIGH> rstBtn(5)).
#pragma once

#include <cstdint>

namespace gc {

class Debouncer {
public:
    // active_high: the pressed level (the thesis' button pulls the pin HIGH).
    void init(uint32_t stable_ms = 50, bool active_high = true);
    // Sample the pin; true exactly once per press, stable_ms after the level became "pressed" and stayed so.
    bool update(bool level, uint32_t now_ms);
    bool pressed() const { return stable_ == active_; }

private:
    uint32_t stable_ms_ = 50, changed_at_ = 0;
    bool active_ = true, raw_ = false, stable_ = false, started_ = false;
};

}  // namespace gc
