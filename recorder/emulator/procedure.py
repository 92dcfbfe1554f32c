"""The calibration procedure (recorder/hand/calibration.py STEPS) as the emulated wearer performs it, for
`gloverec calibrate --glove emulator`, the benchmark and tests: ``ProcedureMotion`` plays the user's steps, then
blends into a recorder.hand.motion Motion ("gestures", "random").

Timeline (seconds): 0-3 still, flat (step 1); 3-6 two flexions of every finger and the thumb to 60 degrees
(step 2); 6-14 tilts of the hand: forward, back, left, right by 45 degrees, each held 0.8 s (step 3); 14-16 flat
and still again (the reference pose, where fusion starts); 16-17 blend into the motion, which starts at 17.
Plug it into a SyntheticGlove: ``glove.motion = ProcedureMotion(kind, seed, rate)``.
With ``pinch`` (`gloverec calibrate --pinch`) the optional pinch step follows the rest, 16-25 s: flat and still
for 1 s, then the thumb tip to the index, middle, ring and little fingertips in turn, 2 s each (0.6 s there,
0.8 s held, 0.6 s back), for a hand of ``size``; the motion then starts 9 s later (``start``).
"""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.emulator.glove import SyntheticGlove
from recorder.hand.calibration import PINCH_EACH_S, PINCH_FINGERS, PINCH_FLAT_S, STEPS
from recorder.hand.kinematics import JOINTS, N_JOINTS, HandSize, interpolate_dip
from recorder.hand.motion import Motion, MotionBlock, SampledMotion, min_jerk
from recorder.hand.pinch import pinch_pose

HOLD, FLEX, TILT, REST, BLEND = STEPS["still"], STEPS["flex"], STEPS["tilt"], STEPS["rest"], 1.0
TILTS_DEG = ((0, 0, 0), (0, 45, 0), (0, -45, 0), (45, 0, 0), (-45, 0, 0), (0, 0, 0))  # palm rotation vectors
MOVE = TILT_HOLD = TILT / (2 * (len(TILTS_DEG) - 1))  # each tilt: a move, then a hold
PHASES = {
    "still": (0.0, HOLD),
    "flex": (HOLD, HOLD + FLEX),
    "tilt": (HOLD + FLEX, HOLD + FLEX + TILT),
    "rest": (HOLD + FLEX + TILT, HOLD + FLEX + TILT + REST),
}
START = HOLD + FLEX + TILT + REST + BLEND  # the motion's t = 0
FLEXED = tuple(
    JOINTS.index(j)
    for j in JOINTS
    if j.endswith(("mcp_flex", "_pip")) or j in ("thumb_cmc_flex", "thumb_mcp", "thumb_ip")
)


class ProcedureMotion(SampledMotion):
    def __init__(
        self,
        kind: str = "gestures",
        seed: int = 0,
        rate_hz: float = 200.0,
        flex_deg: float = 60.0,
        pinch: bool = False,
        size: HandSize = HandSize(),
    ):
        super().__init__(rate_hz)
        self.motion = Motion(kind, seed=seed, rate_hz=rate_hz)
        self.flex = np.radians(flex_deg)
        self.pinch = pinch
        self.pinch_at = START - BLEND  # the pinch step's start
        self.start = START + (STEPS["pinch"] if pinch else 0.0)  # the motion's t = 0
        self._pinches = [pinch_pose(f, size) for f in PINCH_FINGERS] if pinch else []
        self.phases = dict(PHASES, **({"pinch": (self.pinch_at, self.pinch_at + STEPS["pinch"])} if pinch else {}))

    def at(self, t) -> MotionBlock:
        t = np.asarray(t, float)
        if not self.pinch:
            return self._procedure(t)
        out = self._procedure(np.where(t < self.pinch_at, t, np.where(t < self.start - BLEND, 0.0, t - STEPS["pinch"])))
        during = (t >= self.pinch_at) & (t < self.start - BLEND)
        if during.any():
            out.angles[during] = self._pinch_angles(t[during] - self.pinch_at)
            out.palm_quat[during] = quat.IDENTITY
            out.palm_pos[during] = 0.0
        return MotionBlock(t, out.angles, out.palm_quat, out.palm_pos)

    def _pinch_angles(self, s: np.ndarray) -> np.ndarray:
        """The pinch step's angles at ``s`` seconds into it: flat, then each finger's pinch in turn."""
        k = np.clip(((s - PINCH_FLAT_S) // PINCH_EACH_S).astype(int), 0, len(PINCH_FINGERS) - 1)
        u = np.where(s < PINCH_FLAT_S, -1.0, s - PINCH_FLAT_S - k * PINCH_EACH_S)
        go, hold = 0.3 * PINCH_EACH_S, 0.4 * PINCH_EACH_S
        amount = np.where(u < 0, 0.0, np.where(u < go, min_jerk(u / go), 1.0 - min_jerk((u - go - hold) / go)))
        amount = np.clip(amount, 0.0, 1.0)
        targets = np.array(self._pinches)[k]
        return interpolate_dip(amount[:, None] * targets)

    def _procedure(self, t: np.ndarray) -> MotionBlock:
        n = len(t)
        angles = np.zeros((n, N_JOINTS))
        s = np.clip((t - HOLD) / FLEX, 0.0, 1.0)
        amp = np.where((t >= HOLD) & (t < HOLD + FLEX), 0.5 * (1.0 - np.cos(4.0 * np.pi * s)), 0.0)
        angles[:, list(FLEXED)] = amp[:, None] * self.flex
        angles = interpolate_dip(angles)
        tt = t - (HOLD + FLEX)
        k = np.clip((tt // (MOVE + TILT_HOLD)).astype(int), 0, len(TILTS_DEG) - 2)
        u = np.clip((tt - k * (MOVE + TILT_HOLD)) / MOVE, 0.0, 1.0)
        keys = np.radians(np.array(TILTS_DEG, float))
        tilting = (tt >= 0.0) & (tt < TILT)
        palm = quat.from_rotvec(
            np.where(tilting[:, None], keys[k] + (keys[k + 1] - keys[k]) * min_jerk(u)[:, None], 0.0)
        )
        pos = np.zeros((n, 3))
        m0 = self.motion.at(np.array([0.0]))
        b = min_jerk(np.clip((t - (START - BLEND)) / BLEND, 0.0, 1.0))[:, None]
        blend = (t >= START - BLEND) & (t < START)
        angles = np.where(blend[:, None], (1 - b) * angles + b * m0.angles, angles)
        palm = np.where(blend[:, None], quat.slerp(palm, m0.palm_quat, b[:, 0]), palm)
        pos = np.where(blend[:, None], b * m0.palm_pos, pos)
        after = t >= START
        if after.any():
            m = self.motion.at(t[after] - START)
            angles[after], palm[after], pos[after] = m.angles, m.palm_quat, m.palm_pos
        return MotionBlock(t, angles, palm, pos)


def procedure_glove(kind: str = "gestures", rate_hz: float = 200.0, seed: int = 0, **imu_options) -> SyntheticGlove:
    """A SyntheticGlove whose wearer first runs the calibration procedure."""
    glove = SyntheticGlove(kind, rate_hz, seed, **imu_options)
    glove.motion = ProcedureMotion(kind, seed, rate_hz)
    return glove


def phase(name: str, rate_hz: float, margin_s: float = 0.2) -> slice:
    """Sample indices of a procedure step, ``margin_s`` inside its ends."""
    a, b = PHASES[name]
    return slice(int(round((a + margin_s) * rate_hz)), int(round((b - margin_s) * rate_hz)))


class OnRequest(SampledMotion):
    """The wearer of a standalone emulator (`gloverec emulate --motion calibration`): rests flat until the host
    asks for raw frames, the first thing `gloverec calibrate` does, then performs the procedure (a
    ``ProcedureMotion``: the steps, then the ``kind`` motion). Each later switch into raw mode starts it again,
    from the hand's pose then, moved back to flat in ``SETTLE_S``. So calibrating against an emulator in another
    process works without a wire command the firmware lacks: the set-mode command is the cue."""

    SETTLE_S = 0.05  # with the 50 ms the emulator synthesises ahead, well inside the 0.2 s a step leaves out at
    # each end (recorder/calibrate/procedure.py MARGIN_S)

    def __init__(
        self, kind: str = "gestures", seed: int = 0, rate_hz: float = 200.0, pinch: bool = False, procedure=None
    ):
        """``procedure``: what to perform instead of the calibration (a SampledMotion at ``rate_hz`` that starts
        flat and still: the doctor's moves, recorder/emulator/checkup.py)."""
        super().__init__(rate_hz)
        self.procedure = procedure if procedure is not None else ProcedureMotion(kind, seed, rate_hz, pinch=pinch)
        self.start_s: float | None = None  # session time at which the procedure's t = 0 is (None: resting)
        self._from: MotionBlock | None = None  # the pose it settles from (None: from rest)

    def restart(self, at_s: float) -> None:
        """Start the procedure at session time ``at_s`` (the emulator's synthesis horizon)."""
        self._from = self.at(np.array([at_s])) if self.start_s is not None else None
        self.start_s = at_s + (self.SETTLE_S if self._from is not None else 0.0)

    def at(self, t) -> MotionBlock:
        t = np.asarray(t, float)
        if self.start_s is None:
            rest = self.procedure.at(np.zeros_like(t))
            return MotionBlock(t, rest.angles, rest.palm_quat, rest.palm_pos)
        out = self.procedure.at(np.maximum(t - self.start_s, 0.0))
        settling = t < self.start_s
        if self._from is not None and settling.any():
            b = min_jerk(np.clip(1.0 - (self.start_s - t[settling]) / self.SETTLE_S, 0.0, 1.0))[:, None]
            rest = self.procedure.at(np.zeros(int(settling.sum())))
            out.angles[settling] = (1 - b) * self._from.angles + b * rest.angles
            out.palm_quat[settling] = quat.slerp(self._from.palm_quat, rest.palm_quat, b[:, 0])
            out.palm_pos[settling] = (1 - b) * self._from.palm_pos
        return MotionBlock(t, out.angles, out.palm_quat, out.palm_pos)
