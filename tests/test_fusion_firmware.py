"""The glove's filter on both sides: the firmware's C++ core (firmware/lib/glove_core/complementary_filter.cpp,
FilterMode::Inertial, the host build of `make firmware`, run by glove_core_cli) and its Python twin (recorder/fusion/
inertial.py, inertial_step) give the same bits from the same register counts, dropped samples included.
And on two real recordings with optical truth (BROAD trials 16, fast translation, and 30, the worst trial of
every filter measured in bench/fusion_real.py) the host's default fusion, as a recording runs it, and the glove's
core stay within docs/fusion.md's bounds against VQF (PyPI ``vqf``, by the dataset's authors) run here."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from recorder.emulator.glove import SyntheticGlove
from recorder.fusion import FusionConfig, make_filter
from recorder.fusion.truth import G, host_palm, load_trial, orientation_errors, registers, stamped_samples

REPO = Path(__file__).resolve().parents[1]
BROAD = REPO.parent / "shared" / "data" / "broad"
GYRO_SCALE, ACCEL_SCALE = 2000 * (0.017453292519943295 / 32768), 16 / 32768  # imu_units.h, as the core


@pytest.fixture(scope="module")
def cli(fw_build) -> Path:
    """glove_core_cli of the core's host build (the conftest's fw_build: what `make firmware` built)."""
    return fw_build / "glove_core_cli"


def run_core(cli: Path, tmp: Path, gyro, accel_g, t_us, *options) -> np.ndarray:
    """glove_core_cli run --stamped on 12 IMUs (gyro, accel (T, 12, 3) or (T, 3): then on every IMU); returns
    every IMU's filter quaternion after every cycle (T, 12, 4)."""
    samples = tmp / "samples.bin"
    if np.ndim(gyro) == 2:
        samples.write_bytes(stamped_samples(gyro, accel_g, t_us))
    else:
        rec = np.zeros(len(gyro), [("t", "<u4"), ("flags", "u1"), ("imu", "<f4", (12, 6))])
        rec["t"], rec["imu"] = t_us, np.concatenate((gyro, accel_g), axis=2)
        samples.write_bytes(rec.tobytes())
    done = subprocess.run(
        [str(cli), "run", "--stamped", "--trace", str(tmp / "trace.bin"), "--out", str(tmp / "out.bin"), *options]
        + [str(samples)],
        capture_output=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr.decode()
    return np.fromfile(tmp / "trace.bin", "<f8").reshape(len(gyro), 12, 4)


def twin(gyro_counts, accel_counts, t_us, ok, name: str = "inertial") -> np.ndarray:
    """The Python twin as the glove runs it without a boot calibration (glove.cpp ``sense``): cycle 0 observes
    and resets from gravity; then every IMU that answered is filtered with dt = its own time since it last
    answered (u32 us * 1e-6, at most 0.05 s)."""
    g = gyro_counts * GYRO_SCALE
    a = accel_counts * ACCEL_SCALE
    f = make_filter(name)
    out = np.empty(g.shape[:2] + (4,))
    f.observe(a[0], ok[0])
    f.reset(None, ok[0])
    out[0] = f.q
    last = np.where(ok[0], t_us[0], -1)
    for k in range(1, len(g)):
        dt = np.where(last >= 0, ((t_us[k] - last) & 0xFFFFFFFF).astype(float) * 1e-6, 0.01)
        f.update(g[k], a[k], np.minimum(dt, 0.05), ok[k])
        out[k] = f.q
        last = np.where(ok[k], t_us[k], last)
    return out


def counts(x, scale) -> np.ndarray:
    return np.clip(np.sign(x) * np.floor(np.abs(x) / scale + 0.5), -32768, 32767)


@pytest.mark.parametrize("rate, seconds", [(1000, 2.5), (200, 20.0)])
def test_inertial_filter_matches_the_firmware_bit_for_bit(cli, tmp_path, rate, seconds):
    T = int(rate * seconds)
    b = SyntheticGlove("gestures", rate, seed=3).next_block(T)
    accel = b.raw[..., 0:3].astype(float) * ACCEL_SCALE
    gyro = b.raw[..., 3:6].astype(float) * GYRO_SCALE
    gyro[T // 3 : T // 3 + rate // 5, 4] = np.nan  # IMU 4 does not answer for 200 ms
    t_us = np.round(np.arange(1, T + 1) * 1e6 / rate).astype(np.int64)
    trace = run_core(cli, tmp_path, gyro, accel, t_us, "--calib-samples", "0", "--sense-rate", str(rate))
    ok = np.all(np.isfinite(gyro), axis=2)
    ours = twin(counts(np.nan_to_num(gyro), GYRO_SCALE), counts(accel, ACCEL_SCALE), t_us, ok)
    assert np.array_equal(ours, trace)  # the same bits, not just close
    assert np.abs(ours[-1] - ours[0]).max() > 0.1  # the hand moved
    held = slice(T // 3, T // 3 + rate // 5)
    assert np.array_equal(trace[held, 4], np.repeat(trace[T // 3 - 1 : T // 3, 4], rate // 5, axis=0))


def test_thesis_filter_matches_the_firmware(cli, tmp_path):
    """The thesis' filter (FilterMode::Thesis, --filter thesis) against recorder/fusion/complementary.py: the same
    algorithm to rounding (atan2, sin and cos in the reset come from two libms)."""
    rate, T = 200, 4000
    b = SyntheticGlove("gestures", rate, seed=4).next_block(T)
    accel = b.raw[..., 0:3].astype(float) * ACCEL_SCALE
    gyro = b.raw[..., 3:6].astype(float) * GYRO_SCALE
    gyro[T // 2 : T // 2 + 40, 7] = np.nan  # IMU 7 does not answer for 200 ms
    t_us = np.round(np.arange(1, T + 1) * 1e6 / rate).astype(np.int64)
    trace = run_core(cli, tmp_path, gyro, accel, t_us, "--calib-samples", "0", "--sense-rate", str(rate),
                     "--filter", "thesis")  # fmt: skip
    ok = np.all(np.isfinite(gyro), axis=2)
    ours = twin(counts(np.nan_to_num(gyro), GYRO_SCALE), counts(accel, ACCEL_SCALE), t_us, ok, "complementary")
    ours = ours * np.sign(np.sum(ours * trace, axis=-1, keepdims=True))  # q and -q are one rotation
    assert np.abs(ours - trace).max() < 1e-9
    assert np.abs(ours[-1] - ours[0]).max() > 0.1  # the hand moved
    inertial = run_core(cli, tmp_path, gyro, accel, t_us, "--calib-samples", "0", "--sense-rate", str(rate))
    assert np.abs(inertial - trace).max() > 1e-3  # the option did select another filter


@pytest.fixture(scope="module")
def trials():
    assert BROAD.is_dir(), f"the BROAD trials are expected in {BROAD} (README there)"
    return [load_trial(BROAD / name) for name in ("16_undisturbed_fast_translation_B.hdf5",
                                                  "30_disturbed_stationary_magnet_C.hdf5")]  # fmt: skip


def test_real_recordings_host_and_glove_within_bounds_of_vqf(cli, tmp_path, trials):
    from vqf import VQF

    rmse = {"vqf": [], "host": [], "glove": []}
    for tr in trials:
        accel_g = tr.accel / G
        v = VQF(1.0 / tr.rate).updateBatch(np.ascontiguousarray(tr.gyro), np.ascontiguousarray(tr.accel))
        rmse["vqf"].append(orientation_errors(v["quat6D"], tr.truth, tr.movement, tr.rate)["inclination_rmse_deg"])
        palm, _ = host_palm(FusionConfig(), registers(tr.gyro, accel_g), tr.t_us)
        rmse["host"].append(orientation_errors(palm, tr.truth, tr.movement, tr.rate)["inclination_rmse_deg"])
        # the glove as it boots: gyro calibration over its first 256 samples (the hand rests), then pose mode
        core = run_core(cli, tmp_path, tr.gyro, accel_g, tr.t_us, "--sense-rate", "286", "--output-rate", "50")
        rmse["glove"].append(orientation_errors(core[:, 0], tr.truth, tr.movement, tr.rate)["inclination_rmse_deg"])
    vqf, host, glove = (np.array(rmse[k]) for k in ("vqf", "host", "glove"))
    assert host.mean() <= vqf.mean() and host.max() <= vqf.max(), rmse
    assert glove.mean() <= 1.5 * vqf.mean(), rmse
    assert (host <= 3 * host.mean()).all() and (glove <= 3 * glove.mean()).all()
    # what the same host fusion gave before (mahony with its trust gate): bounds that can fail
    old, _ = host_palm(FusionConfig(filter="mahony"), registers(trials[1].gyro, trials[1].accel / G), trials[1].t_us)
    assert orientation_errors(old, trials[1].truth, trials[1].movement, trials[1].rate)["inclination_rmse_deg"] > 3
