"""Where the tracked marker sits on the glove: M, the marker's orientation in the palm's frame
(``WristFusion(marker_in_palm=M)``), found from a short calibration step (`gloverec calibrate --wrist SOURCE
--glove GLOVE`, recorder/calibrate/mount.py) and saved beside the camera calibrations as ``marker_mount.json``.

The model. At each tracked frame k, the marker's orientation in the tracker's frame and the palm IMU's orientation
at the frame's capture time are related by

    q_marker_k = X · q_palm_k · M

with X (the IMU's world in the tracker's frame) and M (the marker in the palm's frame) unknown and fixed. That is
the rotation part of the robot-world/hand-eye problem A·X' = Z·B (A: the marker's pose, B: the palm's, Z = X and
X' = M⁻¹), which OpenCV solves with ``cv2.calibrateRobotWorldHandEye``. Its Shah method (Kronecker product,
rotation first and translation after) takes zero translations and recovers the rotations as they are (0.1-0.4°
from 400 synthetic frames with 2.7° of marker noise, as the pairwise rotation axes aligned with scipy's
``Rotation.align_vectors`` do); its Li method (simultaneous) fails on zero translations ("determinant(R) is null"),
and ``calibrateHandEye`` needs the relative motions' translations. So OpenCV's Shah solves; what is written here
is the gate around it and a refinement after it. The gate: of the two poses a square's image allows (IPPE), each
frame takes the one that fits the others' solution better, frames off by more than three times the median are
left out, and it solves again until the choice settles. The refinement: scipy's ``least_squares`` on each frame's
angular error with a Cauchy loss at the median error, since Shah's least squares weighs every frame alike and a
square seen nearly face-on gives a far less certain orientation (on the emulated webcam, 2.8° RMS within 20° of
face-on against 0.5° beyond: in an 8 s step with the marker glued 90° off, 1.1° of error in M from Shah alone,
0.5° refined). The residual is the RMS angle between each frame's marker and X · q_palm · M.

Observability: M is fixed only if the palm turned about two different axes (turns about one axis leave M free to
spin about it). ``turns(palm)`` measures that from the IMU alone: the palm's orientations relative to their mean,
as rotation vectors in the palm's axes, and their spread (the 5th to 95th percentile) along each principal
direction; the second largest must reach MIN_TURN_DEG, else the step is refused in one line.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from recorder import GloverecError, quat
from recorder.paths import calibration_dir
from recorder.wrist.fusion import MARKER_ON_BACK

MOUNT_FILE = "marker_mount.json"  # in the calibrations' folder (recorder/paths.py calibration_dir)
MIN_SAMPLES = 20  # tracked frames paired with the palm's orientation
MIN_TURN_DEG = 30.0  # the palm's spread about its second axis (5th to 95th percentile)
GATE_MIN_DEG = 6.0  # a frame is left out when it is off by more than this and three times the median
TURN_MORE = "turn the hand more: tilt it forward/back and left/right in view"
AXES = ("left/right", "forward/back", "turn")  # rotation about the palm's x (fingers), y (thumb side), z (back)


@dataclass(frozen=True)
class MarkerMount:
    """The marker's orientation in the palm's frame (``quat``, wxyz: the rotation from the marker's frame to the
    palm's; identity: flat on the back of the hand, printed x toward the fingers), the fit's ``residual_deg`` (RMS
    over the ``samples`` frames it used), and how it was measured."""

    quat: tuple
    residual_deg: float
    samples: int
    flipped: int = 0  # frames whose other IPPE pose fitted better
    dropped: int = 0  # frames left out by the gate
    turned_deg: tuple = ()  # the palm's spread about its principal axes, largest first
    source: str = ""
    glove: str = ""
    glove_id: int | None = None
    kind: str = field(default="gloverec.MarkerMount", repr=False)

    @property
    def q(self) -> np.ndarray:
        return np.asarray(self.quat, float)

    @property
    def angle_deg(self) -> float:
        return float(np.degrees(quat.angle_between(quat.IDENTITY, self.q)))

    def describe(self) -> str:
        """One line: how far the marker is off flat, as a rotation about the palm's axes, and the fit."""
        rv = np.degrees(quat.to_rotvec(self.q))
        return (f"{self.angle_deg:.1f}° off flat (rotation vector x {rv[0]:+.1f}°, y {rv[1]:+.1f}°, z {rv[2]:+.1f}° "
                f"in the palm's axes), residual {self.residual_deg:.2f}° RMS over {self.samples} frames")  # fmt: skip

    def as_dict(self) -> dict:
        d = asdict(self)
        d["quat"] = [round(float(v), 9) for v in self.quat]
        d["turned_deg"] = [round(float(v), 2) for v in self.turned_deg]
        d["rotvec_deg"] = [round(float(v), 4) for v in np.degrees(quat.to_rotvec(self.q))]
        d["angle_deg"] = round(self.angle_deg, 4)
        d["residual_deg"] = round(float(self.residual_deg), 4)
        return d

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(self.as_dict(), indent=1) + "\n")
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> MarkerMount:
        """The mounting saved at ``path``; GloverecError in one line when it is missing or not one."""
        try:
            data = json.loads(Path(path).read_text())
            if not isinstance(data, dict) or data.get("kind", cls.kind) != "gloverec.MarkerMount":
                raise ValueError("not a marker mounting")
            q = data.get("quat")
            if not (isinstance(q, list) and len(q) == 4 and all(_number(v) for v in q)):
                raise ValueError("'quat' must be 4 numbers, w x y z")
            if abs(math.hypot(*q) - 1.0) > 0.01:
                raise ValueError(f"'quat' is not a unit quaternion (norm {math.hypot(*q):.3g})")
            if not _number(data.get("residual_deg")) or not isinstance(data.get("samples"), int):
                raise ValueError("'residual_deg' and 'samples' must be numbers")
            known = {k: data[k] for k in cls.__dataclass_fields__ if k in data}
            return cls(**{**known, "quat": tuple(quat.normalize(np.asarray(q, float))),
                          "turned_deg": tuple(data.get("turned_deg") or ())})  # fmt: skip
        except FileNotFoundError:
            raise GloverecError(
                f"no marker mounting at {path}: run gloverec calibrate --wrist SOURCE --glove GLOVE"
            ) from None
        except (OSError, ValueError, TypeError) as exc:
            raise GloverecError(f"bad marker mounting {path}: {exc}") from None


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def mount_file(directory) -> Path:
    """Where the mounting is saved: ``marker_mount.json`` in the calibrations' folder."""
    return Path(directory) / MOUNT_FILE


# ---------------------------------------------------------------- how much the palm turned


def _mean(q: np.ndarray) -> np.ndarray:
    q = np.where((q @ q[0])[:, None] < 0, -q, q)
    return quat.normalize(q.sum(axis=0))


def _spread(x: np.ndarray) -> np.ndarray:
    lo, hi = np.percentile(x, [5.0, 95.0], axis=0)
    return hi - lo


def turns(palm) -> tuple[np.ndarray, np.ndarray]:
    """How far the palm turned (degrees): (about its principal axes, largest first (3,); about the palm's own x, y
    and z (3,): AXES), each the 5th to 95th percentile of its orientations relative to their mean."""
    palm = quat.normalize(np.asarray(palm, float).reshape(-1, 4))
    if len(palm) < 2:
        return np.zeros(3), np.zeros(3)
    w = np.degrees(quat.to_rotvec(quat.mul(quat.conj(_mean(palm)), palm)))
    _, _, directions = np.linalg.svd(w - w.mean(axis=0), full_matrices=False)
    principal = np.sort(_spread(w @ directions.T))[::-1]
    return principal, _spread(w)


def progress(palm) -> tuple[float, str]:
    """(how much of the needed turning is done, 0-1; what to do next, in words)."""
    principal, per_axis = turns(palm)
    done = float(np.minimum(principal[:2], MIN_TURN_DEG).sum() / (2 * MIN_TURN_DEG))
    if done >= 1.0:
        return 1.0, "enough: keep turning the hand until the end"
    least = int(np.argmin(per_axis[:2]))  # tilting is what a wearer forgets; turning in the plane comes by itself
    return done, f"tilt it {AXES[least]}"


# ---------------------------------------------------------------- the fit


def _shah(marker: np.ndarray, palm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(X, M) from marker_k = X · palm_k · M by OpenCV's robot-world/hand-eye calibration (Shah), translations 0."""

    zero = [np.zeros((3, 1))] * len(marker)
    r_m_inv, _, r_x, _ = cv2.calibrateRobotWorldHandEye(list(quat.to_matrix(marker)), zero,
                                                        list(quat.to_matrix(palm)), zero,
                                                        method=cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH)  # fmt: skip
    as_quat = lambda r: Rotation.from_matrix(r).as_quat(scalar_first=True)  # noqa: E731
    return as_quat(r_x), quat.conj(as_quat(r_m_inv))


def _refined(marker: np.ndarray, palm: np.ndarray, x: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(X, M) refined from Shah's (x, m) by least squares on each frame's angular error with a Cauchy loss at the
    median error: the frames a square's pose gets most wrong (seen nearly face-on) weigh less."""

    def errors(v):
        predicted = quat.mul(quat.mul(x, quat.from_rotvec(v[:3])), quat.mul(palm, quat.mul(m, quat.from_rotvec(v[3:]))))
        return np.degrees(quat.to_rotvec(quat.mul(quat.conj(predicted), marker))).ravel()

    scale = max(float(np.median(np.linalg.norm(errors(np.zeros(6)).reshape(-1, 3), axis=1))), 0.05)
    v = least_squares(errors, np.zeros(6), loss="cauchy", f_scale=scale).x
    return quat.mul(x, quat.from_rotvec(v[:3])), quat.mul(m, quat.from_rotvec(v[3:]))


def solve_mount(marker, palm, alternatives=None, iterations: int = 8, **about) -> MarkerMount:
    """The mounting from ``marker`` (n, 4: the marker's orientations in the tracker's frame) and ``palm`` (n, 4:
    the palm IMU's at the same times); ``alternatives`` (n, 4, NaN where there is none): each frame's other IPPE
    pose. ``about``: MarkerMount's source, glove and glove_id. GloverecError in one line when too few frames came
    or the palm did not turn about two axes."""
    marker = quat.normalize(np.asarray(marker, float).reshape(-1, 4))
    palm = quat.normalize(np.asarray(palm, float).reshape(-1, 4))
    if len(marker) != len(palm):
        raise ValueError("one palm orientation per marker orientation")
    alt = np.full_like(marker, np.nan) if alternatives is None else np.asarray(alternatives, float).reshape(-1, 4)
    if len(marker) < MIN_SAMPLES:
        raise GloverecError(f"only {len(marker)} tracked marker poses with the glove's palm ({MIN_SAMPLES} needed): "
                            "is the marker in view, and the glove sending?")  # fmt: skip
    _enough_turning(palm)
    has_alt = np.all(np.isfinite(alt), axis=1)
    alt = np.where(has_alt[:, None], alt, marker)
    chosen, use = marker, np.ones(len(marker), bool)
    for _ in range(iterations):
        if use.sum() < MIN_SAMPLES:
            break
        x, m = _shah(chosen[use], palm[use])
        predicted = quat.mul(x, quat.mul(palm, m))
        first, other = quat.angle_between(marker, predicted), quat.angle_between(alt, predicted)
        flip = has_alt & (other < first)
        residual = np.where(flip, other, first)
        gate = max(np.radians(GATE_MIN_DEG), 3.0 * float(np.median(residual)))
        new_chosen, new_use = np.where(flip[:, None], alt, marker), residual <= gate
        settled = np.array_equal(new_use, use) and np.array_equal(new_chosen, chosen)
        chosen, use = new_chosen, new_use
        if settled:
            break
    if use.sum() < MIN_SAMPLES:
        raise GloverecError(f"only {int(use.sum())} of {len(marker)} marker poses agree with the palm's "
                            "orientation: is the glove's palm IMU the one that moves with the marker?")  # fmt: skip
    principal = _enough_turning(palm[use])
    x, m = _refined(chosen[use], palm[use], *_shah(chosen[use], palm[use]))
    predicted = quat.mul(x, quat.mul(palm[use], m))
    rms = float(np.degrees(np.sqrt(np.mean(quat.angle_between(chosen[use], predicted) ** 2))))
    return MarkerMount(tuple(float(v) for v in quat.positive(m)), rms, int(use.sum()), int((flip & use).sum()),
                       int((~use).sum()), tuple(float(v) for v in principal[:2]), **about)  # fmt: skip


def _enough_turning(palm) -> np.ndarray:
    principal, per_axis = turns(palm)
    if principal[1] < MIN_TURN_DEG:
        said = ", ".join(f"{name} {v:.0f}°" for name, v in zip(AXES, per_axis))
        raise GloverecError(f"the hand turned {principal[0]:.0f}° about one axis and {principal[1]:.0f}° about any "
                            f"other ({MIN_TURN_DEG:.0f}° needed about two; {said}): {TURN_MORE}")  # fmt: skip
    return principal


# ---------------------------------------------------------------- what a recording uses


def mounting(source=None, path=None, folder=None, say=None, spec: str | None = None) -> np.ndarray:
    """The marker's mounting a recording's wrist fusion takes (a quaternion): the file ``path`` when given; a
    session log's own (``source.marker_in_palm``: what the recording used); else the one `gloverec calibrate
    --wrist` saved in the calibrations' folder (``folder``, as recorder/paths.py calibration_dir), if it was
    calibrated with this wrist source (``spec``; another source's marker is another marker: not applied, and said);
    else flat on the back of the hand. ``say``: where the line saying which goes."""
    logged = getattr(source, "marker_in_palm", None)
    if path is None and logged is not None:
        q = np.asarray(logged, float)
        where = "the session log's"
    else:
        saved = path is None
        path = mount_file(calibration_dir(folder)) if saved else Path(path)
        if saved and not path.exists():
            return MARKER_ON_BACK.copy()
        mount = MarkerMount.load(path)
        if saved and spec and mount.source and mount.source != spec:
            if say is not None:
                say(f"the marker mounting saved in {path} was calibrated for {mount.source}, not {spec}: not applied "
                    f"(flat on the back of the hand; --wrist-mount {path} applies it)")  # fmt: skip
            return MARKER_ON_BACK.copy()
        q = mount.q
        where = f"from {path}"
    if say is not None:
        angle = float(np.degrees(quat.angle_between(quat.IDENTITY, q)))
        say(f"the marker's mounting on the glove: {angle:.1f}° off flat ({where})")
    return q
