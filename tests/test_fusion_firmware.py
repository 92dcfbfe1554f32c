"""The host's complementary filter (recorder/fusion/complementary.py, its kernel recorder/fusion/kernels.py
``complementary_step``) against the firmware's C++ one (firmware/lib/glove_core/complementary_filter.cpp, built
here with cmake + g++), the two implementations of the thesis' filter: the same raw samples give the same
quaternions within 1e-5 per component. The C++ core computes in float32: the difference is rounding that
accumulates in the (uncorrected) heading, about 1e-5 after 3 s at 1 kHz or 60 s at 200 Hz."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from recorder.emulator.glove import SyntheticGlove
from recorder.fusion import filter_block, make_filter

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"


@pytest.fixture(scope="module")
def cli(tmp_path_factory) -> Path:
    if not (FIRMWARE / "CMakeLists.txt").exists():
        pytest.skip("no firmware/ tree")
    missing = [t for t in ("cmake", "g++") if shutil.which(t) is None]
    if missing:
        pytest.skip(f"needs {' and '.join(missing)} to build the firmware core")
    build = tmp_path_factory.mktemp("fw")
    for cmd in (
        ["cmake", "-S", str(FIRMWARE), "-B", str(build), "-DGLOVE_CHECK_ARDUINO_LAYER=OFF"],
        ["cmake", "--build", str(build), "-j", "2", "--target", "glove_core_cli"],
    ):
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return build / "glove_core_cli"


@pytest.mark.parametrize("rate, seconds", [(1000, 2.5), (200, 30.0)])
def test_complementary_filter_matches_the_firmware(cli, tmp_path, rate, seconds):
    T = int(rate * seconds)
    b = SyntheticGlove("gestures", rate, seed=3).next_block(T)
    accel = b.raw[..., 0:3].astype(float) * (16 / 32768.0)
    gyro = np.radians(b.raw[..., 3:6].astype(float) * (2000 / 32768.0))
    # the CLI's input: float32 gyro (rad/s) and accel (g) per IMU; it re-quantises to the same registers
    np.concatenate((gyro, accel), axis=2).astype("<f4").tofile(tmp_path / "samples.bin")
    done = subprocess.run(
        [
            str(cli),
            "run",
            "--calib-samples",
            "0",
            "--sense-rate",
            str(rate),
            "--trace",
            str(tmp_path / "trace.bin"),
            "--out",
            str(tmp_path / "out.bin"),
            str(tmp_path / "samples.bin"),
        ],
        capture_output=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr.decode()
    raw_trace = (tmp_path / "trace.bin").read_bytes()
    dtype = "<f4" if len(raw_trace) == T * 12 * 4 * 4 else "<f8"
    trace = np.frombuffer(raw_trace, dtype).reshape(T, 12, 4).astype(float)
    # the firmware without boot calibration: cycle 0 initialises from gravity (eq. 3.5-3.6), then filters
    f = make_filter("complementary")
    f.observe(accel[0])
    f.reset()
    ours = np.concatenate((f.q[None].copy(), filter_block(f, gyro[1:], accel[1:], 1.0 / rate)))
    ours = ours * np.sign(np.sum(ours * trace, axis=-1, keepdims=True))  # q and -q are one rotation
    assert np.abs(ours - trace).max() < 1e-5
    assert np.abs(ours[-1] - ours[0]).max() > 0.1  # the hand moved
