"""Fusion against optical ground truth: real single-IMU recordings (the BROAD dataset: D. Laidig, M. Caruso,
A. Cereatti, T. Seel, "BROAD - A Benchmark for Robust Inertial Orientation Estimation", Data 6(7), 2021,
doi:10.3390/data6070072, CC BY 4.0; nine trials in ../shared/data/broad/), the errors the way BROAD defines them,
and such a recording run through the host's fusion and the glove's core exactly as a recording runs them.

- ``load_trial``: one BROAD HDF5 file (needs h5py, the ``bench`` and ``test`` extras).
- ``orientation_errors``: q_err = q_est (x) q_true^-1 (both sensor -> earth, so the error is in the earth
  frame); inclination 2 acos(sqrt(w^2 + z^2)), heading 2 atan2(z, w); RMSE over the movement samples with a finite
  truth. A 6-D filter cannot see heading: it gets the total error after removing one constant heading offset
  (the circular mean of the heading error) and the heading drift (slope of the unwrapped heading error, deg/min).
- ``registers``: what the glove's MPU9250 reads (counts at +-16 g, +-2000 dps, ties away from zero, saturated).
- ``host_palm``: the recording as the palm IMU of a glove through HostFusion, started from its first ``rest_s``
  seconds (what SessionFusion does): all 12 IMUs read the sensor during that rest (the rest check and the gyro
  bias see a real, still hand), then only the palm's answers (the others are flagged missing, so no joint ties
  the palm to IMUs that do not exist). Returns the palm's orientation in the world after every sample and the
  palm IMU's flags.
- ``stamped_samples``: the glove_core_cli ``run --stamped`` input for the same recording on the glove's core.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from recorder import GloverecError, quat
from recorder.fusion.config import FusionConfig
from recorder.fusion.host import HostFusion
from recorder.hand.skeleton import N_IMUS
from recorder.protocol.frames import MPU_TEMP_OFFSET_C, MPU_TEMP_SENSITIVITY

G = 9.80665  # m/s^2 per g: the MPU9250's unit
ACCEL_FS_G, GYRO_FS_DPS = 16, 2000


@dataclass
class Trial:
    """One recording: gyro (T, 3) rad/s and accel (T, 3) m/s^2 in the sensor's axes, truth (T, 4) sensor ->
    earth (z up; NaN where the markers were hidden), movement (T,) the samples errors count on, rate in Hz."""

    name: str
    rate: float
    gyro: np.ndarray
    accel: np.ndarray
    truth: np.ndarray
    movement: np.ndarray

    @property
    def t_us(self) -> np.ndarray:
        """Device time of every sample (u32 microseconds) as a glove clock at the recording's rate would give."""
        return (np.round(np.arange(len(self.gyro)) * 1e6 / self.rate).astype(np.int64)) & 0xFFFFFFFF


def load_trial(path) -> Trial:
    """A BROAD trial (HDF5: imu_gyr, imu_acc, opt_quat, movement, attribute sampling_rate)."""
    try:
        import h5py  # an optional dependency (the bench extra)
    except ImportError:
        raise GloverecError("reading BROAD trials needs h5py: pip install -e '.[bench]'") from None
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            return Trial(
                path.stem,
                float(f.attrs["sampling_rate"]),
                np.asarray(f["imu_gyr"], float),
                np.asarray(f["imu_acc"], float),
                np.asarray(f["opt_quat"], float),
                np.asarray(f["movement"], bool),
            )
    except (OSError, KeyError) as exc:
        raise GloverecError(f"cannot read BROAD trial {path}: {exc}") from None


def orientation_errors(q_est, truth, movement, rate: float) -> dict:
    """BROAD's errors of estimates q_est (T, 4) against truth (T, 4) over the movement samples, in degrees."""
    ok = np.asarray(movement, bool) & np.all(np.isfinite(truth), axis=1) & np.all(np.isfinite(q_est), axis=1)
    e = quat.mul(quat.normalize(np.asarray(q_est, float)[ok]), quat.conj(np.asarray(truth, float)[ok]))
    w, z = e[:, 0], e[:, 3]
    incl = 2.0 * np.arccos(np.clip(np.sqrt(w * w + z * z), 0.0, 1.0))
    heading = 2.0 * np.arctan2(z, w)
    offset = np.angle(np.mean(np.exp(1j * heading)))
    rest = quat.mul(quat.from_axis_angle([0.0, 0.0, 1.0], -offset), e)
    total = 2.0 * np.arccos(np.clip(np.abs(rest[:, 0]), 0.0, 1.0))
    minutes = np.flatnonzero(ok) / rate / 60.0
    unwrapped = np.unwrap(heading)
    drift = np.polyfit(minutes, unwrapped, 1)[0] if len(minutes) > 1 else 0.0

    def rms(x):
        return float(np.degrees(np.sqrt(np.mean(x * x))))

    return {
        "inclination_rmse_deg": rms(incl),
        "total_rmse_deg": rms(total),  # after removing one constant heading offset
        "heading_drift_deg_per_min": float(np.degrees(drift)),
        "samples": int(ok.sum()),
    }


def registers(gyro, accel_g, temperature_c: float = 25.0) -> np.ndarray:
    """MPU9250 registers (T, 7) int16: accel counts, gyro counts, temperature (the firmware's imu_units.h)."""

    def counts(x):
        return np.clip(np.sign(x) * np.floor(np.abs(x) + 0.5), -32768, 32767)

    out = np.empty(np.shape(gyro)[:-1] + (7,), np.int16)
    out[..., 0:3] = counts(np.asarray(accel_g, float) * (32768.0 / ACCEL_FS_G))
    out[..., 3:6] = counts(np.asarray(gyro, float) * (32768.0 / GYRO_FS_DPS) * (180.0 / np.pi))
    out[..., 6] = round((temperature_c - MPU_TEMP_OFFSET_C) * MPU_TEMP_SENSITIVITY)
    return out


def host_palm(config: FusionConfig, raw, t_us, ok=None, rest_s: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """One IMU fused as a glove's palm IMU (module docstring): raw (T, 7) its registers (``registers``; floats
    with NaN are accepted, as a replayed log may hold), t_us (T,) device time, ok (T,) bool whether it answered
    (None: always). The first ``rest_s`` seconds start the fusion. Returns the palm's orientation in the world
    after every sample (T, 4) and the fusion's flags of the palm IMU (T,) uint8 (recorder/fusion/quality.py)."""
    raw = np.asarray(raw)
    t_us = np.asarray(t_us, np.int64)
    ok = np.ones(len(raw), bool) if ok is None else np.asarray(ok, bool)
    span = ((t_us - t_us[0]) & 0xFFFFFFFF) * 1e-6
    n_rest = int(np.searchsorted(span, rest_s, side="right"))
    if n_rest < 2 or n_rest >= len(raw):
        raise GloverecError(f"the recording needs more than {rest_s} s of rest and then some motion")
    fusion = HostFusion(config)
    fusion.start((np.repeat(raw[:n_rest, None], N_IMUS, axis=1), t_us[:n_rest]))
    out = np.empty((len(raw), 4))
    out[:n_rest] = quat.mul(fusion.C[0], quat.mul(fusion.filter.q[0], quat.conj(fusion.calibration.mounts[0])))
    glove = np.zeros((len(raw) - n_rest, N_IMUS, 7), raw.dtype)
    glove[:, 0] = np.where(ok[n_rest:, None], raw[n_rest:], 0)  # a silent IMU's row is zeros (the firmware's)
    fused = fusion.process_block(glove, t_us[n_rest:], ok[n_rest:].astype(np.int64))
    out[n_rest:] = fused.quats[:, 0]
    flags = np.zeros(len(raw), np.uint8)
    flags[n_rest:] = fused.flags[:, 0]
    return out, flags


def stamped_samples(gyro, accel_g, t_us, n_imu: int = N_IMUS) -> bytes:
    """glove_core_cli ``run --stamped`` input: per sample u32 t_us, u8 flags (0), then for every IMU float32
    gx gy gz (rad/s) ax ay az (g); the recording is on IMU 0 and on every other IMU too (a rigid glove)."""
    T = len(gyro)
    rec = np.zeros(T, [("t", "<u4"), ("flags", "u1"), ("imu", "<f4", (n_imu, 6))])
    rec["t"] = np.asarray(t_us, np.int64) & 0xFFFFFFFF
    rec["imu"] = np.concatenate((gyro, accel_g), axis=1)[:, None, :]
    return rec.tobytes()
