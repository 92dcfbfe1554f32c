"""The recorder's save path: exact episode stats in lerobot's layout, the writer process, one session per root."""

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st
from hypothesis.extra.numpy import arrays
from lerobot.datasets.compute_stats import aggregate_stats, compute_episode_stats
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from recorder import GloverecError
from recorder.record import store as store_module
from recorder.record.episode_stats import episode_stats
from recorder.record.sidecar import read_sidecar
from recorder.record.store import EpisodeStore
from recorder.record.writer import EpisodeWriter

FEATURES = {
    "observation.state": {"dtype": "float32", "shape": (3,), "names": None},
    "action": {"dtype": "float32", "shape": (3,), "names": None},
}
finite = st.floats(-1e3, 1e3, allow_nan=False, width=32)


@settings(max_examples=150, deadline=None)
@example(np.zeros((2, 1), np.float32), np.array([1e-45, 0.0], np.float32))  # subnormals: found by CI
@given(
    arrays(np.float32, st.tuples(st.integers(2, 60), st.integers(1, 5)), elements=finite),
    arrays(np.float32, st.integers(2, 60), elements=finite),
)
def test_episode_stats_match_lerobot_layout_and_values(vec, scalar):
    features = {
        "v": {"dtype": "float32", "shape": vec.shape[1:]},
        "s": {"dtype": "float32", "shape": (1,)},
        "task": {"dtype": "string", "shape": (1,)},
    }
    data = {"v": vec, "s": scalar, "task": ["t"] * len(scalar)}
    ours, theirs = episode_stats(data, features), compute_episode_stats(data, features)
    assert ours.keys() == theirs.keys() == {"v", "s"}
    for key in ours:
        assert ours[key].keys() == theirs[key].keys()
        x = np.sort(data[key].reshape(len(data[key]), -1), axis=0)
        n, span = len(x), np.ptp(x, axis=0) + 1e-6
        for stat, value in ours[key].items():
            assert value.shape == theirs[key][stat].shape, (key, stat)
            if stat.startswith("q"):
                # both estimate the same quantile: ours interpolates the order statistics (np.quantile),
                # lerobot reads a 5000-bin histogram's CDF; both lie within one order statistic of the rank
                rank = int(stat[1:]) / 100 * (n - 1)
                lo = x[max(0, int(np.floor(rank)) - 1)] - 2 * span / 5000
                hi = x[min(n - 1, int(np.ceil(rank)) + 1)] + 2 * span / 5000
                for v in (value.ravel(), theirs[key][stat].ravel()):
                    assert np.all((lo <= v) & (v <= hi)), (key, stat, v, lo, hi)
            else:
                wide = x.astype(np.float64)
                exact = {"min": x[0], "max": x[-1], "mean": wide.mean(0), "std": wide.std(0), "count": [n]}[stat]
                np.testing.assert_allclose(value.ravel(), np.ravel(exact), rtol=1e-12, atol=1e-12)
                # lerobot's std is sqrt(E[x^2] - E[x]^2) in float32, which cancels: ~1e-3 of |x| off
                big = float(np.max(np.abs(x)))
                tol = {"min": 0.0, "max": 0.0, "count": 0.0, "mean": 1e-5 * big}.get(stat, 2e-3 * big + 1e-6)
                tol += float(np.finfo(np.float32).tiny)  # lerobot's float32 mean of subnormals underflows to 0
                np.testing.assert_allclose(value, theirs[key][stat], atol=tol, rtol=1e-5, err_msg=f"{key} {stat}")
    aggregate_stats([ours, theirs])  # lerobot merges them like its own


def test_exact_quantiles_where_lerobot_approximates():
    x = np.arange(101, dtype=np.float32)
    stats = episode_stats({"x": x}, {"x": {"dtype": "float32", "shape": (1,)}})["x"]
    assert stats["q10"][0] == pytest.approx(10.0) and stats["q99"][0] == pytest.approx(99.0)


def _frames(store, n, value):
    for i in range(n):
        store.add_frame(
            {
                "observation.state": np.full(3, value + i, np.float32),
                "action": np.full(3, -value - i, np.float32),
                "task": f"task {value}",
            }
        )


def test_writer_process_saves_in_order_and_reports(tmp_path):
    root = tmp_path / "ds"
    store = EpisodeStore(root, "test/writer", 30, FEATURES, "glovehand")
    writer = EpisodeWriter(store)
    for e in range(3):
        _frames(store, 5 + e, 100 * e)
        assert store.next_index == e
        writer.submit(store.take_episode(), {"marker": e})
    _frames(store, 4, 999)
    store.discard_episode()  # an episode in progress, dropped: its index is reused
    assert store.next_index == 3
    done = writer.results(wait=True) + writer.close()
    store.close()
    assert [(i, s["marker"]) for i, s in done] == [(0, 0), (1, 1), (2, 2)]
    ds = LeRobotDataset("test/writer", root=root)
    assert ds.num_episodes == 3 and ds.num_frames == 5 + 6 + 7
    assert float(ds[5]["observation.state"][0]) == 100.0  # episode 1, frame 0
    assert [s["marker"] for s in read_sidecar(root)] == [0, 1, 2]


def test_writer_failure_is_one_clear_error_and_saved_episodes_stay(tmp_path):
    root = tmp_path / "ds"
    store = EpisodeStore(root, "test/writer", 30, FEATURES, "glovehand")
    writer = EpisodeWriter(store)
    _frames(store, 5, 0)
    writer.submit(store.take_episode(), {})
    _frames(store, 5, 10)
    bad = store.take_episode()
    bad["episode_index"] = 7  # not the next index: lerobot refuses to save it
    writer.submit(bad, {})
    with pytest.raises(GloverecError, match="saving episode 7 failed"):
        writer.results(wait=True)
    writer.close()
    store.close()
    assert LeRobotDataset("test/writer", root=root).num_episodes == 1


def test_one_session_per_dataset(tmp_path, monkeypatch):
    root = tmp_path / "ds"
    monkeypatch.setattr(store_module, "LOCK_WAIT_S", 0.3)
    first = EpisodeStore(root, "test/lock", 30, FEATURES, "glovehand")
    _frames(first, 3, 0)
    first.save_episode({})
    with pytest.raises(GloverecError, match="in use by another gloverec session"):
        EpisodeStore(root, "test/lock", 30, FEATURES, "glovehand", resume=True)
    first.close()
    second = EpisodeStore(root, "test/lock", 30, FEATURES, "glovehand", resume=True)
    assert second.num_episodes == 1
    second.close()
