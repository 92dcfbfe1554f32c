// A tiny test harness for the host unit tests (no downloads, no GoogleTest): TEST(name) { CHECK(...); } and
// TEST_MAIN() at the end of each file. Exits non-zero when any check failed.
#pragma once

#include <cmath>
#include <cstdio>

namespace check {

struct Case {
    const char* name;
    void (*fn)();
    Case* next;
};
inline Case*& head() {
    static Case* h = nullptr;
    return h;
}
inline int& failures() {
    static int f = 0;
    return f;
}
struct Reg {
    Case c;
    Reg(const char* n, void (*f)()) : c{n, f, nullptr} {
        Case** p = &head();
        while (*p) p = &(*p)->next;  // keep file order
        *p = &c;
    }
};
inline int run_all(const char* file) {
    int passed = 0, failed = 0;
    for (Case* c = head(); c; c = c->next) {
        const int before = failures();
        c->fn();
        const bool ok = failures() == before;
        std::printf("%-50s %s\n", c->name, ok ? "ok" : "FAILED");
        (ok ? passed : failed)++;
    }
    std::printf("%s: %d passed, %d failed\n", file, passed, failed);
    return failed ? 1 : 0;
}

}  // namespace check

#define TEST(name)                                           \
    static void name();                                      \
    static check::Reg name##_reg_(#name, name);              \
    static void name()

#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            ++check::failures();                                                     \
            std::printf("  %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);   \
        }                                                                            \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                                         \
    do {                                                                                              \
        const double a_ = (a), b_ = (b);                                                              \
        if (!(std::fabs(a_ - b_) <= (tol))) {                                                         \
            ++check::failures();                                                                      \
            std::printf("  %s:%d: %s = %.9g, %s = %.9g, differ by more than %g\n", __FILE__, __LINE__, \
                        #a, a_, #b, b_, static_cast<double>(tol));                                    \
        }                                                                                             \
    } while (0)

#define TEST_MAIN() \
    int main() { return check::run_all(__FILE__); }
