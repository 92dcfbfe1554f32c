"""What is wrong with a glove, from its raw frames (`gloverec doctor`, and `gloverec calibrate` before it fits
anything): each problem names the IMU by its index, multiplexer channel and the segment it should be on, and
what to do.

- sensors (any frames): ``dead`` (never answers, or answers zeros), ``stuck`` (the same registers frame after
  frame), ``intermittent`` (drops out part of the time), ``slow_rate`` (frames arrive slower than the glove's
  status frames announce);
- placement (the doctor's moves, recorder/hand/checkup.py): while one finger curls, the IMUs that turn are that
  finger's, and the further out a segment the more it turns; an IMU that turns with another finger, or out of
  its chain's order, is ``swapped`` (a permutation: fixed in software by a channel map) or ``misplaced``;
- mounting: an IMU's rotation axis while its finger flexes, signed by the way the finger went first (curling),
  is its segment's +y; one near -y or +-x is ``rotated`` by 180 or 90 degrees about its normal (fixed in software
  by quarter turns in the channel map).
The palm turns in none of the finger moves; its own turn about its normal is not checked (no move shows it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from recorder.fusion.channels import ChannelMap
from recorder.fusion.quality import STUCK, InputCheck
from recorder.hand import checkup
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS, JOINT_MAP, MUX_MAP, N_IMUS, SEGMENTS
from recorder.protocol.frames import RawFrame

MARGIN_S = 0.1  # left out at both ends of a move


@dataclass(frozen=True)
class CheckSettings:
    dead_share: float = 0.95  # frames without an answer (or with zeros) beyond which an IMU is dead
    flaky_share: float = 0.01  # ... and above which it is intermittent
    stuck_share: float = 0.5  # frames flagged stuck (recorder/fusion/quality.py) beyond which it is stuck
    rate_ratio: float = 0.9  # frames per second below this share of the announced rate: too slow
    moved_dps: float = 8.0  # RMS gyro over a move above which an IMU turned ...
    moved_share: float = 0.15  # ... and at least this share of the move's most-turning IMU
    rotated_deg: float = 45.0  # flexion axis this far from +y about the normal: turned


@dataclass(frozen=True)
class Problem:
    kind: str  # dead, stuck, intermittent, slow_rate, swapped, misplaced, not_moving, rotated
    imus: tuple[int, ...]
    found: str  # what was seen
    action: str  # what to do
    fixable: bool = False  # the channel map fixes it (`gloverec doctor --fix`)

    def line(self) -> str:
        return f"{self.found}: {self.action}"

    def as_dict(self) -> dict:
        return {
            "kind": self.kind,
            "imus": list(self.imus),
            "channels": [MUX_MAP[i] for i in self.imus],
            "segments": [SEGMENTS[JOINT_MAP[i]] for i in self.imus],
            "found": self.found,
            "action": self.action,
            "fixable": self.fixable,
        }


@dataclass
class Checkup:
    problems: list[Problem] = field(default_factory=list)
    rate_hz: float = 0.0  # measured
    announced_hz: float | None = None
    frames: int = 0
    activity_dps: dict | None = None  # per move, per IMU: RMS gyro
    axes: list | None = None  # per IMU: the signed flexion axis in its own axes (None: not seen)
    channel_map: ChannelMap | None = None  # the software fix, when every problem found has one

    @property
    def ok(self) -> bool:
        return not self.problems


def imu_name(i: int) -> str:
    return f"IMU {i} (channel {MUX_MAP[i]}, {SEGMENTS[JOINT_MAP[i]]})"


def finger_of(i: int) -> str:
    """The finger IMU ``i`` belongs on ('palm' for IMU 0)."""
    seg = JOINT_MAP[i]
    return next((f for f, segs in FINGER_SEGMENTS.items() if seg in segs), "palm")


SLOTS = {f: [i for i in range(N_IMUS) if finger_of(i) == f] for f in ("palm", *FINGERS)}  # base to tip


# ---------------------------------------------------------------- sensors
def sensor_problems(frames: list, announced_hz: float | None, s: CheckSettings = CheckSettings()) -> list[Problem]:
    raw = [f for f in frames if isinstance(f, RawFrame)]
    out = []
    if not raw:
        return out
    data = np.stack([f.data for f in raw])
    ok = (np.array([f.ok_mask for f in raw], np.int64)[:, None] >> np.arange(N_IMUS)) & 1
    silent = (ok == 0) | np.all(data[..., :3] == 0, axis=2)
    share = silent.mean(0)
    stuck = (InputCheck(N_IMUS)(data, [f.ok_mask for f in raw]) & STUCK).astype(bool) & ~silent
    for i in range(N_IMUS):
        if share[i] >= s.dead_share:
            out.append(Problem("dead", (i,), f"{imu_name(i)} sends no data (dead or not connected)",
                               f"check its wires and solder joints on channel {MUX_MAP[i]}, else replace the "
                               "IMU"))  # fmt: skip
        elif share[i] > s.flaky_share:
            out.append(Problem("intermittent", (i,), f"{imu_name(i)} drops out {100 * share[i]:.0f} % of the time",
                               f"a loose contact: reseat or resolder its cable on channel {MUX_MAP[i]}"))  # fmt: skip
        elif stuck[:, i].mean() > s.stuck_share:
            out.append(Problem("stuck", (i,), f"{imu_name(i)} reads the same values frame after frame (stuck)",
                               "power the glove off and on; if it stays stuck, replace the IMU"))  # fmt: skip
    rate = measured_rate(raw)
    if announced_hz and rate < s.rate_ratio * announced_hz:
        out.append(Problem("slow_rate", (), f"frames arrive at {rate:.0f} Hz, the glove announces {announced_hz:g} Hz",
                           "the bus is too slow for that rate: check the I2C clock (400 kHz) and pull-ups, or set a "
                           f"lower rate (set_rate {int(rate)})"))  # fmt: skip
    return out


def measured_rate(raw: list) -> float:
    if len(raw) < 2:
        return 0.0
    span = ((raw[-1].t_us - raw[0].t_us) & 0xFFFFFFFF) * 1e-6
    return (len(raw) - 1) / span if span > 0 else 0.0


# ---------------------------------------------------------------- moves
def split_moves(frames: list, steps: dict = checkup.STEPS) -> dict[str, list[RawFrame]]:
    """Raw frames cut into the doctor's moves by the glove's clock from the first raw frame."""
    raw = [f for f in frames if isinstance(f, RawFrame)]
    if not raw:
        return {}
    t = np.array([(f.t_us - raw[0].t_us) & 0xFFFFFFFF for f in raw]) * 1e-6
    out, start = {}, 0.0
    for name, seconds in steps.items():
        out[name] = [f for f, ti in zip(raw, t) if start <= ti < start + seconds]
        start += seconds
    return out


def _gyro(frames: list, margin_s: float = MARGIN_S) -> tuple[np.ndarray, np.ndarray, float]:
    """(gyro deg/s (T, 12, 3), answered (T, 12), dt s) of the frames more than ``margin_s`` inside the move."""
    if not frames:
        return np.zeros((0, N_IMUS, 3)), np.zeros((0, N_IMUS), bool), 0.005
    t = np.array([(f.t_us - frames[0].t_us) & 0xFFFFFFFF for f in frames]) * 1e-6
    keep = [f for f, ti in zip(frames, t) if margin_s <= ti <= t[-1] - margin_s] or frames
    g = np.stack([f.gyro_dps for f in keep])
    ok = ((np.array([f.ok_mask for f in keep], np.int64)[:, None] >> np.arange(N_IMUS)) & 1).astype(bool)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.005
    return g, ok & np.any(np.stack([f.data[:, :3] for f in keep]) != 0, axis=2), dt


def _bias(still: list) -> np.ndarray:
    g, ok, _ = _gyro(still)
    w = ok[..., None]
    return np.where(w.sum(0) > 0, (g * w).sum(0) / np.maximum(w.sum(0), 1), 0.0)


def _activity(g: np.ndarray, ok: np.ndarray, bias: np.ndarray) -> np.ndarray:
    w = np.where(ok[..., None], g - bias, 0.0)
    return np.sqrt(np.sum(w**2, axis=(0, 2)) / np.maximum(ok.sum(0), 1))


def signed_axis(g: np.ndarray, ok: np.ndarray, bias: np.ndarray, dt: float) -> np.ndarray:
    """Per IMU, the axis (12, 3) it turned about over a move, in its own axes, signed by the way it turned
    first (a finger curls before it straightens: flexion is positive)."""
    w = np.where(ok[..., None], g - bias, 0.0)
    _, vec = np.linalg.eigh(np.einsum("tni,tnj->nij", w, w))
    axis = vec[..., -1]
    angle = np.cumsum(np.einsum("tni,ni->tn", w, axis), axis=0) * dt
    peak = angle[np.argmax(np.abs(angle), axis=0), np.arange(N_IMUS)]
    return axis * np.where(peak < 0, -1.0, 1.0)[:, None]


def quarter_turns_of(axis: np.ndarray) -> int | None:
    """How many quarter turns about its normal a sensor whose flexion axis reads ``axis`` is turned (0-3;
    None: the axis is not in its x-y plane, so no quarter turn explains it)."""
    if abs(axis[2]) > 0.7:
        return None
    return int(np.round(np.degrees(np.arctan2(axis[0], axis[1])) / 90.0)) % 4


def _mounting(i: int, axis, s: CheckSettings, where: str) -> Problem | None:
    psi = np.degrees(np.arctan2(axis[0], axis[1]))
    turns = quarter_turns_of(axis)
    if abs(psi) <= s.rotated_deg and turns is not None:
        return None
    if turns is None:
        return Problem("rotated", (i,), f"{imu_name(i)} turns about its z axis when {where} flexes: it is glued "
                       "tilted, not flat on the segment", "glue it flat, x along the bone")  # fmt: skip
    return Problem("rotated", (i,), f"{imu_name(i)} is mounted turned {90 * turns} degrees about its normal (its "
                   f"flexion axis reads {np.round(axis, 2).tolist()} in its own axes, +y expected)",
                   "`gloverec doctor --fix` saves a quarter-turn correction the host applies to its readings "
                   "(or re-glue it, x along the bone)", fixable=True)  # fmt: skip


def examine(frames: list | dict, announced_hz: float | None = None, s: CheckSettings = CheckSettings()) -> Checkup:
    """The doctor's verdict on the raw frames of its moves (recorder/hand/checkup.py), split by the glove's clock
    from the first raw frame; ``announced_hz``: the output rate the glove's status frames state."""
    if isinstance(frames, dict):  # already cut into moves (the doctor records them one by one)
        moves, raw = frames, [f for m in frames.values() for f in m if isinstance(f, RawFrame)]
    else:
        raw = [f for f in frames if isinstance(f, RawFrame)]
        if announced_hz is None:
            announced_hz = next((float(f.output_rate_hz) for f in frames if hasattr(f, "output_rate_hz")), None)
        moves = split_moves(raw)
    out = Checkup(sensor_problems(raw, announced_hz, s), measured_rate(raw), announced_hz, len(raw))
    bad = {i for p in out.problems if p.kind in ("dead", "stuck") for i in p.imus}
    if not moves or any(len(moves[m]) < 10 for m in checkup.STEPS):
        out.problems.append(Problem("too_short", (), f"only {len(raw)} raw frames: the moves were not all recorded",
                                    "run the doctor again and do every move"))  # fmt: skip
        return out
    bias = _bias(moves["still"])
    act, axis_in = {}, {}
    for finger in FINGERS:
        g, ok, dt = _gyro(moves[finger])
        act[finger] = _activity(g, ok, bias)
        axis_in[finger] = signed_axis(g, ok, bias, dt)
    out.activity_dps = {f: np.round(a, 2).tolist() for f, a in act.items()}
    table = np.stack([act[f] for f in FINGERS], axis=1)  # (12, 5)
    moved = table >= np.maximum(s.moved_dps, s.moved_share * table.max(axis=0))
    seen = [f if moved[i].any() else "palm" for i, f in enumerate(np.array(FINGERS)[np.argmax(table, axis=1)])]
    slot_of, misplaced = _placement(seen, table, bad)
    gappy = {i for p in out.problems if p.kind == "intermittent" for i in p.imus}  # a turn half seen: no sign
    axes_final = [None if i in bad | gappy or seen[i] == "palm" else axis_in[seen[i]][i] for i in range(N_IMUS)]
    out.axes = [None if a is None else np.round(a, 3).tolist() for a in axes_final]
    if misplaced:
        out.problems += misplaced
    else:
        out.problems += _swaps(slot_of, seen)
    turns = [0] * N_IMUS
    for i, a in enumerate(axes_final):
        if a is None:
            continue
        p = _mounting(i, a, s, f"the {seen[i]}")
        if p is not None:
            out.problems.append(p)
            k = quarter_turns_of(a)
            if k is not None:
                turns[slot_of.get(i, i)] = (4 - k) % 4
    if out.problems and all(p.fixable for p in out.problems):
        order = [0] * N_IMUS
        for i in range(N_IMUS):
            order[slot_of.get(i, i)] = i
        out.channel_map = ChannelMap(
            order=tuple(order), turns=tuple(turns), note="; ".join(p.found for p in out.problems)
        )
    return out


def _placement(seen: list, table: np.ndarray, bad: set) -> tuple[dict, list]:
    """Which slot each IMU's readings belong to (by the finger it turned with and how much, base to tip), or the
    problems when that is no permutation of the slots."""
    slot_of, problems = {}, []
    for finger, slots in SLOTS.items():
        members = [i for i in range(N_IMUS) if seen[i] == finger and i not in bad]
        free = [j for j in slots if j not in bad]
        if len(members) != len(free):
            continue
        col = FINGERS.index(finger) if finger != "palm" else None
        members.sort(key=lambda i: table[i, col] if col is not None else 0.0)
        slot_of.update(zip(members, free))
    for i in range(N_IMUS):
        if i in bad or i in slot_of:
            continue
        if seen[i] == "palm":
            problems.append(Problem("not_moving", (i,), f"{imu_name(i)} did not turn when the {finger_of(i)} flexed, "
                                    "nor with any other finger", "check that it is glued to its segment and wired "
                                    f"to channel {MUX_MAP[i]}; or the finger did not move: run the doctor "
                                    "again"))  # fmt: skip
        elif seen[i] != finger_of(i):
            problems.append(Problem("misplaced", (i,), f"{imu_name(i)} turned when the {seen[i]} flexed, not the "
                                    f"{finger_of(i)}", f"its cable is on the {seen[i]}'s place: check which IMU is "
                                    f"wired to channel {MUX_MAP[i]}"))  # fmt: skip
    return slot_of, problems


def _swaps(slot_of: dict, seen: list) -> list[Problem]:
    """The permutation's cycles, each a swap the channel map fixes."""
    out, done = [], set()
    for i, j in sorted(slot_of.items()):
        if i == j or i in done:
            continue
        cycle = [i]
        while slot_of[cycle[-1]] != i and slot_of[cycle[-1]] in slot_of and len(cycle) <= N_IMUS:
            cycle.append(slot_of[cycle[-1]])
        done.update(cycle)
        parts = [f"{imu_name(k)} turned as the {SEGMENTS[JOINT_MAP[slot_of[k]]]} (with the {seen[k]})"
                 if seen[k] != "palm" else f"{imu_name(k)} turned with no finger, as the palm's"
                 for k in cycle]  # fmt: skip
        what = " and ".join(str(k) for k in cycle)
        verb = "swapped" if len(cycle) == 2 else "on each other's places"
        out.append(Problem("swapped", tuple(cycle), f"IMUs {what} are {verb}: " + "; ".join(parts),
                           "`gloverec doctor --fix` saves a channel map the host applies to the raw frames (no "
                           "re-soldering), or swap their cables on the multiplexer", fixable=True))  # fmt: skip
    return out


# ---------------------------------------------------------------- before calibrating
def calibration_problems(still: list, flex: list, announced_hz: float | None = None,
                         s: CheckSettings = CheckSettings()) -> list[Problem]:  # fmt: skip
    """What `gloverec calibrate` checks before fitting anything, from its first two steps (the hand still, then
    every finger flexed together): the sensors, an IMU that turns while the palm rests or rests while every finger
    flexes (the palm's IMU swapped with a finger's), a chain whose segments turn out of order (swapped within a
    finger), a sensor mounted turned. Two fingers' IMUs swapped at the same place look alike here: the doctor's
    one-finger-at-a-time moves tell them apart."""
    out = sensor_problems(list(still) + list(flex), announced_hz, s)
    bad = {i for p in out for i in p.imus}
    bias = _bias(still)
    g, ok, dt = _gyro(flex)
    act = _activity(g, ok, bias)
    axes = signed_axis(g, ok, bias, dt)
    moving = act >= max(s.moved_dps, s.moved_share * act.max())
    if moving[0] and 0 not in bad:
        out.append(Problem("misplaced", (0,), f"{imu_name(0)} turned while the fingers flexed: it is not on the palm",
                           "run `gloverec doctor` to find where it is"))  # fmt: skip
    for i in range(1, N_IMUS):
        if i in bad:
            continue
        if not moving[i]:
            out.append(Problem("not_moving", (i,), f"{imu_name(i)} did not turn while the fingers flexed",
                               "run `gloverec doctor` to find where it is"))  # fmt: skip
            continue
        p = _mounting(i, axes[i], s, "the hand")
        if p is not None:
            out.append(Problem(p.kind, p.imus, p.found, "run `gloverec doctor --fix` (it saves a correction)"))
    for finger in FINGERS:
        chain = [i for i in SLOTS[finger] if i not in bad and moving[i]]
        for a, b in zip(chain, chain[1:]):
            if act[b] < act[a]:
                out.append(Problem("swapped", (a, b), f"{imu_name(b)} turned less than {imu_name(a)} while the "
                                   f"{finger} flexed: they are swapped, or not on their segments",
                                   "run `gloverec doctor --fix`"))  # fmt: skip
    return out
