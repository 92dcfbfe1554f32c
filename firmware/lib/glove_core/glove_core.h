// Umbrella header of the portable glove core (no Arduino headers, no allocation in the per-cycle paths).
#pragma once

#include "calibration.h"
#include "cobs.h"
#include "complementary_filter.h"
#include "crc32.h"
#include "debounce.h"
#include "glove.h"
#include "hand.h"
#include "i2c.h"
#include "imu_bus.h"
#include "imu_units.h"
#include "legacy_json.h"
#include "median_filter.h"
#include "mpu9250.h"
#include "protocol.h"
#include "quaternion.h"
