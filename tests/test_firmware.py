"""The glove firmware core (firmware/lib/glove_core), built on this machine, against the Python side.

Uses the core's host build (build/firmware, the conftest's fw_build: `make firmware` builds it and runs its ctest
suite on the host and on the emulated Cortex-M7, so the suite does not run ctest again), then checks across
languages: frames the C++ encoders write are byte-identical to recorder.protocol's and decode
exactly; the core's joint angles are recorder.hand.kinematics'; the C++ command decoder accepts what
recorder.protocol.encode_command sends; and the compiled glove ("firmware in the loop": synthetic IMU samples ->
tools/glove_core_cli run -> bytes, and recorder.emulator.firmware.FirmwareCore on the emulator's SyntheticGlove)
streams frames the StreamDecoder reads without a single error, with a filter that agrees with the numpy
reference below and a pose that agrees with the synthetic ground truth.
"""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
from pathlib import Path

import numpy as np

from recorder import quat
from recorder.emulator.firmware import FirmwareCore, RestThenMove
from recorder.emulator.glove import SyntheticGlove
from recorder.hand.kinematics import (
    LIMITS,
    REST,
    forward,
    joint_angles_from_relative,
    relative_from_angles,
    relative_quats,
)
from recorder.hand.motion import Motion
from recorder.hand.skeleton import JOINT_MAP, MEASURED_MASK, MUX_MAP, PARENTS
from recorder.protocol import (
    CommandCode,
    EventCode,
    EventFrame,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
    StreamDecoder,
    decode_frame,
    encode_command,
    encode_frame,
)
from recorder.protocol.frames import CLOCK_HOST_MONOTONIC, CalibState
from recorder.protocol.legacy_json import decode_line, encode_line

RATE = 1000  # Hz, sensing rate of the firmware-in-the-loop runs


# ------------------------------------------------------------------------------------------------ build


def cli(fw_build: Path, *args: str, stdin: bytes = b"") -> bytes:
    done = subprocess.run([str(fw_build / "glove_core_cli"), *args], input=stdin, capture_output=True, timeout=120)
    assert done.returncode == 0, done.stderr.decode()
    return done.stdout


# ------------------------------------------------------------------------------------------------ frames


def split_frames(wire: bytes) -> list[bytes]:
    assert wire.endswith(b"\x00")
    return [c for c in wire.split(b"\x00")[:-1]]


def test_pose_frames_are_byte_identical(fw_build):
    rng = np.random.default_rng(1)
    quats = rng.uniform(-1, 1, (300, 16, 4)).astype(np.float32)
    quats[0] = 0
    quats[0, :, 0] = 1
    quats[1, :4] = [
        [1, -1, 2, -2],
        [0.5 / 16384, 1.5 / 16384, 2.5 / 16384, -2.5 / 16384],  # ties: half to even
        [-0.0, 1e-9, -1e-9, 0.99999],
        [32767.6 / 16384, -32768.4 / 16384, 0.7071068, 0],
    ]
    frames = [PoseFrame(int(rng.integers(65536)), int(rng.integers(2**32)), q, int(rng.integers(65536))) for q in quats]
    records = b"".join(
        struct.pack("<HIH", f.seq, f.t_us, f.measured_mask) + f.quats.astype("<f4").tobytes() for f in frames
    )
    wire = cli(fw_build, "pose", stdin=records)
    assert wire == b"".join(encode_frame(f) for f in frames)
    for chunk, f in zip(split_frames(wire), frames, strict=True):
        assert len(chunk) + 1 == 144
        got = decode_frame(chunk)
        assert (got.seq, got.t_us, got.measured_mask) == (f.seq, f.t_us, f.measured_mask)
        expect = np.clip(np.rint(f.quats.astype(np.float64) * 16384), -32768, 32767) / 16384
        assert np.array_equal(got.quats, expect.astype(np.float32))


def test_pose_compact_frames_are_byte_identical(fw_build):
    rng = np.random.default_rng(5)
    palm = rng.uniform(-1, 1, (300, 4)).astype(np.float32)
    angles = rng.uniform(-3.7, 3.7, (300, 20)).astype(np.float32)  # beyond +-204.7 deg: saturated
    angles[0, :6] = np.radians([0.05, 0.15, -0.05, 204.7, -204.75, 0.0])  # ties, the range's ends
    angles[1, ::3] = np.nan  # "no value"
    frames = [PoseCompactFrame(k, int(rng.integers(2**32)), p, a) for k, (p, a) in enumerate(zip(palm, angles))]
    records = b"".join(
        struct.pack("<HI", f.seq, f.t_us) + f.palm_quat.astype("<f4").tobytes() + f.angles.astype("<f4").tobytes()
        for f in frames
    )
    wire = cli(fw_build, "compact", stdin=records)
    assert wire == b"".join(encode_frame(f) for f in frames)
    for chunk, f in zip(split_frames(wire), frames, strict=True):
        assert len(chunk) + 1 == 52
        got = decode_frame(chunk)
        ok = np.abs(f.angles) <= np.radians(204.7)
        assert np.all(np.abs(got.angles - f.angles)[ok] <= np.radians(0.05) + 1e-6)
        assert np.array_equal(np.isnan(got.angles), np.isnan(f.angles))


def test_joint_angles_are_kinematics_joint_angles(fw_build):
    """gc::joint_angles (what pose_compact frames carry) is kinematics.joint_angles_from_relative: same formula,
    REST thumb frame included; on model poses both return the angles the pose was made from."""
    rng = np.random.default_rng(6)
    angles = rng.uniform(LIMITS[:, 0], LIMITS[:, 1], (500, 20))
    rel = relative_quats(forward(angles, quat.normalize(rng.normal(size=(500, 4))))[0])
    rel[:100] = quat.normalize(rel[:100] + rng.normal(0, 0.2, (100, 16, 4)))  # not model poses: projected alike
    out = cli(fw_build, "angles", stdin=rel.astype("<f8").tobytes())
    got = np.frombuffer(out, "<f8").reshape(-1, 20)
    assert np.abs(got - joint_angles_from_relative(rel)).max() < 1e-12
    assert np.abs(got[100:] - angles[100:]).max() < 1e-9


def test_raw_status_and_event_frames_are_byte_identical(fw_build):
    rng = np.random.default_rng(2)
    raws, rec = [], b""
    for k in range(200):
        n = int(rng.integers(1, 17))
        data = rng.integers(-32768, 32768, (n, 7)).astype(np.int16)
        f = RawFrame(
            k * 7919 % 65536,
            int(rng.integers(2**32)),
            data,
            int(rng.choice([2, 4, 8, 16])),
            int(rng.choice([250, 500, 1000, 2000])),
            int(rng.integers(65536)),
        )
        padded = np.zeros((16, 7), "<i2")
        padded[:n] = data
        rec += struct.pack("<HIBBHH", f.seq, f.t_us, n, f.accel_fs_g, f.gyro_fs_dps, f.ok_mask) + padded.tobytes()
        raws.append(f)
    wire = cli(fw_build, "raw", stdin=rec)
    assert wire == b"".join(encode_frame(f) for f in raws)
    for chunk, f in zip(split_frames(wire), raws, strict=True):
        got = decode_frame(chunk)
        assert np.array_equal(got.data, f.data) and got.ok_mask == f.ok_mask and got.seq == f.seq

    statuses, rec = [], b""
    for k in range(100):
        n = int(rng.integers(0, 17))
        mux, joint = tuple(int(v) for v in rng.integers(0, 8, n)), tuple(int(v) for v in rng.integers(0, 16, n))
        f = StatusFrame(
            k,
            int(rng.integers(2**32)),
            tuple(int(v) for v in rng.integers(0, 256, 3)),
            Mode(int(rng.integers(3))),
            int(rng.integers(65536)),
            int(rng.integers(65536)),
            CalibState(int(rng.integers(4))),
            int(rng.integers(101)),
            int(rng.integers(2)),
            int(rng.integers(2**32)),
            int(rng.integers(65536)),
            mux,
            joint,
        )
        rec += struct.pack(
            "<HI3BBHHBBBIHB",
            f.seq,
            f.t_us,
            *f.firmware,
            f.mode,
            f.sense_rate_hz,
            f.output_rate_hz,
            f.calib_state,
            f.calib_progress,
            f.clock_flags,
            f.glove_id,
            f.imu_ok_mask,
            n,
        )
        rec += bytes(mux).ljust(16, b"\0") + bytes(joint).ljust(16, b"\0")
        statuses.append(f)
    wire = cli(fw_build, "status", stdin=rec)
    assert wire == b"".join(encode_frame(f) for f in statuses)
    assert [decode_frame(c) for c in split_frames(wire)] == statuses

    events = [
        EventFrame(i, i * 1000003 % 2**32, code, arg)
        for i, (code, arg) in enumerate((c, a) for c in EventCode for a in (0, 1, 11, 255))
    ]
    wire = cli(fw_build, "event", stdin=b"".join(struct.pack("<HIBB", e.seq, e.t_us, e.code, e.arg) for e in events))
    assert wire == b"".join(encode_frame(e) for e in events)
    assert [decode_frame(c) for c in split_frames(wire)] == events


def test_legacy_json_lines_decode_exactly(fw_build):
    rng = np.random.default_rng(3)
    quats = rng.normal(size=(200, 16, 4)).astype(np.float32)
    quats /= np.linalg.norm(quats, axis=2, keepdims=True)
    quats[0] = [1, 0, 0, 0]
    quats[1, :, 1] = [0.5e-6, 1.5e-6, 2.5e-6, -0.5e-6, 0.1234565, -0.9999995, 1e-7, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    out = cli(fw_build, "json", stdin=quats.astype("<f4").tobytes())
    lines = out.split(b"\n")
    assert lines[-1] == b"" and len(lines) == 201
    for line, q in zip(lines[:-1], quats, strict=True):
        obj = json.loads(line)
        assert set(obj) == {"wrists", "fingers"} and len(obj["fingers"]) == 5
        assert len(line) < 1300  # the thesis measured ~1200 bytes
        # C++ rounds the float value half-to-even to 6 decimals, as Python's round(): same numbers, same frame
        assert np.array_equal(decode_line(line).quats, decode_line(encode_line(q)).quats)
    assert lines[0].startswith(b'{"wrists":{"w":1,"x":0,"y":0,"z":0},"fingers":[{"joints":[{"w":1,')


def test_cpp_decodes_python_commands(fw_build):
    sent = [(CommandCode.SET_MODE, m) for m in (0, 1, 2, 3)] + [(CommandCode.SET_RATE, r) for r in (1, 200, 65535)]
    sent += [(CommandCode.RECALIBRATE, 0), (CommandCode.RESET_POSE, 0), (CommandCode.GET_STATUS, 0)]
    stream, expect = b"\x12\x34garbage\x00", ["reject"]
    for i, (code, arg) in enumerate(sent):
        wire = encode_command(code, arg, seq=1000 + i)
        stream += wire
        expect.append(f"{int(code)} {arg} {1000 + i} 0")
        bad = bytearray(wire)
        bad[3] ^= 0x40  # one flipped bit: CRC mismatch, must be rejected
        stream += bytes(bad)
        expect.append("reject")
    stream += encode_frame(EventFrame(1, 2, EventCode.BOOT))  # a valid frame, but not a command
    expect.append("reject")
    assert cli(fw_build, "command", stdin=stream).decode().split("\n")[:-1] == expect


# ---------------------------------------------------------------------------------- synthetic IMU data


def qmul(p, q):
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        -1,
    )


def conj(q):
    return q * np.array([1.0, -1, -1, -1])


def normalize(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotate(q, v):
    u = q[..., 1:]
    t = 2 * np.cross(u, v)
    return v + q[..., :1] * t + np.cross(u, t)


def synth_motion(seconds: float, n_imu: int = 12, seed: int = 0):
    """Smooth random body rates per IMU, the matching gravity, noise and bursts of linear acceleration.
    Returns gyro (rad/s) and accel (g), float32 arrays (T, n, 3), the format of glove_core_cli's input."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * RATE)) / RATE
    amp, freq, phase = rng.uniform(0.5, 3, (3, n_imu, 3)) * [[[1]], [[0.5]], [[2.1]]]
    gyro = amp * np.sin(2 * np.pi * freq * t[:, None, None] + phase)
    q = np.empty((len(t), n_imu, 4))
    q[0] = normalize(rng.normal(size=(n_imu, 4)))
    for k in range(1, len(t)):  # integrate the true attitude with the exact exponential of the mid rate
        w = 0.5 * (gyro[k - 1] + gyro[k]) / RATE
        ang = np.linalg.norm(w, axis=-1, keepdims=True)
        q[k] = normalize(
            qmul(q[k - 1], np.concatenate([np.cos(ang / 2), w / np.maximum(ang, 1e-12) * np.sin(ang / 2)], -1))
        )
    accel = rotate(conj(q), np.array([0, 0, 1.0])) + rng.normal(0, 0.01, q.shape[:2] + (3,))
    accel += (np.sin(2 * np.pi * 0.3 * t) > 0.8)[:, None, None] * np.array([0.15, -0.1, 0.05])  # e_m 0.1-0.2
    return gyro.astype(np.float32), accel.astype(np.float32)


def still(seconds: float, n_imu: int = 12, seed: int = 0):
    rng = np.random.default_rng(seed)
    shape = (int(seconds * RATE), n_imu, 3)
    gyro = np.array([0.02, -0.03, 0.01]) + rng.normal(0, 0.002, shape)  # a gyro bias plus noise
    accel = np.array([0, 0, 1.0]) + rng.normal(0, 0.005, shape)
    return gyro.astype(np.float32), accel.astype(np.float32)


def write_samples(path: Path, gyro, accel) -> Path:
    np.concatenate([gyro, accel], -1).astype("<f4").tofile(path)
    return path


def quantize(gyro, accel):
    """What the glove reads (MPU9250 counts at +-16 g, +-2000 dps; round half away from zero, as std::round)
    and the values the core fuses, counts * scale (firmware/lib/glove_core/imu_units.h)."""

    def counts(x):
        return np.clip(np.sign(x) * np.floor(np.abs(x) + 0.5), -32768, 32767)

    a = counts(accel.astype(np.float64) * 32768.0 / 16)
    g = counts(gyro.astype(np.float64) * (32768.0 / 2000) * (180.0 / math.pi))
    return g, a, g * (2000 * (0.017453292519943295 / 32768)), a * (16 / 32768)


# ------------------------------------------------------------------------------ numpy reference filter


def from_gravity(a):
    """Thesis eq. 3.5-3.6, yaw 0."""
    roll, pitch = np.arctan2(a[..., 1], a[..., 2]), np.arctan2(-a[..., 0], np.hypot(a[..., 1], a[..., 2]))
    cr, sr, cp, sp = np.cos(roll / 2), np.sin(roll / 2), np.cos(pitch / 2), np.sin(pitch / 2)
    return np.stack([cr * cp, sr * cp, cr * sp, -sr * sp], -1)


def reference_filter(gyro, accel, dt, tau=4.0, ramp=3.0):
    """The glove's filter (docs/fusion.md, "inertial") in float64: q = q_c q_g; q_g integrates the gyro (the
    exact exponential); the accelerometer in q_g's frame through three first-order low-passes of time constant
    tau, g = y3 + ramp (y2 - y3); q_c turns q_c g onto (0, 0, 1) by the shortest rotation, all of it. Cycle 0
    initialises from gravity (eq. 3.5-3.6)."""
    n = gyro.shape[1]
    out = np.empty(gyro.shape[:2] + (4,))
    qc = out[0] = from_gravity(accel[0])
    qg = np.tile([1.0, 0, 0, 0], (n, 1))
    y1, y2, y3 = accel[0].copy(), accel[0].copy(), accel[0].copy()
    k = min(dt / tau, 1.0)
    for t in range(1, len(gyro)):
        h = dt / 2 * gyro[t]
        ang = np.linalg.norm(h, axis=-1, keepdims=True)
        step = np.concatenate([np.cos(ang), h / np.maximum(ang, 1e-300) * np.sin(ang)], -1)
        qg = normalize(qmul(qg, np.where(ang > 0, step, [1.0, 0, 0, 0])))
        a = rotate(qg, accel[t])
        y1 = y1 + k * (a - y1)
        y2 = y2 + k * (y1 - y2)
        y3 = y3 + k * (y2 - y3)
        e = rotate(qc, y3 + ramp * (y2 - y3))
        e = e / np.linalg.norm(e, axis=-1, keepdims=True)
        dq = normalize(np.stack([1 + e[:, 2], e[:, 1], -e[:, 0], np.zeros(n)], -1))  # e -> (0, 0, 1)
        qc = normalize(qmul(dq, qc))
        out[t] = normalize(qmul(qc, qg))
    return out


def reference_pose(filt, ref, joint_map=JOINT_MAP, ratio=65 / 115):
    """16 parent-relative quaternions: eq. 3.21 q_ref^-1 q_est placed on the reference pose (the model's zero
    pose: kinematics.REST), then eq. 3.3 for the finger distal phalanges."""
    corr = np.tile([1.0, 0, 0, 0], filt.shape[:-2] + (16, 1))
    corr[..., list(joint_map), :] = qmul(conj(ref), filt)
    rel = np.empty_like(corr)
    for s in range(16):
        p = PARENTS[s]
        if s in joint_map:
            parent = corr[..., p, :] if p >= 0 else np.array([1.0, 0, 0, 0])
            rel[..., s, :] = normalize(qmul(qmul(conj(parent), REST[s]), corr[..., s, :]))
            continue
        between = qmul(conj(corr[..., s - 2, :]), corr[..., s - 1, :])
        sign = np.where(between[..., 0] < 0, -1.0, 1.0)
        alpha = 2 * np.arctan2(between[..., 2] * sign, between[..., 0] * sign)  # twist about the flexion axis y
        beta = np.where(alpha > 0, ratio * alpha, 0.0)
        rel[..., s, :] = np.stack([np.cos(beta / 2), 0 * beta, np.sin(beta / 2), 0 * beta], -1)
        corr[..., s, :] = qmul(corr[..., p, :], rel[..., s, :])
    return rel


# --------------------------------------------------------------------------------- firmware in the loop


def run_glove(fw_build, tmp_path, gyro, accel, *args, name="run") -> bytes:
    samples = write_samples(tmp_path / f"{name}.bin", gyro, accel)
    return cli(fw_build, "run", "--sense-rate", str(RATE), *args, str(samples))


def decode_stream(wire: bytes, protocol: str = "auto"):
    dec = StreamDecoder(protocol)
    frames = dec.feed(wire)
    return frames, dec.stats


def test_boot_calibration_and_pose_stream(fw_build, tmp_path):
    gyro, accel = still(1.5)
    frames, stats = decode_stream(
        run_glove(fw_build, tmp_path, gyro, accel, "--output-rate", "100", "--glove-id", "0xC0FFEE")
    )
    assert stats.errors == 0 and stats.gaps == 0 and stats.skipped_bytes == 0
    assert [f.seq for f in frames] == list(range(len(frames)))
    events = [f.code for f in frames if isinstance(f, EventFrame)]
    assert events == [EventCode.BOOT, EventCode.CALIB_START, EventCode.CALIB_DONE, EventCode.POSE_RESET]
    status = [f for f in frames if isinstance(f, StatusFrame)]
    assert status[0].calib_state == CalibState.RUNNING and status[-1].calib_state == CalibState.DONE
    assert status[-1].glove_id == 0xC0FFEE and status[-1].imu_ok_mask == 0xFFF
    assert status[-1].mux_map == MUX_MAP and status[-1].joint_map == JOINT_MAP
    assert (status[-1].sense_rate_hz, status[-1].output_rate_hz, status[-1].mode) == (RATE, 100, Mode.POSE)
    poses = [f for f in frames if isinstance(f, PoseFrame)]
    # calibration ends in cycle 255 (t = 256 ms); then a frame every 10 ms on the 100 Hz grid
    assert [p.t_us for p in poses] == list(range(260000, 1500001, 10000))
    assert all(p.measured_mask == MEASURED_MASK for p in poses)
    assert max(np.abs(p.quats - REST).max() for p in poses) < 2e-3  # a still hand stays in its reference pose


def test_filter_matches_numpy_reference_over_10s(fw_build, tmp_path):
    """The issue's criterion: the compiled core and a Python reference agree within 1e-5 per quaternion
    component over 10 s (1 kHz, 12 IMUs, rates up to ~6 rad/s, linear-acceleration bursts)."""
    gyro, accel = synth_motion(10.0)
    wire = run_glove(
        fw_build,
        tmp_path,
        gyro,
        accel,
        "--calib-samples",
        "0",
        "--output-rate",
        "50",
        "--trace",
        str(tmp_path / "trace.bin"),
        "--trace-pose",
        str(tmp_path / "pose.bin"),
    )
    T = len(gyro)
    trace = np.fromfile(tmp_path / "trace.bin", "<f8").reshape(T, 12, 4)
    _, _, g, a = quantize(gyro, accel)
    ref = reference_filter(g, a, dt=1000 * 1e-6)
    assert np.abs(trace - ref).max() < 1e-5
    assert np.abs(trace - ref).max() < 1e-9  # in fact: the double core follows the reference to rounding

    # hand model: reference-pose correction, distal interpolation and parent-relative conversion
    pose_ref = reference_pose(ref, ref[0])
    pose_cpp = np.fromfile(tmp_path / "pose.bin", "<f8").reshape(T, 16, 4)
    assert np.abs(pose_cpp - pose_ref).max() < 1e-9
    frames, stats = decode_stream(wire)
    assert stats.errors == 0 and stats.gaps == 0
    poses = [f for f in frames if isinstance(f, PoseFrame)]
    assert len(poses) == 501  # cycle 0, then every 20 ms
    cycles = [(p.t_us // 1000) - 1 for p in poses]  # t_us = (k + 1) ms for cycle k
    got = np.stack([p.quats for p in poses])
    assert np.abs(got - pose_ref[cycles]).max() <= 0.5 / 16384 + 1e-9  # Q14 rounding only
    distal = got[:, [6, 9, 12, 15]]
    assert (np.abs(distal[..., 2]) > 0.05).any()  # the interpolated phalanges did bend


def test_raw_mode_sends_the_counts_read(fw_build, tmp_path):
    gyro, accel = synth_motion(0.5, seed=4)
    frames, stats = decode_stream(
        run_glove(fw_build, tmp_path, gyro, accel, "--mode", "raw", "--output-rate", "1000", "--calib-samples", "0")
    )
    assert stats.errors == 0 and stats.gaps == 0
    raws = [f for f in frames if isinstance(f, RawFrame)]
    assert len(raws) == len(gyro)
    gc, ac, _, _ = quantize(gyro, accel)
    data = np.stack([r.data for r in raws])
    assert np.array_equal(data[..., :3], ac) and np.array_equal(data[..., 3:6], gc)
    assert (data[..., 6] == round(4 * 333.87)).all()  # 25 degC
    assert np.allclose(raws[10].accel_g, accel[10], atol=1e-3) and raws[0].ok_mask == 0xFFF


def test_commands_button_and_faults_in_the_loop(fw_build, tmp_path):
    gyro, accel = still(3.0)
    gyro[1500:1800, 3] = np.nan  # IMU 3 stops answering for 300 ms
    rx = [
        (300, encode_command(CommandCode.SET_MODE, Mode.RAW)),
        (400, encode_command(CommandCode.SET_RATE, 20)),
        (500, encode_command(CommandCode.SET_RATE, 5000)),  # above the sense rate: ignored
        (600, bytes([1, 2, 3, 0])),  # garbage: ignored
        (700, encode_command(CommandCode.SET_MODE, Mode.POSE)),
        (800, encode_command(CommandCode.RESET_POSE)),
        (900, encode_command(CommandCode.GET_STATUS)),
        (1600, encode_command(CommandCode.GET_STATUS)),
        (2000, encode_command(CommandCode.RECALIBRATE)),
    ]
    (tmp_path / "rx.bin").write_bytes(b"".join(struct.pack("<IH", k, len(b)) + b for k, b in rx))
    frames, stats = decode_stream(
        run_glove(
            fw_build,
            tmp_path,
            gyro,
            accel,
            "--rx",
            str(tmp_path / "rx.bin"),
            "--button",
            "1000",
            "--output-rate",
            "100",
        )
    )
    assert stats.errors == 0 and stats.gaps == 0

    def at(kind, lo, hi):  # frames of a kind sent during cycles lo..hi (t_us = (k + 1) ms)
        return [f for f in frames if isinstance(f, kind) and lo <= f.t_us // 1000 - 1 <= hi]

    answered = sorted({f.t_us // 1000 - 1 for f in frames if isinstance(f, StatusFrame)} & {k for k, _ in rx})
    assert answered == [300, 400, 700, 800, 900, 1600, 2000]  # every valid command, nothing else
    assert at(StatusFrame, 300, 300)[0].mode == Mode.RAW
    assert at(StatusFrame, 400, 400)[0].output_rate_hz == 20
    assert len(at(RawFrame, 300, 399)) == 10 and len(at(RawFrame, 400, 699)) == 6  # 100 Hz, then 20 Hz
    assert len(at(PoseFrame, 700, 999)) == 6 and not at(RawFrame, 700, 2999)
    events = [(f.t_us // 1000 - 1, f.code, f.arg) for f in frames if isinstance(f, EventFrame)]
    assert (800, EventCode.POSE_RESET, 0) in events
    assert (1000, EventCode.BUTTON, 0) in events and (1000, EventCode.POSE_RESET, 0) in events
    assert (1500, EventCode.IMU_FAULT, 3) in events and (1800, EventCode.IMU_RECOVERED, 3) in events
    assert at(StatusFrame, 1600, 1600)[0].imu_ok_mask == 0xFFF & ~(1 << 3)
    assert at(StatusFrame, 2000, 2000)[0].calib_state == CalibState.RUNNING
    assert (2000, EventCode.CALIB_START, 0) in events and (2255, EventCode.CALIB_DONE, 0) in events
    assert not at(PoseFrame, 2000, 2255) and at(PoseFrame, 2256, 2999)  # no pose while recalibrating


def test_calibration_refused_while_the_hand_moves(fw_build, tmp_path):
    gyro, accel = still(2.0)
    moving, _ = synth_motion(0.5, seed=5)
    gyro[100:600] += moving  # the hand moves during the boot calibration, then rests
    ask = encode_command(CommandCode.GET_STATUS)
    (tmp_path / "rx.bin").write_bytes(struct.pack("<IH", 300, len(ask)) + ask)
    frames, stats = decode_stream(run_glove(fw_build, tmp_path, gyro, accel, "--rx", str(tmp_path / "rx.bin")))
    assert stats.errors == 0
    events = [(f.t_us // 1000 - 1, f.code) for f in frames if isinstance(f, EventFrame)]
    refused = [k for k, c in events if c == EventCode.CALIB_REFUSED]
    assert refused and all(100 <= k < 600 for k in refused)
    done = [k for k, c in events if c == EventCode.CALIB_DONE]
    assert len(done) == 1 and 600 + 255 <= done[0] < 600 + 256 + 10  # a full window after the motion
    asked = [f for f in frames if isinstance(f, StatusFrame) and f.t_us == 301000]
    assert asked[0].calib_state == CalibState.REFUSED and asked[0].calib_progress < 20


def test_json_mode_streams_legacy_lines(fw_build, tmp_path):
    gyro, accel = synth_motion(1.0, seed=6)
    common = ("--calib-samples", "0", "--output-rate", "30")
    lines, stats = decode_stream(run_glove(fw_build, tmp_path, gyro, accel, "--mode", "json", *common, name="j"))
    binary, _ = decode_stream(run_glove(fw_build, tmp_path, gyro, accel, *common, name="b"))
    poses = [f for f in binary if isinstance(f, PoseFrame)]
    assert stats.errors == 0 and stats.skipped_bytes == 0  # the auto decoder locked onto JSON at once
    assert len(lines) == len(poses) == 31 and all(isinstance(f, PoseFrame) and f.t_us == -1 for f in lines)
    for line, pose in zip(lines, poses):
        assert np.abs(line.quats - pose.quats).max() < 1e-4  # 6 decimals vs Q14


def test_live_mode_runs_the_core_as_emulator_firmware(fw_build, tmp_path):
    """Samples streamed on stdin, frames flushed every cycle, host commands through a FIFO while it runs."""
    fifo = tmp_path / "rx.fifo"
    os.mkfifo(fifo)
    gyro, accel = still(0.2)
    blob = np.concatenate([gyro, accel], -1).astype("<f4")
    proc = subprocess.Popen(
        [
            str(fw_build / "glove_core_cli"),
            "run",
            "--live",
            "--rx-fifo",
            str(fifo),
            "--sense-rate",
            str(RATE),
            "--output-rate",
            str(RATE),
            "--calib-samples",
            "0",
            "-",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
    )
    try:
        dec, frames = StreamDecoder(), []
        proc.stdin.write(blob[:100].tobytes())
        proc.stdin.flush()
        while not any(isinstance(f, PoseFrame) and f.t_us == 100_000 for f in frames):  # cycle 99 is out
            chunk = os.read(proc.stdout.fileno(), 65536)
            assert chunk, "glove_core_cli ended early"
            frames += dec.feed(chunk)
        with open(fifo, "wb") as rx:  # the glove is waiting for sample 100: the command lands in cycle 100
            rx.write(encode_command(CommandCode.SET_MODE, Mode.RAW))
        proc.stdin.write(blob[100:].tobytes())
        proc.stdin.close()
        frames += dec.feed(proc.stdout.read())
    finally:
        proc.wait(timeout=30)
    assert proc.returncode == 0 and dec.stats.errors == 0 and dec.stats.gaps == 0
    answer = [f for f in frames if isinstance(f, StatusFrame) and f.mode == Mode.RAW]
    assert answer and answer[0].t_us == 101_000
    assert {f.t_us for f in frames if isinstance(f, RawFrame)} == set(range(101_000, 200_001, 1000))
    assert {f.t_us for f in frames if isinstance(f, PoseFrame)} == set(range(1000, 100_001, 1000))


def test_firmware_core_serves_the_synthetic_glove(fw_build):
    """recorder.emulator.firmware.FirmwareCore, as `gloverec emulate --firmware` uses it: SyntheticGlove register
    counts in, one feed() per sensing cycle with a host-clock t_us (wrapping at 2^32 during the run), bytes out,
    a command in mid-run. The hand rests flat for 0.6 s (the core calibrates its gyros: the synthetic ones have
    +-5 dps of bias), then moves. The accelerometer offsets are zeroed: the core has no accelerometer
    calibration, and their +-60 mg tilt each IMU by up to 3.4 deg (the pose error then reaches ~10 deg)."""
    glove = SyntheticGlove(RestThenMove(Motion("gestures", seed=2, rate_hz=RATE), 0.6, 0.6), rate_hz=RATE, seed=2)
    glove.imus.accel_offset[:] = 0.0
    block = glove.next_block(4 * RATE)
    t0 = 2**32 - 2_000_000  # the device clock wraps 2 s in
    dec, frames = StreamDecoder("binary"), []
    with FirmwareCore(fw_build / "glove_core_cli", sense_hz=RATE, output_hz=100) as core:
        for k in range(len(block.t)):
            if k == 3000:
                core.send(encode_command(CommandCode.SET_MODE, Mode.COMPACT))
            core.feed(block.raw[k], block.accel_fs_g, block.gyro_fs_dps, t_us=(t0 + 1000 * k) % 2**32)
            frames += dec.feed(core.read())
        assert core.close() == 0
    assert dec.stats.errors == 0 and dec.stats.gaps == 0 and dec.stats.skipped_bytes == 0

    def cycle(f):
        return (f.t_us - t0) % 2**32 // 1000

    events = [(cycle(f), f.code) for f in frames if isinstance(f, EventFrame)]
    assert events == [
        (0, EventCode.BOOT),
        (0, EventCode.CALIB_START),
        (255, EventCode.CALIB_DONE),
        (255, EventCode.POSE_RESET),
    ]
    status = [f for f in frames if isinstance(f, StatusFrame)]
    assert all(f.clock_flags == CLOCK_HOST_MONOTONIC for f in status)
    assert [cycle(f) for f in status if f.mode == Mode.COMPACT][0] == 3000  # the command's answer
    poses = [f for f in frames if isinstance(f, PoseFrame)]
    compact = [f for f in frames if isinstance(f, PoseCompactFrame)]
    assert [cycle(f) for f in poses] == list(range(260, 3000, 10))  # 100 Hz once the reference pose is taken
    assert [cycle(f) for f in compact] == list(range(3000, 4000, 10))

    # against the ground truth: every segment but the palm (whose heading the filter cannot know)
    k = np.array([cycle(f) for f in poses + compact])
    compact_quats = [relative_from_angles(f.angles, f.palm_quat) for f in compact]
    got = np.concatenate([np.stack([f.quats for f in poses]), np.stack(compact_quats)])
    err = np.degrees(quat.angle_between(got, block.truth_rel[k]))[:, 1:]
    # observed: rms 0.9 deg, 99th percentile 3.2 deg, max 8.6 deg (fast gesture transitions)
    assert np.sqrt(np.mean(err**2)) < 2.0 and np.percentile(err, 99) < 6.0, (err.mean(0), err.max(0))
