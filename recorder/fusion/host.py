"""Host-side fusion: raw glove frames -> 16 parent-relative segment quaternions + 20 joint angles + quality.

Per raw frame, in this order (docs/fusion.md):
1. registers -> accelerometer (g) and gyro (rad/s); flags (recorder/fusion/quality.py); flagged IMUs are not
   fused this frame;
2. calibration (recorder/hand/calibration.py): accelerometer offset and static gyro bias removed (eq. 3.20),
   then the tracked bias (recorder/fusion/bias.py);
3. dt per IMU: device time since that IMU's last fused sample (u32 microseconds, wraps), at most max_dt_s; after
   frames it missed (flagged), the gap is integrated at the mean of its last fused rate and this one;
4. one filter step for all IMUs (the configured filter, recorder/fusion/registry.py);
5. bias tracking;
6. hand model: segment = C (x) q_imu (x) mount^-1 (C: heading reference, thesis eq. 3.21; mount: Kortier
   eq. 34); parent-relative orientations; joint angles with the joints' dimensionality and limits and
   eq. 3.3 for the distal phalanges (recorder/hand/joints.py);
7. joint-constraint feedback (Kortier et al.: the constraint as a measurement): the heading each measured
   segment needs to satisfy its joint's dimensionality is fed back into C and the bias tracker.
Steps 3-7 are recorder/fusion/pipeline.py ``run`` (numba, on the filters' step kernels), the same code for one
frame (``process``) and for a block (``process_block``). Pose frames (fused on the glove) pass through: their
quaternions are kept and the joint angles computed.
An EventFrame BUTTON (the glove's reset button) resets the reference pose, as ``reset()`` does (a key).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.fusion import pipeline
from recorder.fusion.bias import BiasTracker
from recorder.fusion.block import filter_block
from recorder.fusion.config import FusionConfig
from recorder.fusion.dispatch import loops
from recorder.fusion.quality import NONFINITE, InputCheck
from recorder.fusion.registry import filter_names, make_filter
from recorder.hand import calibration as cal, joints
from recorder.hand.kinematics import N_JOINTS
from recorder.hand.skeleton import JOINT_MAP, N_IMUS, N_SEGMENTS, PARENTS
from recorder.protocol.frames import (
    MPU_TEMP_OFFSET_C,
    MPU_TEMP_SENSITIVITY,
    EventCode,
    EventFrame,
    PoseFrame,
    RawFrame,
)


@dataclass
class Fused:
    """Fusion output for T frames (``process_block``, ``pose_block``): quats (T, 16, 4) parent-relative (row 0: the
    palm in the world), angles (T, 20) rad, valid (T, 20) bool, flags (T, 12) uint8 (recorder.fusion.quality), and
    quality arrays (T, 12): accel_error (| |a| - 1 | g), trust (accelerometer trust 0..1), bias_change
    (|online bias estimate| rad/s), constraint (rad the joint dimensionality removed), heading (rad of heading
    correction applied since the reference pose: the drift the constraints found)."""

    seq: np.ndarray
    t_us: np.ndarray
    quats: np.ndarray
    angles: np.ndarray
    valid: np.ndarray
    flags: np.ndarray
    accel_error: np.ndarray
    trust: np.ndarray
    bias_change: np.ndarray
    constraint: np.ndarray
    heading: np.ndarray
    source: str = "raw"

    def frame(self, k: int = -1) -> FusedFrame:
        """Frame k alone (what ``process`` returns for one glove frame)."""
        fused = self.flags[k] == 0
        aerr = np.where(fused, self.accel_error[k], 0.0)
        detail = {
            "accel_error": self.accel_error[k],
            "trust": self.trust[k],
            "bias_change": self.bias_change[k],
            "constraint": self.constraint[k],
            "heading": self.heading[k],
            "flagged_imus": int(np.count_nonzero(self.flags[k])),
        }
        return FusedFrame(
            int(self.seq[k]),
            int(self.t_us[k]),
            self.quats[k],
            self.angles[k],
            self.valid[k],
            self.flags[k],
            float(np.max(aerr)) if aerr.size else 0.0,
            detail,
            self.source,
        )


@dataclass
class FusedFrame:
    """One fused glove frame: quats (16, 4) parent-relative (row 0 the palm in the world), angles (20,) rad,
    valid (20,), flags (12,); ``quality`` the frame's disturbance estimate for a recording (the largest
    accelerometer magnitude error of the fused IMUs, g: 0 for a hand at rest; 0 for pose frames), ``detail``
    the per-IMU quality arrays of Fused."""

    seq: int
    t_us: int
    quats: np.ndarray
    angles: np.ndarray
    valid: np.ndarray
    flags: np.ndarray
    quality: float
    detail: dict
    source: str = "raw"


def _joint_imus() -> list[tuple[int, ...]]:
    """The IMUs each joint angle depends on (its segment's and its parent's; DIPs through the PIP)."""
    seg_imu = {s: i for i, s in enumerate(JOINT_MAP)}
    out = []
    for j in range(N_JOINTS):
        seg = next(s for s, f, a in joints.SWING + joints.HINGE if j in (f, a))
        if seg not in seg_imu:  # interpolated distal: driven by the intermediate and the proximal
            seg = PARENTS[seg]
        out.append(tuple(seg_imu[s] for s in (seg, PARENTS[seg]) if s in seg_imu))
    return out


JOINT_IMUS = _joint_imus()
_TABLES = tuple(pipeline.hand_tables().values())  # the order frame_out's ``tables`` takes (+ use_limits)
_JOINT_IMU_MASK = np.zeros((N_JOINTS, N_IMUS), bool)
for _j, _imus in enumerate(JOINT_IMUS):
    _JOINT_IMU_MASK[_j, list(_imus)] = True


class HostFusion:
    def __init__(self, config: FusionConfig | None = None, calibration: cal.GloveCalibration | None = None):
        self.config = config or FusionConfig()
        self.calibration = calibration or cal.GloveCalibration()
        c = self.config
        self.filter = make_filter(c.filter, N_IMUS, **c.filter_settings)
        self.tracker = BiasTracker(N_IMUS, c.bias, use_gravity=not self.filter.spec.own_bias)
        self.check = InputCheck(N_IMUS)
        self.C = np.tile(quat.IDENTITY, (N_IMUS, 1))
        self.heading = np.zeros(N_IMUS)
        self.started = np.zeros(N_IMUS, bool)
        self.last_t = np.zeros(N_IMUS, np.int64)
        self.last_gyro = np.zeros((N_IMUS, 3))  # rad/s, each IMU's last fused rate (bias removed)
        self.missed = np.zeros(N_IMUS, bool)  # frames were missed since the IMU's last fused sample
        self.last_quats = joints.constrained_relative(np.zeros(N_JOINTS))  # pose frames: the last good one
        self.rest_angles = None  # the pose (20,) rad the hand holds at start and reset; None: the calibration's
        self.start_rested = None  # whether the hand rested over what ``start`` was given (None: not started)
        self.channels = None  # the glove's ChannelMap (recorder/fusion/channels.py): applied to raw readings first

    @property
    def reference_angles(self) -> np.ndarray:
        """The joint angles the hand holds when the reference pose is taken (``start``, ``reset``): the
        calibration's reference pose unless ``rest_angles`` says otherwise (an emulated wearer that rests in
        another pose)."""
        return self.calibration.reference_angles if self.rest_angles is None else np.asarray(self.rest_angles)

    # ------------------------------------------------------------------ calibration and reference pose
    def calibrate(self, still, flex=None, tilt=None, glove_id: int | None = None) -> cal.GloveCalibration:
        """The calibration procedure (recorder/hand/calibration.py) from its three recordings, each a list of
        RawFrames, a (raw registers (T, 12, 7), t_us (T,)) pair or a (gyro rad/s, accel g, dt s) tuple. Raises
        CalibrationRefused when the hand moved during ``still``. Returns (and uses) the new calibration."""
        g, a, _, temp = _arrays(still)
        bias = cal.gyro_bias(g, a)
        offset = np.zeros((N_IMUS, 3))
        quality = {"accel_offset_ok": [False] * N_IMUS, "flexion_axis_ok": [False] * N_IMUS}
        if tilt is not None:
            tg, ta, tdt, _ = _arrays(tilt, 1.0 / self.config.rate_hz)
            offset, ok = cal.accel_offsets(tg - bias, ta, tdt)
            quality["accel_offset_ok"] = ok.tolist()
        axes = None
        if flex is not None:
            fg, _, _, _ = _arrays(flex)
            axes = cal.flexion_axes(fg - bias)
            turned = np.sqrt(np.mean(np.sum((fg - bias) ** 2, axis=2), axis=0)) > 0.2
            axes[0] = np.nan  # the palm does not flex
            axes[~turned] = np.nan
            quality["flexion_axis_ok"] = (turned & (np.arange(N_IMUS) > 0)).tolist()
        mounts = cal.align(np.mean(a, axis=0) - offset, axes, self.calibration.reference_angles)
        self.calibration = cal.GloveCalibration(
            glove_id=self.calibration.glove_id if glove_id is None else glove_id,
            created=cal.created_now(),
            gyro_bias=bias,
            gyro_bias_temp_c=temp,
            accel_offset=offset,
            mounts=mounts,
            reference_angles=self.calibration.reference_angles.copy(),
            quality=quality,
        )
        return self.calibration

    def start(self, still) -> None:
        """Start (or restart) fusing with the hand resting in the reference pose over ``still`` (frames or a
        (gyro, accel, dt) tuple): gyro bias refreshed if the hand was still, every filter initialised from
        gravity (eq. 3.5-3.6), bias tracking cleared, and the reference pose taken (eq. 3.21)."""
        if self.channels is not None and isinstance(still, list):
            still = [self.channels.apply(f) if isinstance(f, RawFrame) else f for f in still]
        g, a, _, _ = _arrays(still)
        try:
            self.calibration.gyro_bias = cal.gyro_bias(g, a)
            self.start_rested = True
        except cal.CalibrationRefused:
            self.start_rested = False  # the calibration's bias is kept; the reference pose is as the hand was
        accel = np.mean(a, axis=0) - self.calibration.accel_offset
        self.filter.reset(accel)
        self.filter.bias[:] = 0.0
        self.tracker.b[:] = 0.0
        self.started[:] = True
        self.missed[:] = False
        self.last_gyro[:] = 0.0
        last = _last_t(still)
        if last is not None:
            self.last_t[:] = last
        self.reset()

    def reset(self) -> None:
        """The reference pose, now (the reset button or a key): per-IMU heading corrections C such that the
        hand model is in its reference pose with the palm's heading 0 (eq. 3.21, headings only)."""
        self.C = cal.reference(self.filter.q, self.calibration.mounts, self.reference_angles)
        self.heading[:] = 0.0

    # ------------------------------------------------------------------ frames
    def process(self, frame) -> FusedFrame | None:
        """One frame: a FusedFrame for raw and pose frames, None for others (BUTTON events reset)."""
        if isinstance(frame, RawFrame):
            return self.process_block(
                frame.data[None], [frame.t_us], [frame.ok_mask], frame.accel_fs_g, frame.gyro_fs_dps, [frame.seq]
            ).frame(0)
        if isinstance(frame, PoseFrame):
            return self.pose_block(frame.quats[None], [frame.t_us], [frame.seq]).frame(0)
        if isinstance(frame, EventFrame) and frame.code == EventCode.BUTTON:
            self.reset()
        return None

    def pose_block(self, quats, t_us, seq=None) -> Fused:
        """Pose frames fused on the glove: quaternions kept, joint angles computed, non-finite ones flagged."""
        q = np.array(quats, dtype=float)
        T = len(q)
        finite = np.all(np.isfinite(q), axis=(1, 2))
        for k in range(T):  # a bad frame holds the last good pose (flagged)
            if finite[k]:
                self.last_quats = q[k]
            else:
                q[k] = self.last_quats
        angles = joints.joint_angles(q, limits=self.config.limits)
        z = np.zeros((T, N_IMUS))
        flags = np.repeat(np.where(finite, 0, NONFINITE).astype(np.uint8)[:, None], N_IMUS, axis=1)
        valid = np.repeat(finite[:, None], N_JOINTS, axis=1)
        return Fused(_seq(seq, T), np.asarray(t_us, np.int64), q, angles, valid, flags, z, z, z, z, z, "pose")

    def process_block(self, raw, t_us, ok_mask=None, accel_fs_g: int = 16, gyro_fs_dps: int = 2000, seq=None) -> Fused:
        """T raw frames at once (raw (T, 12, 7) registers, t_us (T,) device µs, ok_mask (T,) bit masks)."""
        raw = np.asarray(raw)
        T = len(raw)
        if self.channels is not None and not self.channels.identity:
            full = np.full(T, (1 << N_IMUS) - 1, np.int64) if ok_mask is None else np.asarray(ok_mask, np.int64)
            raw, ok_mask = self.channels.apply_raw(raw, full)
        t_us = np.asarray(t_us, np.int64)
        flags = self.check(raw, ok_mask)
        fuse = flags == 0
        cal_ = self.calibration
        accel = raw[..., 0:3].astype(float) * (accel_fs_g / 32768.0) - cal_.accel_offset
        gyro = np.radians(raw[..., 3:6].astype(float) * (gyro_fs_dps / 32768.0)) - cal_.gyro_bias
        out = _Out(T)
        run = fuse.copy()  # what the filters take: an IMU's first sample initialises it instead
        k = 0
        while k < T:
            new = fuse[k] & ~self.started
            if new.any():
                self._first_sample(new, accel[k], int(t_us[k]))
                run[k] &= ~new
            fresh = (fuse[k + 1 :] & ~self.started).any(axis=1)
            stop = k + 1 + int(np.argmax(fresh)) if fresh.any() else T
            self._run(k, stop, accel, gyro, t_us, run, out)
            k = stop
        valid = ~(~fuse[:, None, :] & _JOINT_IMU_MASK[None]).any(axis=2)
        return Fused(
            _seq(seq, T),
            t_us,
            out.quats,
            out.angles,
            valid,
            flags,
            out.accel_error,
            out.trust,
            out.bias_change,
            out.constraint,
            out.heading,
        )

    def _first_sample(self, new, accel, t_us: int) -> None:
        """IMUs ``new`` (12,) bool seen for the first time: attitude from gravity (eq. 3.5-3.6), their clock
        starts, and their heading reference from the hand model in its reference pose (eq. 3.21)."""
        self.filter.reset(accel, new)
        self.started |= new
        self.missed[new] = False
        self.last_gyro[new] = 0.0
        self.last_t[new] = t_us
        self.C[new] = cal.reference(self.filter.q, self.calibration.mounts, self.reference_angles)[new]

    def _run(self, k0, k1, accel, gyro, t_us, fuse, out) -> None:
        """Frames k0..k1 through the pipeline (the loop generated around the filter's step, recorder/fusion/
        dispatch.py), the state arrays updated in place and the outputs into ``out``."""
        c, f, tr = self.config, self.filter, self.tracker
        sl = slice(k0, k1)
        host = (tr.b, tr.still_for, tr.params(), bool(tr.use_gravity), bool(c.track_bias), self.C, self.heading,
                self.last_t, self.last_gyro, self.missed, np.ascontiguousarray(quat.conj(self.calibration.mounts)),
                float(c.heading_rate), float(c.heading_bias_rate), float(c.max_dt_s), float(c.parent_share),
                float(c.min_visibility))  # fmt: skip
        inputs = tuple(np.ascontiguousarray(x[sl]) for x in (accel, gyro, t_us, fuse))
        outputs = (out.quats[sl], out.angles[sl], out.accel_error[sl], out.trust[sl], out.bias_change[sl],
                   out.constraint[sl], out.heading[sl])  # fmt: skip
        tables = (*_TABLES, bool(c.limits))
        loops(f.spec).run(f.q, f.bias, f.kernel_state(), f.kernel_params(), host, tables, inputs, outputs)


_COMPILED: set[str] = set()  # filters whose kernels this process has compiled or loaded from numba's cache


def compile_kernels(config: FusionConfig | None = None) -> float:
    """Compile the fusion kernels for ``config``'s filter now (or load them from numba's on-disk cache: about
    0.2 s); returns the seconds it took. Otherwise the first raw frame a process fuses pays for it: 9 s on an idle
    2-core machine the first time after an install, 25 s under load, with the caller stalled meanwhile (a
    recording's reset period froze on it, and its "no glove frames" check then fired)."""
    config = config or FusionConfig()
    if config.filter in _COMPILED:
        return 0.0
    t0 = time.monotonic()
    fusion = HostFusion(config)
    raw = np.zeros((4, N_IMUS, 7), np.int16)
    raw[..., 2] = 2048  # 1 g on z at the +-16 g scale: a hand at rest, palm down
    t_us = np.arange(4, dtype=np.int64) * 5000
    fusion.start((raw[:2], t_us[:2]))
    fusion.process_block(raw[2:], t_us[2:])
    _COMPILED.add(config.filter)
    return time.monotonic() - t0


class _Out:
    def __init__(self, T):
        self.quats = np.empty((T, N_SEGMENTS, 4))
        self.angles = np.empty((T, N_JOINTS))
        self.accel_error, self.trust, self.bias_change, self.constraint, self.heading = (
            np.empty((T, N_IMUS)) for _ in range(5)
        )


def _seq(seq, T):
    return np.arange(T) if seq is None else np.asarray(seq, np.int64)


def _last_t(rec):
    if isinstance(rec, (tuple, list)) and len(rec) and isinstance(rec[-1], RawFrame):
        return rec[-1].t_us
    if isinstance(rec, (tuple, list)) and len(rec) == 2 and np.ndim(rec[0]) == 3 and np.shape(rec[0])[-1] == 7:
        return int(np.asarray(rec[1])[-1])
    return None


def _arrays(rec, dt: float = 0.005, accel_fs_g: int = 16, gyro_fs_dps: int = 2000):
    """(gyro rad/s, accel g, dt s, temperature °C (12,) or NaN) of a recording given as RawFrames, as a
    (raw registers (T, 12, 7), t_us (T,)) pair, or as a (gyro, accel[, dt]) tuple of float arrays."""
    if isinstance(rec, (tuple, list)) and len(rec) and not isinstance(rec[0], RawFrame):
        first = np.asarray(rec[0])
        if first.ndim == 3 and first.shape[-1] == 7:
            raw, t = first, np.asarray(rec[1], np.int64)
            g = np.radians(raw[..., 3:6] * (gyro_fs_dps / 32768.0))
            a = raw[..., 0:3] * (accel_fs_g / 32768.0)
            temp = np.mean(raw[..., 6] / MPU_TEMP_SENSITIVITY + MPU_TEMP_OFFSET_C, axis=0)
        else:
            g, a = first.astype(float), np.asarray(rec[1], float)
            return g, a, (rec[2] if len(rec) > 2 else dt), np.full(g.shape[1], np.nan)
    else:
        frames = list(rec)
        g = np.radians(np.stack([f.gyro_dps for f in frames]))
        a = np.stack([f.accel_g for f in frames])
        t = np.array([f.t_us for f in frames], np.int64)
        temp = np.mean([f.temperature_c for f in frames], axis=0)
    gaps = (np.diff(t) & 0xFFFFFFFF) * 1e-6
    return g, a, np.concatenate(([np.median(gaps) if len(gaps) else dt], gaps)), temp


def compile_every_filter() -> float:
    """Compile (or load from numba's on-disk cache) every registered filter's kernels: the host pipeline
    (``compile_kernels``), the block loop and the single step. Returns the seconds it took. For what starts many
    processes at once that fuse frames (the test suite's workers, before they start): each then loads the cache
    instead of compiling the same kernels at the same time as the others."""
    t0 = time.monotonic()
    gyro, accel = np.zeros((2, N_IMUS, 3)), np.tile([0.0, 0.0, 9.81], (2, N_IMUS, 1))
    for name in filter_names():
        compile_kernels(FusionConfig(filter=name))
        f = make_filter(name, N_IMUS)
        f.update(gyro[0], accel[0], 0.005)
        filter_block(f, gyro, accel, 0.005)
    return time.monotonic() - t0
