// The thesis prototype's JSON line (§4.3), recorder/protocol/legacy_json.py:
//   {"wrists":{"w":..,"x":..,"y":..,"z":..},"fingers":[{"joints":[q,q,q]}, ... x5]}\n
// Segment order as the pose frame (palm, then thumb first, joints proximal -> distal). Numbers carry at most
// 6 decimals, rounded half-to-even (as Python's round(v, 6)), trailing zeros dropped.
#pragma once

#include <cstddef>

#include "quaternion.h"

namespace gc {

constexpr size_t kMaxJsonLine = 1400;  // 64 numbers of at most 9 characters plus 444 bytes of structure

// Writes the line, '\n' included, into `out`; returns its length, 0 if `cap` is too small. No allocation.
size_t encode_json_line(const Quat q[16], char* out, size_t cap);

}  // namespace gc
