"""WristFusion: the wrist pose a free-wrist task takes, from a tracker's poses and the palm IMU's orientation.

Frames. The tracker reports the marker in its own frame T (a camera's: x right, y down, z away from it; a UDP
tracker's world). The robot's world W has z up and the task's axes. ``zero(t)`` (the zero key, or the start of
an episode) takes the palm as pointing its fingers along W's +x at the task's start position: it fixes the IMU's
heading, T's orientation in W (through the marker's mounting on the glove, ``marker_in_palm``) and the tracker
position that maps to the start. The palm's tilt at the zero is the IMU's, which gravity references: a palm
held a few degrees off level tilts neither the mapping nor the robot's start.

Orientation: the palm IMU's (the glove's fused palm quaternion, at the glove's rate), turned about W's vertical
by a heading offset that the tracker's orientation corrects: a complementary filter on that one angle (time
constant ``heading_tau_s``). Why not an error-state Kalman filter on the whole orientation: the IMU's tilt is
referenced to gravity and steadier than a marker's (2.7° RMS here); only its heading drifts, slowly (2.5 °/min on
the BROAD recordings), so one low-passed scalar removes the drift without passing on the marker's noise, with one
constant to choose. A correction that disagrees by more than ``gate_deg`` (a misdetection) is skipped.

The planar ambiguity: of the two poses a square's image allows (IPPE), the one whose palm orientation is nearer
the IMU's at the frame's capture time.

Position: a constant-velocity Kalman filter per axis of T (a camera's depth is far noisier than its image axes,
and both grow with distance), predicted to the time asked: that compensates the tracker's latency (a frame is
taken as captured ``latency_s`` before its stamp) and fills in between frames. Written here rather than with
cv2.KalmanFilter: the frame interval and the measurement noise change every frame, which that class fixes at
construction. Marker lost (no tracked frame for ``lost_after_s``): the pose holds and is flagged; once it is back,
the output moves to the tracked pose no faster than ``reacquire_mps``, and never faster than ``max_mps``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import numpy as np

from recorder import quat
from recorder.config import STRICT, NonNegative, Positive

AGREE_DEG = 5.0  # settling frames whose estimates of T's orientation agree this well count as one view of it
MISS_PX = 3.0  # the cost of a settling frame none of whose poses agrees with a candidate (a reprojection error)

# The marker flat on the back of the hand, its printed x toward the fingers: its axes are the palm's (the palm
# frame's z points out of the back of the hand, as OpenCV's marker z points out of the print; kinematics.py)
MARKER_ON_BACK = quat.IDENTITY.copy()


@dataclass
class FusionConfig:
    __pydantic_config__ = STRICT

    heading_tau_s: Annotated[float, Positive] = 3.0
    settle_s: Annotated[float, NonNegative] = 1.0  # after the zero: T's orientation averaged over this, from the IMU
    gate_deg: Annotated[float, Positive] = 20.0
    latency_s: Annotated[float, NonNegative] = 0.0  # the tracker's, capture to stamp (the emulated camera's is known)
    lost_after_s: Annotated[float, Positive] = 0.2
    reacquire_mps: Annotated[float, Positive] = 0.25
    max_mps: Annotated[float, Positive] = 2.0
    scale: Annotated[float, Positive] = 1.0  # robot metres per tracked metre
    accel_mps2: Annotated[float, Positive] = 3.0  # the Kalman filter's process noise: a hand's accelerations
    noise_m: tuple[float, float, float] = (0.0006, 0.0006, 0.004)  # per axis of T at 0.5 m (grows with distance)
    camera_noise: bool = True  # noise grows with distance (a camera); False: constant (a mocap or VR tracker)


@dataclass(frozen=True)
class FusedWrist:
    """The palm's pose in the robot's world: ``position`` (3, m), ``quat`` (wxyz), ``tracked`` (False: held or
    catching up after the marker was lost) and ``age_s`` (since the last tracked frame)."""

    position: np.ndarray
    quat: np.ndarray
    tracked: bool
    age_s: float


class _Orientations:
    """The IMU's recent orientations (time, quat) in arrays, to look one up at any time (slerp between samples)."""

    def __init__(self, capacity: int = 2048):
        self.t = np.empty(capacity)
        self.q = np.empty((capacity, 4))
        self.n = 0

    def append(self, t: float, q: np.ndarray) -> None:
        if self.n and t <= self.t[self.n - 1]:  # time went back (a loop that waited for the zero): it restates them
            self.n = int(np.searchsorted(self.t[: self.n], t))
        if self.n == len(self.t):  # full: keep the newer half
            half = self.n // 2
            self.t[:half], self.q[:half] = self.t[self.n - half : self.n], self.q[self.n - half : self.n]
            self.n = half
        self.t[self.n], self.q[self.n] = t, q
        self.n += 1

    def at(self, t: float):
        if self.n == 0:
            return None
        k = int(np.searchsorted(self.t[: self.n], t))
        if k <= 0 or k >= self.n:
            return self.q[min(k, self.n - 1)].copy()
        t0, t1 = self.t[k - 1], self.t[k]
        return quat.slerp(self.q[k - 1], self.q[k], (t - t0) / (t1 - t0) if t1 > t0 else 1.0)


def heading_of(q) -> float:
    """The heading (rad, about W's z) of a palm orientation ``q``: its x axis (the fingers) seen from above."""
    x = quat.rotate(q, np.array([1.0, 0.0, 0.0]))
    return float(np.arctan2(x[1], x[0]))


class _ConstantVelocity:
    """A constant-velocity Kalman filter on each of three independent axes."""

    def __init__(self, accel: float):
        self.q = accel**2
        self.x = None  # (3, 2): position, velocity per axis
        self.P = None  # (3, 2, 2)
        self.t = None

    def _predicted(self, t: float):
        dt = max(t - self.t, 0.0)
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = self.q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        return self.x @ F.T, F @ self.P @ F.T + Q

    def update(self, t: float, z: np.ndarray, sigma: np.ndarray) -> None:
        if self.x is None or t < self.t:
            self.x = np.stack((z, np.zeros(3)), axis=1)
            self.P = np.zeros((3, 2, 2))
            self.P[:, 0, 0], self.P[:, 1, 1] = sigma**2, 0.5**2
            self.t = t
            return
        x, P = self._predicted(t)
        S = P[:, 0, 0] + sigma**2
        K = P[:, :, 0] / S[:, None]
        x = x + K * (z - x[:, 0])[:, None]
        P = P - K[:, :, None] * P[:, 0, :][:, None, :]
        self.x, self.P, self.t = x, P, t

    def position(self, t: float) -> np.ndarray:
        return self._predicted(t)[0][:, 0]


class WristFusion:
    """``imu(t, q)`` at the glove's rate, ``tracker(pose)`` per tracker pose (a WristPose, times on the same
    clock as ``t``), ``zero(t, start)`` once the palm is in the nominal pose, ``pose(t)`` -> FusedWrist."""

    def __init__(self, config: FusionConfig | None = None, marker_in_palm=MARKER_ON_BACK):
        self.config = config = config or FusionConfig()
        self.marker_in_palm = np.asarray(marker_in_palm, float)
        self._imu = _Orientations()  # the IMU's recent orientations, to look one up at a capture time
        self._last_tracked = None  # (t, p_T, q_T) of the newest tracked pose
        self._last_poses = []  # its candidates: [(p_T, q_T)], IPPE's two for a marker
        self._settle = []  # the settling frames' estimates of T's orientation in W, a list per frame
        self._filter = _ConstantVelocity(config.accel_mps2)
        self.heading = 0.0  # rad: the IMU's heading correction about W's z
        self.t_in_w = None  # T's orientation in W (set by zero)
        self.imu_in_w = quat.IDENTITY.copy()  # the IMU world's orientation in W (set by zero)
        self.origin = None  # (p_T at the zero, the robot start position)
        self._out = None  # the last output position (W)
        self._out_t = None
        self._catching_up = False
        self.flips = 0  # IPPE poses the IMU chose over the solver's first
        self.skipped = 0  # heading corrections skipped by the gate

    # ------------------------------------------------------------ inputs
    def imu(self, t: float, q) -> None:
        self._imu.append(float(t), quat.normalize(np.asarray(q, float)))

    def _imu_at(self, t: float):
        return self._imu.at(t)

    def _palm_w_from_imu(self, q_imu) -> np.ndarray:
        return quat.mul(quat.from_axis_angle([0, 0, 1.0], self.heading), quat.mul(self.imu_in_w, q_imu))

    def _palm_w_from_marker(self, q_marker) -> np.ndarray:
        return quat.mul(self.t_in_w, quat.mul(q_marker, quat.conj(self.marker_in_palm)))

    def _sigma(self, p) -> np.ndarray:
        noise = np.asarray(self.config.noise_m, float)
        if not self.config.camera_noise:
            return noise
        d = max(float(np.linalg.norm(p)), 0.05) / 0.5
        return noise * np.array([d, d, d * d])

    def tracker(self, pose) -> None:
        """A tracker pose (WristPose, with ``alternative`` for a marker's second IPPE pose); untracked ones (the
        source repeating the last pose) only age the track."""
        if not pose.tracked:
            return
        t = float(pose.t) - self.config.latency_s  # when it was captured
        poses = [(np.asarray(pose.position, float), quat.normalize(np.asarray(pose.quat, float)))]
        if getattr(pose, "alternative", None) is not None:
            poses.append(
                (np.asarray(pose.alternative[0], float), quat.normalize(np.asarray(pose.alternative[1], float)))
            )
        errors = getattr(pose, "errors_px", None) or (0.0,) * len(poses)
        p, q = poses[0]
        q_imu = self._imu_at(t)
        if self.t_in_w is not None and q_imu is not None:
            expected = self._palm_w_from_imu(q_imu)
            settling = t - self._zero_t < self.config.settle_s
            if settling:  # the first second: T's orientation in W from the IMU's, by consensus
                self._settle.append([(self._t_in_w_from(expected, qc), e) for (_, qc), e in zip(poses, errors)])
                self.t_in_w = self._consensus()
            errors = [quat.angle_between(self._palm_w_from_marker(qc), expected) for _, qc in poses]
            k = int(np.argmin(errors))
            p, q = poses[k]
            self.flips += k
            if not settling:
                self._correct_heading(t, self._palm_w_from_marker(q), expected)
        gap = self._last_tracked is not None and t - self._last_tracked[0] > self.config.lost_after_s
        self._catching_up = self._catching_up or gap
        self._last_tracked = (t, p, q)
        self._last_poses = list(zip(poses, errors))
        self._filter.update(t, p, self._sigma(p))

    def _t_in_w_from(self, palm_w, q_marker) -> np.ndarray:
        """T's orientation in W that a marker seen at ``q_marker`` (T) means with the palm at ``palm_w`` (W)."""
        return quat.mul(palm_w, quat.mul(self.marker_in_palm, quat.conj(q_marker)))

    def _consensus(self) -> np.ndarray:
        """T's orientation in W from the settling frames' candidates (a marker's two IPPE poses per frame, each
        with its reprojection error): the candidate whose agreeing poses (within ``AGREE_DEG``, one per frame)
        explain the frames best, summed over the frames (a frame with none costs ``MISS_PX``), averaged with those
        poses. One frame's ranking of the two poses is a coin toss where the view is near the ambiguity, and a
        wrist held still at the zero repeats the same view; the errors summed over the frames still tell."""
        candidates = np.array([c for frame in self._settle for c, _ in frame])
        frame_of = np.array([f for f, frame in enumerate(self._settle) for _ in frame])
        error = np.array([e for frame in self._settle for _, e in frame]) ** 2
        close = quat.angle_between(candidates[:, None], candidates[None]) < np.radians(AGREE_DEG)
        costs = []
        for row in close:
            best = np.full(len(self._settle), MISS_PX**2)  # per frame: its best agreeing pose's error
            np.minimum.at(best, frame_of[row], error[row])
            costs.append(best.sum())
        k = int(np.argmin(costs))
        agree = candidates[close[k]]
        agree = np.where((agree @ candidates[k])[:, None] < 0, -agree, agree)
        return quat.normalize(agree.sum(axis=0))

    def _correct_heading(self, t: float, from_marker, from_imu) -> None:
        err = quat.mul(from_marker, quat.conj(from_imu))
        yaw = 2.0 * np.arctan2(err[3], err[0])
        yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
        if abs(yaw) > np.radians(self.config.gate_deg):
            self.skipped += 1
            return
        dt = 1.0 / 30.0 if self._last_tracked is None else float(np.clip(t - self._last_tracked[0], 1e-3, 0.5))
        self.heading += yaw * min(dt / self.config.heading_tau_s, 1.0)

    def zero(self, t: float, start) -> bool:
        """The palm points its fingers along W's +x now, at the robot's ``start`` position: set the mapping.
        False when there is no tracked pose or IMU orientation to set it from yet."""
        q_imu = self._imu_at(t)
        if self._last_tracked is None or q_imu is None:
            return False
        self.imu_in_w = quat.from_axis_angle([0.0, 0.0, 1.0], -heading_of(q_imu))
        self.heading = 0.0
        palm_w = self._palm_w_from_imu(q_imu)
        self._settle = [[(self._t_in_w_from(palm_w, qc), e) for (_, qc), e in self._last_poses]]
        self.t_in_w, self._zero_t = self._consensus(), float(t)
        self.origin = (self._filter.position(t), np.asarray(start, float))
        self._out, self._out_t, self._catching_up = np.asarray(start, float).copy(), float(t), False
        return True

    # ------------------------------------------------------------ output
    @property
    def zeroed(self) -> bool:
        return self.origin is not None

    def marker(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The fused marker pose in the tracker's frame T at ``t`` (after ``zero``): the filtered position and the
        IMU's orientation (what the tracker would report with no noise, no ambiguity and no latency)."""
        q_imu = self._imu_at(t)
        q = quat.mul(quat.conj(self.t_in_w), quat.mul(self._palm_w_from_imu(q_imu), self.marker_in_palm))
        return self._filter.position(t), q

    def pose(self, t: float) -> FusedWrist:
        """The palm's pose in W at ``t`` (after ``zero``)."""
        if not self.zeroed:
            raise RuntimeError("WristFusion.pose before zero()")
        c = self.config
        q_imu = self._imu_at(t)
        q = self._palm_w_from_imu(q_imu) if q_imu is not None else quat.IDENTITY.copy()
        age = t - self._last_tracked[0]
        tracked = age <= c.lost_after_s
        dt = max(t - self._out_t, 0.0)
        if tracked:
            p_t, start = self.origin
            target = start + c.scale * quat.rotate(self.t_in_w, self._filter.position(t) - p_t)
            step = target - self._out
            limit = (c.reacquire_mps if self._catching_up else c.max_mps) * dt
            dist = float(np.linalg.norm(step))
            if dist > limit:
                step *= limit / dist
            elif self._catching_up:
                self._catching_up = False
            self._out = self._out + step
        self._out_t = t
        return FusedWrist(self._out.copy(), q, bool(tracked and not self._catching_up), float(age))
