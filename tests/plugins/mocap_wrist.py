"""A wrist source from outside the package (docs/wrist.md, "Adding a wrist source"): ``mocap:SCALE``, a motion-capture
system following the emulated wearer. It reports the palm's pose in the robot's world at 100 Hz, with no camera, no
noise and no latency, its positions SCALE times the wearer's (a tracker in other units: a test tells its poses from
the wearer's by it). Its poses are made on the recording loop's clock (``until``), as the emulated webcam's are."""

import numpy as np

from recorder.config import ConfigError
from recorder.wrist.config import register_wrist_source
from recorder.wrist.format import WristPose

RATE_HZ = 100.0


def _scale(address: str) -> str:
    try:
        ok = float(address) > 0
    except ValueError:
        ok = False
    if not ok:
        raise ConfigError(f"bad wrist source 'mocap:{address}': expected mocap:SCALE, a positive number")
    return address


class Mocap:
    """``wearer(t) -> (position, quat)``: the emulated wearer's palm in the robot's world at the loop's time t."""

    name = "mocap"
    finished = False

    def __init__(self, wearer, scale: float):
        self.wearer, self.scale = wearer, scale
        self.next_t = None
        self.seq = 0

    def open(self):
        return self

    def until(self, t: float) -> list[WristPose]:
        """The poses captured up to the loop's time ``t`` (on its clock), in order."""
        self.next_t = t if self.next_t is None else self.next_t
        out = []
        while self.next_t <= t + 1e-9:
            position, q = self.wearer(self.next_t)
            out.append(WristPose(self.seq, self.next_t, self.scale * np.asarray(position, float), np.asarray(q, float)))
            self.seq += 1
            self.next_t += 1.0 / RATE_HZ
        return out

    def close(self) -> None:
        pass


@register_wrist_source("mocap", spec="mocap:SCALE (the emulated wearer, motion-captured)", check=_scale, wearer=True)
def mocap(config, *, wearer, **options):
    return Mocap(wearer, float(config.address))
