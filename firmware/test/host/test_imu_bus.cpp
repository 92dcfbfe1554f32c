// The glove's IMU driver (gc::ImuBus, gc::mpu9250) against an I2C bus model: a TCA9548A and MPU9250 register
// files behind it, answering only on the selected channel, and a clock that counts the time of every
// transaction on the wire from its bits and its START/STOP conditions. No board here: the model stands in
// for the bus, and the budget the driver states must be what it actually spends on it.
#include <cstring>
#include <initializer_list>

#include "../../src/glove_config.h"
#include "check.h"
#include "imu_bus.h"
#include "mpu9250.h"

using namespace gc;

namespace {

// An I2C bus at clock_hz with a TCA9548A at 0x70 and up to two MPU9250 per channel (AD0 low, high).
struct BusModel final : I2cBus {
    struct Chip {
        bool present = false;
        uint8_t reg[128] = {};
        int accesses = 0;
    };
    Chip chip[8][2];
    uint8_t mux = 0;  // TCA9548A control register: bit c connects channel c
    uint32_t clock_hz = 400000;
    double time_us = 0;
    int mux_writes = 0, transactions = 0;

    // UM10204 fast mode, as the bus sees it (written here, apart from gc::I2cTiming, on purpose)
    void spend(int clocks, int restarts) {
        time_us += 0.6 + clocks * 1e6 / clock_hz + restarts * (0.6 + 0.6) + 0.6 + 1.3;
        ++transactions;
    }
    Chip* find(uint8_t address) {  // the one chip that answers: on a connected channel, at that address
        if (address != 0x68 && address != 0x69) return nullptr;
        Chip* found = nullptr;
        for (int c = 0; c < 8; ++c) {
            Chip& k = chip[c][address - 0x68];
            if (!(mux >> c & 1) || !k.present) continue;
            if (found) return nullptr;  // two chips answering at once: a garbled bus
            found = &k;
        }
        return found;
    }
    bool write(uint8_t address, const uint8_t* data, size_t n) override {
        if (address == ImuBus::kMuxAddress) {
            spend(9 * (1 + static_cast<int>(n)), 0);
            mux = data[n - 1];
            ++mux_writes;
            return true;
        }
        Chip* k = find(address);
        if (!k) {
            spend(9, 0);  // the address is not acknowledged: STOP
            return false;
        }
        spend(9 * (1 + static_cast<int>(n)), 0);
        ++k->accesses;
        for (size_t i = 1; i < n; ++i) k->reg[(data[0] + i - 1) & 127] = data[i];
        return true;
    }
    bool read_registers(uint8_t address, uint8_t reg, uint8_t* out, size_t n) override {
        Chip* k = find(address);
        if (!k) {
            spend(9, 0);
            return false;
        }
        spend(9 * (3 + static_cast<int>(n)), 1);
        ++k->accesses;
        for (size_t i = 0; i < n; ++i) out[i] = k->reg[(reg + i) & 127];
        return true;
    }
    void add(int channel, uint8_t address, uint8_t who = 0x71) {
        Chip& k = chip[channel][address - 0x68];
        k = Chip{};
        k.present = true;
        k.reg[mpu9250::kWhoAmI] = who;
        k.reg[mpu9250::kPwrMgmt1] = 0x40;  // asleep, as after power-up
    }
    // a sample in the chip's output registers: big-endian ax ay az temp gx gy gz
    void sample(int channel, uint8_t address, const int16_t v[7]) {
        uint8_t* r = chip[channel][address - 0x68].reg + mpu9250::kAccelXoutH;
        for (int i = 0; i < 7; ++i) {
            r[2 * i] = static_cast<uint8_t>(static_cast<uint16_t>(v[i]) >> 8);
            r[2 * i + 1] = static_cast<uint8_t>(v[i]);
        }
    }
};

// The thesis' wiring (table 4.1, src/glove_config.h): pairs on channels 0-5, AD0 high first.
struct Rig {
    BusModel bus;
    ImuBus imus;
    uint8_t n;
    explicit Rig(uint8_t n_imu = glove_config::kNumImus) : n(n_imu) {
        uint8_t channel[kMaxImus];
        bool high[kMaxImus];
        for (uint8_t i = 0; i < n; ++i) {
            channel[i] = glove_config::kMuxMap[i];
            high[i] = glove_config::secondary_address(i);
            bus.add(channel[i], high[i] ? 0x69 : 0x68);
        }
        imus.init(&bus, n, channel, high);
    }
    BusModel::Chip& chip(uint8_t i) {
        return bus.chip[glove_config::kMuxMap[i]][glove_config::secondary_address(i) ? 1 : 0];
    }
};

}  // namespace

TEST(begin_configures_every_imu_and_refuses_a_stranger) {
    Rig r;
    r.bus.chip[3][0].reg[mpu9250::kWhoAmI] = 0x12;  // IMU 7 (channel 3, AD0 low) is not an MPU9250
    const uint16_t ok = r.imus.begin();
    CHECK(ok == (0xFFF & ~(1u << 7)));
    for (uint8_t i = 0; i < r.n; ++i) {
        if (i == 7) continue;
        const uint8_t* reg = r.chip(i).reg;
        for (const auto& rv : mpu9250::kSettings) CHECK(reg[rv[0]] == rv[1]);
        CHECK(reg[mpu9250::kGyroConfig] == 0x18 && reg[mpu9250::kAccelConfig] == 0x18);  // +-2000 dps, +-16 g
    }
    CHECK(r.chip(7).reg[mpu9250::kPwrMgmt1] == 0x40);  // never woken up
}

TEST(a_cycle_reads_each_imu_once_with_one_mux_switch_per_channel) {
    Rig r;
    r.imus.begin();
    for (uint8_t i = 0; i < r.n; ++i) {
        const int16_t v[7] = {int16_t(100 * i), int16_t(-2048), int16_t(i - 300), int16_t(1335 + i),
                              int16_t(-32768), int16_t(32767), int16_t(7 * i)};  // ax ay az temp gx gy gz
        r.bus.sample(glove_config::kMuxMap[i], glove_config::secondary_address(i) ? 0x69 : 0x68, v);
    }
    int16_t raw[kMaxImus][7] = {};
    r.imus.read_all(0, raw);  // the first cycle starts from the mux where begin() left it
    r.bus.mux_writes = 0;
    for (uint8_t i = 0; i < r.n; ++i) r.chip(i).accesses = 0;
    CHECK(r.imus.read_all(10, raw) == 0xFFF);
    CHECK(r.bus.mux_writes == 6);
    for (uint8_t i = 0; i < r.n; ++i) {
        CHECK(r.chip(i).accesses == 1);
        CHECK(raw[i][0] == 100 * i && raw[i][1] == -2048 && raw[i][2] == i - 300);  // accel
        CHECK(raw[i][3] == -32768 && raw[i][4] == 32767 && raw[i][5] == 7 * i);   // gyro
        CHECK(raw[i][6] == 1335 + i);                                              // temperature last
    }
}

TEST(the_stated_budget_is_what_a_cycle_spends_on_the_bus) {
    for (uint8_t n : {uint8_t(12), uint8_t(16)}) {
        uint8_t channel[16] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
        bool high[16];
        BusModel bus;
        for (uint8_t i = 0; i < n; ++i) {
            high[i] = i % 2 == 0;
            bus.add(channel[i], high[i] ? 0x69 : 0x68);
        }
        ImuBus imus;
        imus.init(&bus, n, channel, high);
        imus.begin();
        int16_t raw[kMaxImus][7];
        imus.read_all(0, raw);
        const double before = bus.time_us;
        const int transactions = bus.transactions;
        for (int k = 1; k <= 100; ++k) imus.read_all(static_cast<uint32_t>(k), raw);
        const double per_cycle = (bus.time_us - before) / 100;
        CHECK_NEAR(per_cycle, imus.cycle_us(I2cTiming{400000}), 1e-6);
        CHECK((bus.transactions - transactions) / 100 == n + n / 2);  // a read per IMU, a switch per channel
    }
}

TEST(the_configured_sense_rate_is_within_10_percent_of_the_bus_bound) {
    const uint8_t channel[16] = {0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7};
    const bool high[16] = {true, false, true, false, true, false, true, false,
                           true, false, true, false, true, false, true, false};
    for (uint8_t n : {uint8_t(12), uint8_t(16)}) {
        BusModel bus;
        ImuBus imus;
        imus.init(&bus, n, channel, high);
        const double cycle = imus.cycle_us(I2cTiming{glove_config::kI2cClockHz});
        const double bound_hz = 1e6 / cycle;
        const uint16_t rate = glove_config::sense_rate_hz(n);
        // 12 x 14-byte reads + 6 switches at 400 kHz: 4.92 ms, ~203 cycles a second (the bolderflight library's
        // 23-byte reads allowed ~135); 16 IMUs ~152
        CHECK(n == 16 || (bound_hz > 195 && bound_hz < 210));
        CHECK(rate >= 0.9 * bound_hz);
        // and each period leaves the CPU its part: the core's cycle (~21k M7 instructions for 12 IMUs,
        // firmware/m7_counts.json: 35 us at 600 MHz and 1 instruction a clock) and Teensyduino Wire's own time
        // per transaction (not measurable without a board: 10 us allowed for each)
        const double cpu_us = 21000.0 * n / 12 / 600.0 + (n + n / 2) * 10.0;
        CHECK(1e6 / rate >= cycle + cpu_us);
    }
    CHECK(glove_config::kSenseRateHz == glove_config::sense_rate_hz(glove_config::kNumImus));
}

TEST(a_silent_imu_is_faulted_then_tried_every_100_ms_and_recovers) {
    Rig r;
    r.imus.begin();
    int16_t raw[kMaxImus][7] = {};
    r.chip(5).present = false;  // its cable came loose
    uint32_t t = 0;
    uint16_t ok = 0;
    for (int k = 0; k < 2; ++k) ok = r.imus.read_all(t += 5, raw);
    CHECK(ok & (1u << 5));  // a miss or two: the previous sample stands in
    ok = r.imus.read_all(t += 5, raw);
    CHECK(!(ok & (1u << 5)) && (ok | (1u << 5)) == 0xFFF);
    r.chip(5).present = true;
    r.chip(5).accesses = 0;
    for (int k = 0; k < 10; ++k) ok = r.imus.read_all(t += 5, raw);  // 50 ms: not tried yet
    CHECK(r.chip(5).accesses == 0 && !(ok & (1u << 5)));
    for (int k = 0; k < 12; ++k) ok = r.imus.read_all(t += 5, raw);  // past 100 ms: tried once, answers
    CHECK(r.chip(5).accesses >= 1 && (ok & (1u << 5)));
}

TEST(a_powered_down_imu_is_configured_again) {
    Rig r;
    r.imus.begin();
    int16_t raw[kMaxImus][7] = {};
    r.chip(2).present = false;
    for (uint32_t t = 0; t < 30; t += 5) r.imus.read_all(t, raw);
    r.bus.add(glove_config::kMuxMap[2], 0x69);  // back, asleep with its power-on registers
    r.imus.reinit_faulted();
    CHECK(r.chip(2).reg[mpu9250::kPwrMgmt1] == 0x01 && r.chip(2).reg[mpu9250::kGyroConfig] == 0x18);
    CHECK(r.imus.read_all(40, raw) & (1u << 2));
}

TEST(decode_is_big_endian_and_signed) {
    const uint8_t b[14] = {0x80, 0x00, 0x7F, 0xFF, 0xFF, 0xFF, 0x05, 0x37, 0x00, 0x01, 0x01, 0x00, 0xFF, 0x00};
    int16_t row[7];
    mpu9250::decode(b, row);
    CHECK(row[0] == -32768 && row[1] == 32767 && row[2] == -1);
    CHECK(row[3] == 1 && row[4] == 256 && row[5] == -256 && row[6] == 0x0537);
}

TEST_MAIN()
