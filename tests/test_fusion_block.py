"""The live path and the block path run the same kernels: ``update`` sample by sample equals ``filter_block``, and
``HostFusion.process`` frame by frame equals ``HostFusion.process_block``, exactly, with the state carried over
uneven blocks, dropped samples and dead IMUs, dt per IMU, and the device clock wrapping around."""

import copy
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from recorder.emulator import procedure as emulated
from recorder.emulator.glove import SyntheticGlove
from recorder.fusion import FusionConfig, HostFusion, filter_block, filter_names, make_filter
from recorder.protocol.frames import RawFrame

RATE = 200
SPLITS = (0, 1, 2, 2, 97, 98, 700, 1201, 1500)  # uneven blocks: single samples, an empty one, long ones
DEAD = 5  # an IMU that does not answer for a while


@pytest.fixture(scope="module")
def motion():
    b = SyntheticGlove("random", RATE, seed=11).next_block(SPLITS[-1])
    accel = b.raw[..., 0:3] * (16 / 32768.0)
    gyro = np.radians(b.raw[..., 3:6] * (2000 / 32768.0))
    rng = np.random.default_rng(0)
    mask = rng.random(accel.shape[:2]) > 0.05  # IMUs that miss a sample now and then
    mask[300:700, DEAD] = False
    dt = (1.0 + 0.2 * rng.standard_normal(accel.shape[:2])) / RATE  # jittery clocks, one per IMU
    return gyro, accel, mask, dt


def started_filter(name, accel):
    f = make_filter(name)
    f.observe(accel[0])
    f.reset(accel[0])
    return f


@pytest.mark.parametrize("name", sorted(filter_names()))
def test_update_sample_by_sample_equals_filter_block(name, motion):
    gyro, accel, mask, dt = motion
    live, block = started_filter(name, accel), started_filter(name, accel)
    a = np.stack([live.update(gyro[k], accel[k], dt[k], mask[k]).copy() for k in range(len(gyro))])
    b = np.concatenate(
        [filter_block(block, gyro[i:j], accel[i:j], dt[i:j], mask[i:j]) for i, j in zip(SPLITS, SPLITS[1:])]
    )
    np.testing.assert_array_equal(b, a)
    for k, v in live.state().items():
        np.testing.assert_array_equal(block.state()[k], v, err_msg=k)
    assert np.abs(a[-1] - a[0]).max() > 0.1  # the data did move the filters
    if name != "relative":  # (a relative child's q follows its parent)
        np.testing.assert_array_equal(a[300:700, DEAD], a[299:699, DEAD])  # the dead IMU held its state


@pytest.mark.parametrize("name", sorted(filter_names()))
def test_state_and_load_state_carry_a_filter_over(name, motion):
    """A checkpoint (``state``) loaded into a new filter continues exactly where the old one stopped (the
    complementary filter's median windows, the relative filter's pairs and roots included)."""
    gyro, accel, mask, dt = motion
    whole = started_filter(name, accel)
    a = filter_block(whole, gyro, accel, dt, mask)
    first = started_filter(name, accel)
    filter_block(first, gyro[:503], accel[:503], dt[:503], mask[:503])
    second = make_filter(name)
    second.load_state(first.state())
    np.testing.assert_array_equal(filter_block(second, gyro[503:], accel[503:], dt[503:], mask[503:]), a[503:])


def test_masks_as_bit_masks_and_scalar_dt(motion):
    gyro, accel, mask, _ = motion
    bits = (mask * (1 << np.arange(12))).sum(axis=1)
    f1, f2 = make_filter("complementary"), make_filter("complementary")
    a = filter_block(f1, gyro, accel, 1.0 / RATE, mask)
    b = filter_block(f2, gyro, accel, np.full(len(gyro), 1.0 / RATE), bits)
    np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------------------------------------ HostFusion
@pytest.fixture(scope="module")
def recording():
    """The calibration procedure, then 3 s of gestures from the end of its rest step, with bad input: IMU 7
    answers only from frame 20 on (its first sample initialises it mid-block), IMU 5 dead (zeros) for a while,
    IMU 9 missing, IMU 10 stuck; jittery device times that wrap around the u32 clock at frame 300."""
    glove = emulated.procedure_glove("gestures", RATE, seed=4)
    b = glove.next_block(int((emulated.START + 3.0) * RATE))
    t = np.round(np.arange(len(b.t)) * 1e6 / RATE).astype(np.int64)
    rec = {p: (b.raw[emulated.phase(p, RATE)], t[emulated.phase(p, RATE)]) for p in emulated.PHASES}
    hf = HostFusion(FusionConfig(rate_hz=RATE))
    calibration = hf.calibrate(rec["still"], rec["flex"], rec["tilt"])
    raw = b.raw[emulated.phase("rest", RATE).stop :].copy()
    T = len(raw)
    ok = np.full(T, 0xFFF)
    ok[:20] &= ~(1 << 7)
    raw[250:280, DEAD] = 0
    ok[400:420] &= ~(1 << 9)
    raw[500:520, 10, :6] = raw[500, 10, :6]
    steps = np.round(5000 + 400 * np.random.default_rng(3).standard_normal(T)).astype(np.int64)
    t_long = 2**32 - 1 - int(np.sum(steps[:300])) + np.cumsum(steps)  # frame 299: 2^32 - 1 µs, 300: past it
    return calibration, raw, t_long, ok


def _fusion(name, calibration):
    return HostFusion(FusionConfig(filter=name, rate_hz=RATE), copy.deepcopy(calibration))


FIELDS = ("quats", "angles", "valid", "flags", "accel_error", "trust", "bias_change", "constraint", "heading")


@pytest.mark.parametrize("name", sorted(filter_names()))
def test_process_frame_by_frame_equals_process_block(name, recording):
    calibration, raw, t_long, ok = recording
    t = t_long & 0xFFFFFFFF  # what the glove sends
    assert t[300] < t[299]
    whole = _fusion(name, calibration).process_block(raw, t, ok)
    hf = _fusion(name, calibration)
    live = [hf.process(RawFrame(seq=k, t_us=int(t[k]), data=raw[k], ok_mask=int(ok[k]))) for k in range(len(raw))]
    hf = _fusion(name, calibration)
    cut = (0, 1, 20, 21, 150, 299, 301, 512, len(raw))
    blocks = [hf.process_block(raw[i:j], t[i:j], ok[i:j]) for i, j in zip(cut, cut[1:])]
    unwrapped = _fusion(name, calibration).process_block(raw, t_long, ok)  # the same dt: the clock is u32
    for k in FIELDS:
        ref = getattr(whole, k)
        frames = np.stack([getattr(f, k) if hasattr(f, k) else f.detail[k] for f in live])
        np.testing.assert_array_equal(frames, ref, err_msg=f"process: {k}")
        np.testing.assert_array_equal(np.concatenate([getattr(b, k) for b in blocks]), ref, err_msg=f"blocks: {k}")
        np.testing.assert_array_equal(getattr(unwrapped, k), ref, err_msg=f"unwrapped: {k}")
    flags = whole.flags
    assert flags[:20, 7].all() and not flags[20:, 7].any() and flags[250:280, DEAD].all()
    assert flags[400:420, 9].all() and flags[515, 10] and not whole.valid.all()
    assert np.all(np.isfinite(whole.angles)) and np.abs(whole.angles[-1] - whole.angles[0]).max() > 0.3


PLAIN = """
import sys
import numpy as np
from recorder.fusion import HostFusion, filter_block, filter_names, make_filter, mahony
assert not hasattr(mahony.mahony_step, "py_func")  # not compiled
d = np.load(sys.argv[1])
out = {}
for name in filter_names():
    f = make_filter(name)
    f.reset(d["accel"][0])
    out[name] = filter_block(f, d["gyro"], d["accel"], d["dt"], d["mask"])
out["host"] = HostFusion().process_block(d["raw"], d["t"], d["ok"]).quats
np.savez(sys.argv[2], **out)
"""


@pytest.mark.process
def test_the_kernels_run_as_plain_python(motion, recording, tmp_path):
    """NUMBA_DISABLE_JIT=1 (for a debugger) runs the same code uncompiled, with the same results."""
    gyro, accel, mask, dt = (x[:40] for x in motion)
    _, raw, t_long, ok = recording
    np.savez(tmp_path / "in.npz", gyro=gyro, accel=accel, mask=mask, dt=dt, raw=raw[:25], t=t_long[:25], ok=ok[:25])
    done = subprocess.run(
        [sys.executable, "-c", PLAIN, str(tmp_path / "in.npz"), str(tmp_path / "out.npz")],
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"},
        cwd=Path(__file__).resolve().parents[1],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    plain = np.load(tmp_path / "out.npz")
    for name in filter_names():
        f = make_filter(name)
        f.reset(accel[0])
        np.testing.assert_allclose(plain[name], filter_block(f, gyro, accel, dt, mask), rtol=0, atol=1e-12)
    quats = HostFusion().process_block(raw[:25], t_long[:25], ok[:25]).quats
    np.testing.assert_allclose(plain["host"], quats, rtol=0, atol=1e-12)


def test_a_filter_from_outside_the_package_runs_in_host_fusion(recording, monkeypatch):
    """A filter is one module (tests/plugins/gyro_only.py: settings, class, step kernel, @register_filter): the
    pipeline and the block loop are generated around its step, so HostFusion, filter_block and the fusion config
    take it by name without any other file knowing it."""
    from recorder.fusion import registry

    registry.filter_names()  # the built-in filters registered, then a copy for this test: the others see those only
    monkeypatch.setattr(registry, "_FILTERS", dict(registry._FILTERS))
    monkeypatch.syspath_prepend(str(Path(__file__).parent / "plugins"))
    monkeypatch.delitem(sys.modules, "gyro_only", raising=False)
    import gyro_only  # noqa: F401  (registers "gyro_only")

    assert "gyro_only" in filter_names()
    _, raw, t_us, ok = recording
    config = FusionConfig(filter="gyro_only", filter_settings={"scale": 1.0})
    fused = HostFusion(config).process_block(raw[:300], t_us[:300], ok[:300])
    default = HostFusion().process_block(raw[:300], t_us[:300], ok[:300])
    assert np.all(np.isfinite(fused.angles)) and np.abs(fused.angles - default.angles).max() > 1e-3
    f = make_filter("gyro_only")
    gyro = np.full((50, 12, 3), 0.1)
    q = filter_block(f, gyro, np.zeros((50, 12, 3)), 0.01)
    np.testing.assert_allclose(2 * np.arccos(q[-1, :, 0]), 50 * 0.01 * 0.1 * np.sqrt(3), rtol=1e-9)
    with pytest.raises(ValueError, match="unknown setting.*scal"):
        FusionConfig(filter="gyro_only", filter_settings={"scal": 2.0})
