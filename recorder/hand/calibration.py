"""Glove calibration: gyro bias with a stillness check (thesis §3.5.3 eq. 3.20), accelerometer offsets, the
sensor-to-segment alignment (Kortier et al. eq. 34), and the reference pose (thesis eq. 3.21). Results are a
versioned ``GloveCalibration``, saved as JSON per glove id and carried with every recording.

The user's procedure (docs/fusion.md): 1. rest the hand flat, palm down, fingers straight and together, for
``still_s`` seconds; 2. flex all fingers and the thumb twice (MCP, PIP, DIP; no spreading); 3. tilt the hand
forward, back, left and right by about 45 degrees, holding each tilt for a second.
Step 1 gives the gyro biases, the gravity axis of every segment and the reference pose; step 2 the flexion
axis of every finger segment; step 3 the accelerometer offsets (the MPU9250's zero-g offset, up to 60 mg,
would otherwise tilt every segment by up to 5 degrees).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from recorder import quat
from recorder.hand.kinematics import N_JOINTS, forward
from recorder.hand.skeleton import JOINT_MAP, N_IMUS
from recorder.paths import write_atomic

VERSION = 1
# The procedure's steps and how long each is recorded (s): `gloverec calibrate` walks the user through them,
# and the emulated wearer (recorder/emulator/procedure.py) performs them on the same clock. 4: rest flat again
# (the reference pose), a check that the hand is back where step 1 left it.
STEPS = {"still": 3.0, "flex": 3.0, "tilt": 8.0, "rest": 2.0, "pinch": 9.0}
# The optional pinch step (`gloverec calibrate --pinch`, recorder/hand/pinch.py): the hand flat and still for
# PINCH_FLAT_S (host fusion starts from it), then the thumb tip on each fingertip in turn, PINCH_EACH_S each.
PINCH_FINGERS = ("index", "middle", "ring", "pinky")
PINCH_FLAT_S = 1.0
PINCH_EACH_S = 2.0
_Y = np.array([0.0, 1.0, 0.0])
_UP = np.array([0.0, 0.0, 1.0])


class CalibrationRefused(ValueError):
    """The hand moved (or an IMU misbehaved) while it had to rest; ``reason`` says which check failed."""

    def __init__(self, reason: str, imus=()):
        super().__init__(reason)
        self.reason = reason
        self.imus = tuple(int(i) for i in imus)


@dataclass(frozen=True)
class StillnessSettings:
    max_gyro_std: float = 0.02  # rad/s per axis (about 1 deg/s; MPU9250 noise at 1 kHz is 0.004)
    max_accel_std: float = 0.02  # g per axis
    max_accel_drift: float = 0.02  # g: mean of the first third vs the last third of the window
    max_bias: float = 0.175  # rad/s: a larger mean is a slow turn, not a bias (datasheet +-5 deg/s)
    max_gravity_error: float = 0.1  # g: | |a| - 1 | of the mean


@dataclass
class GloveCalibration:
    """Everything the host needs to fuse one glove's raw frames; arrays are per IMU (IMU order)."""

    glove_id: int = 0
    version: int = VERSION
    created: str = ""
    joint_map: tuple = JOINT_MAP
    gyro_bias: np.ndarray = field(default_factory=lambda: np.zeros((N_IMUS, 3)))  # rad/s, eq. 3.20
    gyro_bias_temp_c: np.ndarray = field(default_factory=lambda: np.full(N_IMUS, np.nan))
    accel_offset: np.ndarray = field(default_factory=lambda: np.zeros((N_IMUS, 3)))  # g, subtracted
    mounts: np.ndarray = field(default_factory=lambda: np.tile(quat.IDENTITY, (N_IMUS, 1)))  # IMU = seg (x) mount
    reference_angles: np.ndarray = field(default_factory=lambda: np.zeros(N_JOINTS))  # rad, the pose of step 1
    quality: dict = field(default_factory=dict)

    def to_json(self) -> str:
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, np.ndarray):
                d[k] = np.where(np.isfinite(v), v, None).tolist()
        d["joint_map"] = list(self.joint_map)
        return json.dumps(d, indent=1)

    @classmethod
    def from_json(cls, text: str) -> GloveCalibration:
        d = json.loads(text)
        version = d.get("version")
        if version != VERSION:
            raise ValueError(f"calibration version {version!r} is not supported (this is version {VERSION})")
        out = cls(
            glove_id=int(d["glove_id"]),
            created=d.get("created", ""),
            joint_map=tuple(d["joint_map"]),
            quality=d.get("quality", {}),
        )
        for k in ("gyro_bias", "gyro_bias_temp_c", "accel_offset", "mounts", "reference_angles"):
            setattr(out, k, np.array(d[k], dtype=float))
        return out

    def path(self, folder) -> Path:
        return Path(folder) / f"glove_{self.glove_id:08x}.json"

    def save(self, folder) -> Path:
        return write_atomic(self.path(folder), self.to_json())

    @classmethod
    def load(cls, folder, glove_id: int) -> GloveCalibration:
        return cls.from_json(cls(glove_id=glove_id).path(folder).read_text())


def check_still(gyro, accel, settings: StillnessSettings = StillnessSettings()) -> None:
    """Raise CalibrationRefused unless every IMU rested over the window: gyro (T, n, 3) rad/s, accel g."""
    g = np.asarray(gyro, float)
    a = np.asarray(accel, float)
    s = settings
    if len(g) < 3:
        raise CalibrationRefused("too few samples")
    third = max(1, len(a) // 3)
    checks = (
        ("not finite", ~np.all(np.isfinite(g), axis=(0, 2)) | ~np.all(np.isfinite(a), axis=(0, 2))),
        ("gyro spread", np.nanmax(np.nanstd(g, axis=0), axis=1) > s.max_gyro_std),
        ("accelerometer spread", np.nanmax(np.nanstd(a, axis=0), axis=1) > s.max_accel_std),
        (
            "accelerometer drift",
            np.nanmax(np.abs(np.nanmean(a[:third], 0) - np.nanmean(a[-third:], 0)), 1) > s.max_accel_drift,
        ),
        ("turning", np.linalg.norm(np.nanmean(g, 0), axis=1) > s.max_bias),
        ("no gravity", np.abs(np.linalg.norm(np.nanmean(a, 0), axis=1) - 1.0) > s.max_gravity_error),
    )
    for reason, bad in checks:
        if np.any(bad):
            raise CalibrationRefused(
                f"the hand moved: {reason} (IMUs {np.flatnonzero(bad).tolist()})", np.flatnonzero(bad)
            )


def gyro_bias(gyro, accel, settings: StillnessSettings = StillnessSettings()) -> np.ndarray:
    """Thesis eq. 3.20: the mean gyro (n, 3) rad/s over a still window; refuses a moving hand."""
    check_still(gyro, accel, settings)
    return np.mean(np.asarray(gyro, float), axis=0)


def integrate(gyro, dt) -> np.ndarray:
    """Body-frame rotations (T, n, 4) from the first sample: q_t = q_{t-1} (x) exp(gyro_t dt)."""
    g = np.asarray(gyro, float)
    steps = quat.from_rotvec(g * np.broadcast_to(np.asarray(dt, float), (len(g),))[:, None, None])
    out = np.empty(g.shape[:-1] + (4,))
    q = np.tile(quat.IDENTITY, (g.shape[1], 1))
    for t in range(len(g)):
        out[t] = q
        q = quat.normalize(quat.mul(q, steps[t]))
    return out


def accel_offsets(
    gyro, accel, dt, max_rate: float = 0.1, max_gravity_error: float = 0.15, min_spread: float = 0.1
) -> tuple[np.ndarray, np.ndarray]:
    """Accelerometer offsets (n, 3) g from a sequence with the hand held in several tilts (procedure step 3).

    gyro (T, n, 3) rad/s with its bias removed, accel (T, n, 3) g. Over the quasi-static samples (|gyro| <
    max_rate, | |a| - 1 | < max_gravity_error) a_t = D_t^T u + b, with D_t the gyro-integrated rotation since the
    first sample, u the up direction at the start and b the offset: linear least squares for (u, b) per IMU.
    Returns (offsets, ok); an IMU whose tilts did not span enough directions (rotations about one axis only
    leave the offset along it unknown: smallest singular value of the design matrix per sqrt(sample) below
    ``min_spread``) gets a zero offset and ok False."""
    g = np.asarray(gyro, float)
    a = np.asarray(accel, float)
    rot = quat.to_matrix(integrate(g, dt))  # (T, n, 3, 3) columns: body axes at t in the start frame
    still = (np.linalg.norm(g, axis=2) < max_rate) & (np.abs(np.linalg.norm(a, axis=2) - 1.0) < max_gravity_error)
    n = g.shape[1]
    offsets = np.zeros((n, 3))
    ok = np.zeros(n, bool)
    for i in range(n):
        k = np.flatnonzero(still[:, i])
        if len(k) < 20:
            continue
        rt = np.swapaxes(rot[k, i], -1, -2)  # up_t = R_t^T u
        m = np.concatenate((rt, np.broadcast_to(np.eye(3), rt.shape)), axis=2).reshape(-1, 6)
        if np.linalg.svd(m, compute_uv=False)[-1] / np.sqrt(len(k)) < min_spread:
            continue
        sol, *_ = np.linalg.lstsq(m, a[k, i].reshape(-1), rcond=None)
        offsets[i] = sol[3:]
        ok[i] = True
    return offsets, ok


def flexion_axes(gyro) -> np.ndarray:
    """Dominant rotation axis (n, 3) of each IMU over a flexion movement (procedure step 2), in its own axes:
    the principal eigenvector of sum(w w^T), signed to point along +y (flexion is positive about y)."""
    g = np.asarray(gyro, float)
    cov = np.einsum("tni,tnj->nij", g, g)
    _, vec = np.linalg.eigh(cov)
    axis = vec[..., -1]
    return axis * np.where(axis[:, 1:2] < 0.0, -1.0, 1.0)


def model_frames(reference_angles=None) -> np.ndarray:
    """World orientations (12, 4) of the IMU segments for the reference pose with the palm flat, heading 0."""
    angles = np.zeros(N_JOINTS) if reference_angles is None else np.asarray(reference_angles, float)
    g, _, _ = forward(angles, quat.IDENTITY)
    return g[list(JOINT_MAP)]


def align(still_accel, flex_axes=None, reference_angles=None) -> np.ndarray:
    """Sensor-to-segment mounts (n, 4), IMU = segment (x) mount (Kortier et al. eq. 34, in this model's frames).

    still_accel (n, 3): mean specific force in the reference pose (offsets removed), the gravity axis; flex_axes
    (n, 3) or None: the flexion axis (+y of the segment) seen by each IMU. Eq. 34 builds the segment frame from
    the two (there: x = gravity, z = flexion; here z is dorsal and y the flexion axis, and the thumb's segments
    are not level in the reference pose, so the expected up direction comes from the hand model). Gravity is
    kept exactly, the flexion axis fixes the rotation about it (TRIAD). Without a flexion axis (the palm, or an
    IMU that did not turn), only the tilt is aligned (shortest rotation)."""
    up_sensor = np.asarray(still_accel, float)
    up_sensor = up_sensor / np.linalg.norm(up_sensor, axis=1, keepdims=True)
    seg = model_frames(reference_angles)
    up_seg = quat.rotate(quat.conj(seg), _UP)
    n = len(up_sensor)
    mounts = np.empty((n, 4))
    for i in range(n):
        f = None if flex_axes is None else np.asarray(flex_axes[i], float)
        if f is None or not np.all(np.isfinite(f)) or np.linalg.norm(np.cross(up_sensor[i], f)) < 0.1:
            m_seg_to_sensor = quat.from_two_vectors(up_seg[i], up_sensor[i])
        else:
            m_seg_to_sensor = _triad(up_seg[i], _Y, up_sensor[i], f)
        mounts[i] = quat.conj(m_seg_to_sensor)  # v_sensor = R(mount)^T v_segment
    return quat.positive(mounts)


def _triad(u1, u2, v1, v2) -> np.ndarray:
    """Rotation taking u1 exactly onto v1 and u2 as close as possible onto v2."""

    def frame(a, b):
        a = a / np.linalg.norm(a)
        c = np.cross(a, b)
        c = c / np.linalg.norm(c)
        return np.stack((a, c, np.cross(a, c)), axis=1)

    m = frame(v1, v2) @ frame(u1, u2).T
    return _quat_from_matrix(m)


def _quat_from_matrix(m) -> np.ndarray:
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0
    y = np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0
    z = np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0
    x = np.copysign(x, m[2, 1] - m[1, 2])
    y = np.copysign(y, m[0, 2] - m[2, 0])
    z = np.copysign(z, m[1, 0] - m[0, 1])
    return quat.normalize(np.array([w, x, y, z]))


def heading(q) -> np.ndarray:
    """The rotation about world z (..., 4) closest to q (its twist about z)."""
    q = np.array(q, dtype=float, copy=True)
    q[..., 1:3] = 0.0
    return quat.normalize(q)


def tilt(q) -> np.ndarray:
    """q with its heading removed: the rotation about a horizontal axis taking z where q takes it."""
    return quat.from_two_vectors(np.broadcast_to(_UP, np.shape(q)[:-1] + (3,)), quat.rotate(q, _UP))


def reference(imu_quats, mounts, reference_angles=None) -> np.ndarray:
    """Thesis eq. 3.21 for this hand model: per-IMU world-heading corrections C (n, 4) such that
    C (x) q_imu (x) mount^-1 is the model's segment orientation in the reference pose, the palm's heading
    being 0. Only headings are corrected: tilt is observed by the accelerometers all the time."""
    seg = quat.mul(np.asarray(imu_quats, float), quat.conj(mounts))
    palm = tilt(seg[0])
    model = quat.mul(palm, model_frames(reference_angles))
    return heading(quat.mul(model, quat.conj(seg)))


def created_now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")
