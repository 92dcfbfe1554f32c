"""A synthetic glove: ground-truth hand motion -> forward kinematics -> 12 emulated MPU9250s.

The façade the emulator's serial writer reads blocks from. ``pose`` is the ground truth with a little
random orientation noise: it stands in for the glove's on-board fusion output until host-side fusion of
``raw`` exists.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.emulator.imu import ImuArray
from recorder.hand.kinematics import HandSize, dorsal_mounts, forward, relative_quats
from recorder.hand.motion import Motion
from recorder.hand.skeleton import JOINT_MAP, N_IMUS, N_SEGMENTS

__all__ = ["GloveBlock", "SyntheticGlove", "N_IMUS"]

_IMU_SEG = list(JOINT_MAP)


@dataclass
class GloveBlock:
    """n samples of the synthetic glove.

    t (n,) s since start; raw (n, 12, 7) int16 MPU9250 readings (ax, ay, az, gx, gy, gz, temp), or None when
    the glove sent fused poses;
    pose (n, 16, 4) float32 parent-relative quats, truth plus noise; truth_rel (n, 16, 4) exact ones;
    angles (n, 20) rad truth; tips (n, 5, 3) m fingertips relative to the palm origin in world axes;
    palm_quat (n, 4) and palm_pos (n, 3) m the palm's world pose; accel_fs_g, gyro_fs_dps the scales of raw.
    """

    t: np.ndarray
    raw: np.ndarray | None
    pose: np.ndarray
    truth_rel: np.ndarray
    angles: np.ndarray
    tips: np.ndarray
    palm_quat: np.ndarray
    palm_pos: np.ndarray
    accel_fs_g: int
    gyro_fs_dps: int


class SyntheticGlove:
    """Seeded, continuous glove data at ``rate_hz``. ``motion`` is a Motion kind ("gestures", "random") or a
    Motion-like object (``next_block(n) -> MotionBlock`` and ``rate_hz``, e.g. a scripted demonstration)."""

    def __init__(
        self,
        motion="gestures",
        rate_hz: float = 200.0,
        seed: int = 0,
        pose_noise_deg: float = 0.5,
        size: HandSize = HandSize(),
        **imu_options,
    ):
        """pose_noise_deg: RMS angle of the orientation noise on ``pose``. imu_options go to ImuArray."""
        self.rate_hz = float(rate_hz)
        self.size = size
        if isinstance(motion, str):
            motion = Motion(motion, seed=seed, rate_hz=rate_hz)
        elif abs(float(motion.rate_hz) - self.rate_hz) > 1e-9:
            raise ValueError(f"motion samples at {motion.rate_hz} Hz, the glove at {self.rate_hz} Hz")
        self.motion = motion
        mounts = dorsal_mounts(size)[list(JOINT_MAP)]
        self.imus = ImuArray(rate_hz, seed=seed, mount_offsets=mounts, **imu_options)
        self.pose_sigma = np.radians(pose_noise_deg) / np.sqrt(3.0)  # per axis
        self._rng = np.random.default_rng([seed, 0x706F7365])

    def next_block(self, n: int, raw: bool = True) -> GloveBlock:
        """The next n samples; ``raw=False``: without the IMU readings (``raw`` None), for a glove that sends
        fused poses: a quarter of the synthesis, on every frame of a recording."""
        m = self.motion.next_block(n)
        g, pos, tips = forward(m.angles, m.palm_quat, self.size)
        world = pos + m.palm_pos[:, None, :]
        if raw:
            imu = self.imus.sample(g[:, _IMU_SEG], world[:, _IMU_SEG])
        else:
            self.imus.skip(g[:, _IMU_SEG], world[:, _IMU_SEG])
        truth = quat.positive(relative_quats(g))
        noise = quat.from_rotvec(self._rng.normal(0.0, self.pose_sigma, (n, N_SEGMENTS, 3)))
        pose = quat.positive(quat.mul(truth, noise)).astype(np.float32)
        return GloveBlock(
            m.t,
            imu.raw if raw else None,
            pose,
            truth,
            m.angles,
            tips,
            m.palm_quat,
            m.palm_pos,
            self.imus.accel_fs_g,
            self.imus.gyro_fs_dps,
        )
