#include "mpu9250.h"

#include <cstddef>

namespace gc {
namespace mpu9250 {

bool configure(I2cBus& bus, uint8_t address) {
    uint8_t who = 0;
    if (!bus.read_registers(address, kWhoAmI, &who, 1) || (who != 0x71 && who != 0x73 && who != 0x70)) return false;
    for (const auto& rv : kSettings)
        if (!bus.write(address, rv, 2)) return false;
    uint8_t back[5];  // SMPLRT_DIV .. ACCEL_CONFIG2, consecutive
    if (!bus.read_registers(address, kSmplrtDiv, back, sizeof back)) return false;
    for (const auto& rv : kSettings)
        if (rv[0] >= kSmplrtDiv && rv[0] <= kAccelConfig2 && back[rv[0] - kSmplrtDiv] != rv[1]) return false;
    return true;
}

void decode(const uint8_t b[kBurstBytes], int16_t row[7]) {
    const auto be = [b](size_t i) { return static_cast<int16_t>(static_cast<uint16_t>(b[i] << 8 | b[i + 1])); };
    row[0] = be(0), row[1] = be(2), row[2] = be(4);   // accel x y z
    row[3] = be(8), row[4] = be(10), row[5] = be(12);  // gyro x y z
    row[6] = be(6);                                    // temperature
}

bool read(I2cBus& bus, uint8_t address, int16_t row[7]) {
    uint8_t burst[kBurstBytes];
    if (!bus.read_registers(address, kAccelXoutH, burst, sizeof burst)) return false;
    decode(burst, row);
    return true;
}

}  // namespace mpu9250
}  // namespace gc
