"""The compiled block API and host pipeline against the numpy reference."""

import time

import numpy as np
import pytest

from recorder.emulator.glove import SyntheticGlove
from recorder.fusion import FILTERS, FusionConfig, HostFusion, emulated, filter_block, kernels, make_filter

pytestmark = pytest.mark.skipif(not kernels.AVAILABLE, reason="numba is not installed")
RATE = 200


@pytest.fixture(scope="module")
def motion():
    b = SyntheticGlove("random", RATE, seed=11).next_block(1500)
    accel = b.raw[..., 0:3] * (16 / 32768.0)
    gyro = np.radians(b.raw[..., 3:6] * (2000 / 32768.0))
    rng = np.random.default_rng(0)
    mask = rng.random(accel.shape[:2]) > 0.05  # IMUs that miss a sample now and then
    dt = (1.0 + 0.2 * rng.standard_normal(accel.shape[:2])) / RATE  # jittery clocks
    return gyro, accel, mask, dt


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_numba_equals_numpy(name, motion):
    gyro, accel, mask, dt = motion
    ref, fast = make_filter(name), make_filter(name)
    for f in (ref, fast):
        f.observe(accel[0])
        f.reset(accel[0])
    a = filter_block(ref, gyro, accel, dt, mask, engine="numpy")
    half = len(gyro) // 2  # two calls: the state (median windows included) carries over
    b = np.concatenate(
        (
            filter_block(fast, gyro[:half], accel[:half], dt[:half], mask[:half], engine="numba"),
            filter_block(fast, gyro[half:], accel[half:], dt[half:], mask[half:], engine="numba"),
        )
    )
    np.testing.assert_allclose(b, a, atol=1e-9)
    for k, v in ref.state().items():
        np.testing.assert_allclose(fast.state()[k], v, atol=1e-9, err_msg=k)
    assert np.abs(a[-1] - a[0]).max() > 0.1  # the data did move the filters


def test_masks_as_bit_masks_and_scalar_dt(motion):
    gyro, accel, mask, _ = motion
    bits = (mask * (1 << np.arange(12))).sum(axis=1)
    f1, f2 = make_filter("complementary"), make_filter("complementary")
    a = filter_block(f1, gyro, accel, 1.0 / RATE, mask)
    b = filter_block(f2, gyro, accel, np.full(len(gyro), 1.0 / RATE), bits)
    np.testing.assert_array_equal(a, b)


def test_block_api_cost_per_12_imu_step(motion):
    """The goal is 2 µs per 12-IMU step (bench/fusion.py measures it); here a 10 µs bound that still fails
    for a non-compiled path (the numpy reference costs ~100 µs)."""
    gyro, accel, _, _ = motion
    g, a = np.tile(gyro, (4, 1, 1)), np.tile(accel, (4, 1, 1))
    for name in FILTERS:
        f = make_filter(name)
        f.reset(a[0])
        filter_block(f, g[:5], a[:5], 1.0 / RATE)  # compiled already: warm
        best = min(_timed(lambda f=f: filter_block(f, g, a, 1.0 / RATE)) for _ in range(3)) / len(g)
        assert best < 10e-6, (name, best)


def _timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_host_pipeline_numba_equals_numpy(name):
    glove = emulated.procedure_glove("gestures", RATE, seed=4)
    b = glove.next_block(int((emulated.START + 2.0) * RATE))
    t = np.round(np.arange(len(b.t)) * 1e6 / RATE).astype(np.int64)
    raw = b.raw.copy()
    ok = np.full(len(raw), 0xFFF)
    k1 = emulated.phase("rest", RATE).stop
    raw[k1 + 50 : k1 + 80, 5] = 0  # a dead IMU for a while
    ok[k1 + 100 : k1 + 120] &= ~(1 << 9)
    outs = []
    for engine in ("numpy", "numba"):
        hf = HostFusion(FusionConfig(filter=name, engine=engine, rate_hz=RATE))
        rec = {p: (raw[emulated.phase(p, RATE)], t[emulated.phase(p, RATE)]) for p in emulated.PHASES}
        hf.calibrate(rec["still"], rec["flex"], rec["tilt"])
        hf.start(rec["rest"])
        outs.append(hf.process_block(raw[k1:], t[k1:], ok[k1:]))
    for k in ("quats", "angles", "valid", "flags", "accel_error", "trust", "bias_change", "constraint", "heading"):
        np.testing.assert_allclose(getattr(outs[1], k), getattr(outs[0], k), atol=1e-9, err_msg=k)
    assert not outs[0].valid.all() and outs[0].flags.any()
