// Per-axis running median of the last N accelerometer samples (thesis §3.3.2 and §4.2.2: "the size of the
// buffer is 12"). A fixed circular buffer plus a sorted copy per axis, updated in O(N) per sample (one removal,
// one insertion) instead of sorting the window again; no allocation.
#pragma once

#include <cstdint>

#include "quaternion.h"

namespace gc {

class MedianFilter3 {
public:
    static constexpr uint8_t kMaxWindow = 16;

    // window: 1 (no filtering) .. kMaxWindow; out-of-range values are clamped.
    void init(uint8_t window);
    void clear() { count_ = 0; head_ = 0; }
    // Push one sample and return the median of the samples held (fewer than the window until it fills).
    // A sample with a non-finite component is ignored.
    Vec3 update(Vec3 sample);
    // The median of the samples held (the mean of the middle two for an even count); (0, 0, 0) when empty.
    Vec3 value() const;
    uint8_t count() const { return count_; }

private:
    real median(uint8_t axis) const;

    real ring_[3][kMaxWindow];    // samples in arrival order, per axis
    real sorted_[3][kMaxWindow];  // the same samples, ascending, per axis
    uint8_t window_ = 12, count_ = 0, head_ = 0;
};

}  // namespace gc
