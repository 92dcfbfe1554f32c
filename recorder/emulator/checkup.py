"""The doctor's moves (recorder/hand/checkup.py) as the emulated wearer performs them, for `gloverec emulate
--motion doctor`, the benchmark and tests: ``CheckupMotion`` rests flat, then curls each finger in turn (all its
joints, to ``flex_deg``, and back), thumb to little, then rests. Like a person, the neighbouring fingers follow a
little (``coupling``, drawn per seed) and each curl has its own depth."""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.emulator.emulator import GLOVE_ID, Emulator
from recorder.emulator.glove import SyntheticGlove
from recorder.hand import checkup
from recorder.hand.kinematics import JOINTS, N_JOINTS, HandSize, interpolate_dip
from recorder.hand.motion import MotionBlock, SampledMotion
from recorder.hand.skeleton import FINGERS

_FLEXED = {
    "thumb": ("thumb_cmc_flex", "thumb_mcp", "thumb_ip"),
    **{f: (f"{f}_mcp_flex", f"{f}_pip") for f in FINGERS[1:]},
}


class CheckupMotion(SampledMotion):
    def __init__(self, seed: int = 0, rate_hz: float = 200.0, flex_deg: float = 60.0, vary: bool = True):
        """``vary``: draw each curl's depth (0.7-1.2 of ``flex_deg``, the thumb's 0.6 of that) and how much the
        neighbouring fingers follow (up to 35 %) from ``seed``; otherwise clean moves."""
        super().__init__(rate_hz)
        rng = np.random.default_rng([seed, 0x646F63])
        depth = rng.uniform(0.7, 1.2, len(FINGERS)) if vary else np.ones(len(FINGERS))
        self.depth = np.radians(flex_deg) * depth * np.where(np.arange(len(FINGERS)) == 0, 0.6, 1.0)
        self.coupling = rng.uniform(0.0, 0.35, len(FINGERS)) if vary else np.zeros(len(FINGERS))

    @property
    def phases(self) -> dict[str, tuple[float, float]]:
        """Each move's (start, end) in s: a live view shows the move in progress (recorder/calibrate/view.py)."""
        return {name: (start, start + checkup.STEPS[name]) for name, start in checkup.START_S.items()}

    def at(self, t) -> MotionBlock:
        t = np.asarray(t, float)
        angles = np.zeros((len(t), N_JOINTS))
        for k, finger in enumerate(FINGERS):
            s = (t - checkup.START_S[finger] - 0.5 * (checkup.FLEX_S - checkup.FLEX_MOVE_S)) / checkup.FLEX_MOVE_S
            amount = np.where((s > 0) & (s < 1), 0.5 * (1.0 - np.cos(2.0 * np.pi * np.clip(s, 0, 1))), 0.0)
            for j, other in enumerate(FINGERS):
                share = 1.0 if j == k else (self.coupling[k] if abs(j - k) == 1 and j > 0 and k > 0 else 0.0)
                if share:
                    for name in _FLEXED[other]:
                        angles[:, JOINTS.index(name)] += share * amount * self.depth[j]
        return MotionBlock(t, interpolate_dip(angles), np.tile(quat.IDENTITY, (len(t), 1)), np.zeros((len(t), 3)))


def checkup_emulator(
    faults=(), seed: int = 0, rate_hz: float = 200.0, misalign_deg: float = 0.0, size: HandSize = HandSize(),
    glove_id: int = GLOVE_ID, vary: bool = True,
) -> Emulator:  # fmt: skip
    """An emulator in raw mode whose wearer performs the doctor's moves from its first sample, with ``faults``
    (recorder/emulator/faults.py), IMUs glued up to ``misalign_deg`` off (RMS) and a hand of ``size``: for
    ``Emulator.stream`` (tests, bench/doctor.py)."""
    emu = Emulator(rate_hz, "raw", "gestures", seed, glove_id=glove_id, faults=faults)
    motion = CheckupMotion(seed, rate_hz, vary=vary)
    emu.glove = SyntheticGlove(motion, rate_hz, seed, size=size, misalign_deg=misalign_deg, unit_seed=glove_id)
    return emu
