"""The doctor's moves (`gloverec doctor`, recorder/calibrate/doctor.py): what the wearer does so that every IMU can
be told apart, and how long each move is recorded on the glove's clock. The emulated wearer
(recorder/emulator/checkup.py) performs them on the same clock.

1. ``still``: the hand flat on a table, palm down, fingers straight and together, still (gyro bias, and which IMUs
   answer at all); 2.-6. one finger at a time, thumb to little: curl it fully and straighten it again, the other
   fingers flat (which IMUs turn, and about which of their axes). The palm's IMU turns in none of them.
"""

from __future__ import annotations

from recorder.hand.skeleton import FINGERS

STILL_S = 2.0
FLEX_S = 1.5  # each finger: rest 0.15 s, curl and straighten in FLEX_MOVE_S, rest
FLEX_MOVE_S = 1.2
STEPS = {"still": STILL_S, **{f: FLEX_S for f in FINGERS}}
START_S = {name: sum(list(STEPS.values())[:k]) for k, name in enumerate(STEPS)}
TOTAL_S = sum(STEPS.values())
