"""HandPose: the hand as the glove measured it at one instant, whatever the wire format (fused poses, compact
poses, raw IMU frames fused on the host, legacy JSON). It is what fusion hands on (recorder/fusion/session.py)
and what every command downstream uses: the recorder, the live views, retargeting."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.hand.kinematics import N_JOINTS


@dataclass(frozen=True, slots=True)
class HandPose:
    """angles (20,) rad in kinematics.JOINTS order, always finite (a joint without a fresh measurement holds its
    last value and is marked in ``valid``); palm (4,) the palm's orientation in the glove's world (w, x, y, z);
    valid (20,) bool: the joint was measured in this sample; quality: host fusion's disturbance estimate (the
    largest accelerometer magnitude error of the fused IMUs, g; 0 when the glove fused); t_us: the device clock
    (µs, wraps at 2^32; -1: a legacy JSON glove has none); rx_ns: host receive time (time.monotonic_ns)."""

    angles: np.ndarray
    palm: np.ndarray
    valid: np.ndarray
    quality: float = 0.0
    t_us: int = -1
    rx_ns: int = 0

    @classmethod
    def rest(cls, angles=None) -> HandPose:
        """A pose with no measurement yet: ``angles`` (default the model's zero pose), palm level, nothing valid."""
        a = np.zeros(N_JOINTS) if angles is None else np.asarray(angles, float)
        return cls(a, quat.IDENTITY.copy(), np.zeros(N_JOINTS, bool))

    def between(self, newer: HandPose, w: float) -> HandPose:
        """The pose a fraction ``w`` of the way to ``newer``: joint angles linear, the palm by SLERP; valid where
        both are; quality the worse; stamps (t_us, rx_ns) of ``newer``, the newest sample used."""
        return HandPose(
            self.angles + w * (newer.angles - self.angles),
            quat.slerp(self.palm, newer.palm, w),
            self.valid & newer.valid,
            max(self.quality, newer.quality),
            newer.t_us,
            newer.rx_ns,
        )

    def vector(self) -> np.ndarray:
        """(24,) float32: the 20 joint angles, then the palm quaternion (the dataset's ``observation.glove``)."""
        return np.concatenate((self.angles, self.palm)).astype(np.float32)
