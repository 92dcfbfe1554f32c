// Reset button debounce (thesis §4.1: a click counts once, after the level stayed stable).
#include "check.h"
#include "debounce.h"

using gc::Debouncer;

TEST(bouncy_press_counts_once) {
    Debouncer d;
    d.init(50, true);
    int presses = 0;
    uint32_t t = 0;
    presses += d.update(false, t);
    // contact bounce for 8 ms, then held for 200 ms
    for (int k = 0; k < 8; ++k) presses += d.update(k % 2 == 0, ++t);
    for (int k = 0; k < 200; ++k) presses += d.update(true, ++t);
    CHECK(presses == 1);
    CHECK(d.pressed());
    for (int k = 0; k < 100; ++k) presses += d.update(false, ++t);  // release
    CHECK(!d.pressed());
    for (int k = 0; k < 100; ++k) presses += d.update(true, ++t);   // second press
    CHECK(presses == 2);
}

TEST(press_is_reported_after_the_stable_time) {
    Debouncer d;
    d.init(50, true);
    d.update(false, 1000);
    CHECK(!d.update(true, 1010));
    CHECK(!d.update(true, 1059));
    CHECK(d.update(true, 1060));   // 50 ms stable
    CHECK(!d.update(true, 1200));  // held: no repeat
}

TEST(short_glitch_is_ignored) {
    Debouncer d;
    d.init(50, true);
    d.update(false, 0);
    int presses = 0;
    for (uint32_t t = 1; t < 30; ++t) presses += d.update(true, t);  // 29 ms high
    for (uint32_t t = 30; t < 300; ++t) presses += d.update(false, t);
    CHECK(presses == 0);
}

TEST(held_at_power_up_is_not_a_press) {
    Debouncer d;
    d.init(50, true);
    int presses = 0;
    for (uint32_t t = 0; t < 500; ++t) presses += d.update(true, t);
    CHECK(presses == 0);
}

TEST(active_low_and_millis_wrap) {
    Debouncer d;
    d.init(50, false);  // a button to ground with a pull-up
    uint32_t t = 0xFFFFFFF0u;
    d.update(true, t);
    int presses = 0;
    for (int k = 0; k < 100; ++k) presses += d.update(false, t + static_cast<uint32_t>(k));
    CHECK(presses == 1);
}

TEST_MAIN()
