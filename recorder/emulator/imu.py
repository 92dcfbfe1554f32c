"""What the glove's 12 MPU9250s read, synthesised from the segments' world trajectories.

Each IMU is strapped on the back of its segment: its frame is the segment frame (see hand.kinematics)
times an optional fixed mounting misalignment, and it sits at a fixed offset in that frame. World frame:
z up, g_world = (0, 0, -9.80665) m/s².

Per sample k (dt = 1 / rate):
- gyro: the body-frame rotation over the last interval, rotvec(conj(q[k-1]) q[k]) / dt, so integrating it
  (q[k] = q[k-1] exp(w dt)) reproduces the orientation exactly; then bias + white noise, saturation,
  int16 quantisation.
- accelerometer: specific force R(q[k])^T (a_world - g_world), a_world from the second-order backward
  second difference (2 p[k] - 5 p[k-1] + 4 p[k-2] - p[k-3]) / dt² of the IMU's world position; then
  offset + white noise, saturation, quantisation.
- temperature: warms from ~24 °C toward ~32 °C (skin contact) with a time constant of a few minutes.
Before the first sample the trajectory is extrapolated back from the first block (see _prime). Samples carry on
across calls.

Error figures (MPU9250 datasheet, PS-MPU-9250A-01): gyro noise 0.01 dps/√Hz, initial ZRO tolerance ±5 dps,
ZRO change with temperature (here ±0.03 dps/°C per axis), accelerometer noise 300 µg/√Hz, zero-g initial
tolerance ±60 mg; full scales ±2/4/8/16 g and ±250/500/1000/2000 dps with LSB = 32768 / full scale
(2048 LSB/g, 16.4 LSB/dps at the defaults); temperature raw = (T - 21 °C) · 333.87.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.hand.skeleton import N_IMUS
from recorder.protocol.frames import MPU_TEMP_OFFSET_C, MPU_TEMP_SENSITIVITY

G = 9.80665  # m/s² per g
G_WORLD = np.array([0.0, 0.0, -G])
ACCEL_FS_G = (2, 4, 8, 16)
GYRO_FS_DPS = (250, 500, 1000, 2000)

GYRO_NOISE_DPS_RTHZ = 0.01
GYRO_BIAS_DPS = 5.0
GYRO_TEMPCO_DPS_C = 0.03
ACCEL_NOISE_G_RTHZ = 300e-6
ACCEL_OFFSET_G = 0.060
TEMP_NOISE_C = 0.02


@dataclass
class ImuBlock:
    """raw (n, 12, 7) int16: ax, ay, az, gx, gy, gz, temperature, as the MPU9250 registers read.
    gyro_true (n, 12, 3) rad/s and accel_true (n, 12, 3) m/s²: noise-free, bias-free, unclipped.
    gyro_bias (n, 12, 3) rad/s and accel_offset (12, 3) m/s²: the errors added to those.
    temp_c (n, 12): true temperature in °C."""

    raw: np.ndarray
    gyro_true: np.ndarray
    accel_true: np.ndarray
    gyro_bias: np.ndarray
    accel_offset: np.ndarray
    temp_c: np.ndarray


def quantise(value, lsb_per_unit: float) -> np.ndarray:
    """Round value · lsb_per_unit to int16, saturating at -32768 / 32767."""
    return np.clip(np.rint(np.asarray(value) * lsb_per_unit), -32768, 32767).astype(np.int16)


class ImuArray:
    """The 12 IMUs, with seeded per-IMU errors. Call ``sample`` with consecutive blocks of a trajectory."""

    def __init__(
        self,
        rate_hz: float,
        seed: int = 0,
        accel_fs_g: int = 16,
        gyro_fs_dps: int = 2000,
        noise: bool = True,
        bias: bool = True,
        mount_offsets=None,
        misalign_deg: float = 0.0,
        unit_seed: int | None = None,
    ):
        """mount_offsets (12, 3) m: IMU position in its segment frame (default 0). noise: white noise on
        gyro, accelerometer and temperature. bias: gyro bias (turn-on + temperature drift) and accelerometer
        offset. misalign_deg: RMS angle of a fixed random mounting rotation per IMU (default none).
        unit_seed: draw the IMUs' own errors (biases, offsets, thermal behaviour, misalignment) from this seed
        and only the noise from ``seed``: the same physical glove in every session (the emulator seeds it with
        its glove id). None: both from ``seed``."""
        if accel_fs_g not in ACCEL_FS_G:
            raise ValueError(f"accel_fs_g must be one of {ACCEL_FS_G}")
        if gyro_fs_dps not in GYRO_FS_DPS:
            raise ValueError(f"gyro_fs_dps must be one of {GYRO_FS_DPS}")
        self.rate_hz = float(rate_hz)
        self.dt = 1.0 / self.rate_hz
        self.accel_fs_g = accel_fs_g
        self.gyro_fs_dps = gyro_fs_dps
        self.noise = noise
        self._rng = np.random.default_rng([seed, 0x696D75])
        rng = self._rng if unit_seed is None else np.random.default_rng([unit_seed, 0x756E6974])
        on = 1.0 if bias else 0.0
        self.gyro_bias0 = on * np.radians(rng.uniform(-GYRO_BIAS_DPS, GYRO_BIAS_DPS, (N_IMUS, 3)))
        self.gyro_tempco = on * np.radians(rng.uniform(-GYRO_TEMPCO_DPS_C, GYRO_TEMPCO_DPS_C, (N_IMUS, 3)))
        self.accel_offset = on * G * rng.uniform(-ACCEL_OFFSET_G, ACCEL_OFFSET_G, (N_IMUS, 3))
        self.temp0 = rng.uniform(23.5, 24.5, N_IMUS)
        self.temp_skin = rng.uniform(31.0, 33.0, N_IMUS)
        self.tau_s = rng.uniform(120.0, 300.0, N_IMUS)
        rv = rng.normal(0.0, np.radians(misalign_deg) / np.sqrt(3.0), (N_IMUS, 3))
        self.mount_quat = quat.from_rotvec(rv)
        self.mount_offsets = np.zeros((N_IMUS, 3)) if mount_offsets is None else np.asarray(mount_offsets)
        # gyro / accel white noise per sample: density · sqrt(Nyquist bandwidth)
        bw = np.sqrt(0.5 * self.rate_hz)
        self.gyro_sigma = np.radians(GYRO_NOISE_DPS_RTHZ) * bw
        self.accel_sigma = ACCEL_NOISE_G_RTHZ * G * bw
        self._k = 0
        self._prev_q = None  # (1, 12, 4) last orientation
        self._prev_p = None  # (3, 12, 3) last three positions, oldest first

    def temperature(self, t) -> np.ndarray:
        """True die temperature (n, 12) in °C at times t (n,) s since the first sample."""
        t = np.asarray(t, dtype=float)[:, None]
        return self.temp_skin - (self.temp_skin - self.temp0) * np.exp(-t / self.tau_s)

    def sample(self, global_quats, positions) -> ImuBlock:
        """Readings for n samples of the segments' world orientations (n, 12, 4) and base positions
        (n, 12, 3) in metres (the IMU sits at ``mount_offsets`` from them)."""
        q_seg = np.asarray(global_quats, dtype=float)
        n = q_seg.shape[0]
        q = quat.mul(q_seg, self.mount_quat)
        p = np.asarray(positions, dtype=float) + quat.rotate(q_seg, self.mount_offsets)
        if n == 0:
            return self._empty()
        if self._prev_q is None:
            self._prime(q, p)
        qq = np.concatenate((self._prev_q, q))
        pp = np.concatenate((self._prev_p, p))
        self._prev_q, self._prev_p = qq[-1:], pp[-3:]

        gyro = quat.to_rotvec(quat.mul(quat.conj(qq[:-1]), qq[1:])) / self.dt
        a_world = (2.0 * pp[3:] - 5.0 * pp[2:-1] + 4.0 * pp[1:-2] - pp[:-3]) / self.dt**2
        accel = quat.rotate(quat.conj(q), a_world - G_WORLD)

        t = (self._k + np.arange(n)) * self.dt
        self._k += n
        temp = self.temperature(t)
        bias = self.gyro_bias0 + self.gyro_tempco * (temp - self.temp0)[..., None]
        g_meas = gyro + bias
        a_meas = accel + self.accel_offset
        t_meas = temp
        if self.noise:  # one draw per sample, so the noise does not depend on how blocks are cut
            z = self._rng.standard_normal((n, N_IMUS, 7))
            a_meas = a_meas + self.accel_sigma * z[..., 0:3]
            g_meas = g_meas + self.gyro_sigma * z[..., 3:6]
            t_meas = t_meas + TEMP_NOISE_C * z[..., 6]

        raw = np.empty((n, N_IMUS, 7), np.int16)
        raw[..., 0:3] = quantise(a_meas / G, 32768.0 / self.accel_fs_g)
        raw[..., 3:6] = quantise(np.degrees(g_meas), 32768.0 / self.gyro_fs_dps)
        raw[..., 6] = quantise(t_meas - MPU_TEMP_OFFSET_C, MPU_TEMP_SENSITIVITY)
        return ImuBlock(raw, gyro, accel, bias, self.accel_offset, temp)

    def skip(self, global_quats, positions) -> None:
        """Advance past n samples without readings (a glove sending fused poses: nobody reads its IMUs), keeping
        the history that the next ``sample`` differentiates; the noise of later readings is drawn afresh."""
        q_seg = np.asarray(global_quats, dtype=float)
        n = q_seg.shape[0]
        if n == 0:
            return
        last = slice(None) if self._prev_q is None else slice(max(0, n - 3), n)  # priming needs the first four
        q = quat.mul(q_seg[last], self.mount_quat)
        p = np.asarray(positions, dtype=float)[last] + quat.rotate(q_seg[last], self.mount_offsets)
        if self._prev_q is None:
            self._prime(q, p)
        self._prev_q, self._prev_p = q[-1:], np.concatenate((self._prev_p, p))[-3:]
        self._k += n

    def _prime(self, q, p) -> None:
        """History before the first sample: extrapolated back from the first block (cubic in position,
        constant rate in orientation) when it has 4 samples, else the IMUs were still."""
        if len(p) < 4:
            self._prev_q = q[:1]
            self._prev_p = np.repeat(p[:1], 3, axis=0)
            return
        hist = list(p[:4])
        for _ in range(3):
            hist.insert(0, 4.0 * hist[0] - 6.0 * hist[1] + 4.0 * hist[2] - hist[3])
        self._prev_p = np.stack(hist[:3])
        step = quat.mul(quat.conj(q[0]), q[1])
        self._prev_q = quat.mul(q[0], quat.conj(step))[None]

    def _empty(self) -> ImuBlock:
        z = np.zeros((0, N_IMUS, 3))
        return ImuBlock(np.zeros((0, N_IMUS, 7), np.int16), z, z, z, self.accel_offset, np.zeros((0, N_IMUS)))
