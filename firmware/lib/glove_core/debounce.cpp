#include "debounce.h"

namespace gc {

void Debouncer::init(uint32_t stable_ms, bool active_high) {
    stable_ms_ = stable_ms;
    active_ = active_high;
    started_ = false;
}

bool Debouncer::update(bool level, uint32_t now_ms) {
    if (!started_) {  // the level at start-up is the idle state, whatever it is: a held button is no press
        started_ = true;
        raw_ = stable_ = level;
        changed_at_ = now_ms;
        return false;
    }
    if (level != raw_) {
        raw_ = level;
        changed_at_ = now_ms;
        return false;
    }
    if (level != stable_ && now_ms - changed_at_ >= stable_ms_) {
        stable_ = level;
        return stable_ == active_;
    }
    return false;
}

}  // namespace gc
