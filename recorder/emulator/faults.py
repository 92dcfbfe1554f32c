"""Build errors of a glove, injected where the real ones happen: in the frames the emulated Teensy sends
(`gloverec emulate --fault ...`), so the host sees them exactly as from a faulty glove.

- ``swap:A,B``: the cables of IMUs A and B swapped on the multiplexer (each one's data under the other's index);
- ``rotate:I:DEG``: IMU I glued turned by 90, 180 or 270 degrees about its normal (its x and y axes turned);
- ``dead:I``: IMU I never answers (the firmware clears its ok bit and zeroes its row);
- ``stuck:I``: IMU I answers with the same registers every time;
- ``flaky:I``: IMU I drops out part of the time (a loose contact): bursts of 50-400 ms, about a third of the time;
- ``rate:HZ``: frames leave at HZ while the status frames announce the glove's rate (a slow bus).
The sensor faults act on the IMU where it is mounted, the swap after them (on the cables), as on a real glove.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import GloverecError
from recorder.fusion.channels import quarter_turns
from recorder.hand.skeleton import N_IMUS

KINDS = ("swap", "rotate", "dead", "stuck", "flaky", "rate")
SPELLING = "swap:A,B, rotate:I:90|180|270, dead:I, stuck:I, flaky:I or rate:HZ"


@dataclass(frozen=True)
class Fault:
    kind: str
    imus: tuple[int, ...] = ()
    value: float = 0.0  # rotate: degrees; rate: Hz

    def __str__(self) -> str:
        if self.kind == "swap":
            return f"swap:{self.imus[0]},{self.imus[1]}"
        if self.kind == "rotate":
            return f"rotate:{self.imus[0]}:{self.value:g}"
        if self.kind == "rate":
            return f"rate:{self.value:g}"
        return f"{self.kind}:{self.imus[0]}"


def parse_fault(text: str) -> Fault:
    """``--fault``'s spelling (module docstring); anything else, or an IMU index outside 0-11: one line."""
    kind, _, rest = str(text).partition(":")

    def imu(s: str) -> int:
        if not s.strip().isdigit() or not 0 <= int(s) < N_IMUS:
            raise GloverecError(f"--fault {text}: {s!r} is not an IMU index (0 to {N_IMUS - 1})")
        return int(s)

    if kind == "swap" and rest.count(",") == 1:
        a, b = (imu(s) for s in rest.split(","))
        if a == b:
            raise GloverecError(f"--fault {text}: swap two different IMUs")
        return Fault("swap", (a, b))
    if kind == "rotate" and rest.count(":") == 1:
        i, deg = rest.split(":")
        if deg not in ("90", "180", "270"):
            raise GloverecError(f"--fault {text}: an IMU is turned by 90, 180 or 270 degrees, not {deg!r}")
        return Fault("rotate", (imu(i),), float(deg))
    if kind in ("dead", "stuck", "flaky") and rest:
        return Fault(kind, (imu(rest),))
    if kind == "rate" and rest:
        try:
            hz = float(rest)
        except ValueError:
            hz = 0.0
        if not hz > 0:
            raise GloverecError(f"--fault {text}: the rate is a number of frames per second")
        return Fault("rate", (), hz)
    raise GloverecError(f"unknown --fault {text!r}; valid: {SPELLING}")


class FaultyGlove:
    """Applies faults to each raw frame's readings (12, 7) and ok mask, and says when a frame is sent."""

    def __init__(self, faults=(), seed: int = 0):
        self.faults = [f if isinstance(f, Fault) else parse_fault(f) for f in faults]
        self.order = np.arange(N_IMUS)
        for f in self.faults:
            if f.kind == "swap":
                a, b = f.imus
                self.order[[a, b]] = self.order[[b, a]]
        rates = [f.value for f in self.faults if f.kind == "rate"]
        self.rate_hz = min(rates) if rates else None
        self._stuck: dict[int, np.ndarray] = {}
        self._rng = np.random.default_rng([seed, 0x666C6B])
        self._flaky_until = {f.imus[0]: (0.0, True) for f in self.faults if f.kind == "flaky"}

    def __bool__(self) -> bool:
        return bool(self.faults)

    def apply(self, t: float, raw: np.ndarray, ok_mask: int) -> tuple[np.ndarray, int]:
        """The readings and ok mask the faulty glove sends at session time ``t`` for the IMUs' true ``raw``."""
        raw = np.array(raw, np.int16, copy=True)
        ok = [(ok_mask >> i) & 1 for i in range(N_IMUS)]
        for f in self.faults:
            if f.kind == "rotate":
                i, turns = f.imus[0], int(f.value) // 90
                raw[i, 0:3] = quarter_turns(raw[i, 0:3], turns)
                raw[i, 3:6] = quarter_turns(raw[i, 3:6], turns)
            elif f.kind == "stuck":
                i = f.imus[0]
                raw[i] = self._stuck.setdefault(i, raw[i].copy())
            elif f.kind == "dead" or (f.kind == "flaky" and not self._flaky_up(f.imus[0], t)):
                raw[f.imus[0]] = 0
                ok[f.imus[0]] = 0
        raw, ok = raw[self.order], [ok[i] for i in self.order]
        return raw, sum(b << i for i, b in enumerate(ok))

    def _flaky_up(self, i: int, t: float) -> bool:
        until, up = self._flaky_until[i]
        if t >= until:  # the contact changes: up for 0.2-1 s, down for 0.05-0.4 s
            up = not up if until > 0 else True
            until = t + (self._rng.uniform(0.2, 1.0) if up else self._rng.uniform(0.05, 0.4))
            self._flaky_until[i] = (until, up)
        return up
