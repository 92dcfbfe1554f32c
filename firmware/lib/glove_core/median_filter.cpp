#include "median_filter.h"

#include <cmath>

namespace gc {
namespace {

// s[0..n-1] is ascending. With `remove`, take `out` out first (it is in s), then insert `in`: s stays sorted.
void replace_sorted(real* s, uint8_t n, bool remove, real out, real in) {
    uint8_t free_slot = n;
    if (remove) {
        uint8_t j = 0;
        while (j + 1 < n && !(s[j] == out)) ++j;
        for (; j + 1 < n; ++j) s[j] = s[j + 1];
        free_slot = static_cast<uint8_t>(n - 1);
    }
    uint8_t i = free_slot;
    for (; i > 0 && s[i - 1] > in; --i) s[i] = s[i - 1];
    s[i] = in;
}

}  // namespace

void MedianFilter3::init(uint8_t window) {
    window_ = window < 1 ? 1 : (window > kMaxWindow ? kMaxWindow : window);
    clear();
}

Vec3 MedianFilter3::update(Vec3 sample) {
    const real v[3] = {sample.x, sample.y, sample.z};
    if (!std::isfinite(v[0] + v[1] + v[2])) return value();  // a NaN would poison the sorted window
    const bool full = count_ == window_;
    for (uint8_t a = 0; a < 3; ++a) {
        replace_sorted(sorted_[a], count_, full, ring_[a][head_], v[a]);
        ring_[a][head_] = v[a];
    }
    head_ = static_cast<uint8_t>((head_ + 1) % window_);
    if (!full) ++count_;
    return value();
}

real MedianFilter3::median(uint8_t a) const {
    const real* s = sorted_[a];
    return (count_ & 1u) ? s[count_ / 2] : (s[count_ / 2 - 1] + s[count_ / 2]) / 2;
}

Vec3 MedianFilter3::value() const {
    if (count_ == 0) return {};
    return {median(0), median(1), median(2)};
}

}  // namespace gc
