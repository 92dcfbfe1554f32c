"""Crash safety of the episode store: SIGKILL at many moments never costs a saved episode."""

import json
import subprocess
import sys
import time

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from recorder import GloverecError
from recorder.record.sidecar import read_sidecar
from recorder.record.store import EpisodeStore

FEATURES = {
    "observation.state": {"dtype": "float32", "shape": (3,), "names": ["a", "b", "c"]},
    "action": {"dtype": "float32", "shape": (3,), "names": ["a", "b", "c"]},
}

WRITER = """
import sys, numpy as np
from recorder.record.store import EpisodeStore
features = {k: {**v, "shape": tuple(v["shape"])} for k, v in __import__("json").loads(sys.argv[2]).items()}
store = EpisodeStore(sys.argv[1], "test/crash", 30, features, "glovehand", resume=True)
e = store.num_episodes
while True:
    for i in range(40):
        store.add_frame({"observation.state": np.full(3, e * 1000 + i, np.float32),
                         "action": np.full(3, e, np.float32), "task": f"task {e % 3}"})
    store.save_episode({"marker": e})
    print("saved", e, flush=True)
    e += 1
"""


def check_dataset(root, min_episodes):
    ds = LeRobotDataset("test/crash", root=root)
    assert ds.num_episodes >= min_episodes
    side = read_sidecar(root)
    assert [s["episode_index"] for s in side] == list(range(ds.num_episodes))
    for e in range(ds.num_episodes):  # every frame of every episode is the one written
        lo, hi = ds.meta.episodes[e]["dataset_from_index"], ds.meta.episodes[e]["dataset_to_index"]
        assert hi - lo == 40
        states = np.stack([ds[i]["observation.state"].numpy() for i in (lo, hi - 1)])
        assert states[:, 0].tolist() == [e * 1000, e * 1000 + 39]
        assert ds[lo]["task"] == f"task {e % 3}"
    return ds.num_episodes


@pytest.mark.process
@pytest.mark.timeout(240)
def test_sigkill_at_many_moments_keeps_every_saved_episode(tmp_path):
    root = tmp_path / "ds"
    feats = json.dumps({k: {**v, "shape": list(v["shape"])} for k, v in FEATURES.items()})
    saved = 0
    rng = np.random.default_rng(7)
    for delay in rng.uniform(0.0, 1.0, 5):  # after the writer's first save: any moment of the next ones
        proc = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(root), feats],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        first = proc.stdout.readline()  # blocks until an episode is saved (startup time varies with load)
        assert first.startswith("saved"), first
        time.sleep(delay)
        proc.kill()
        out, _ = proc.communicate()
        lines = [ln for ln in (first + out).splitlines() if ln.startswith("saved")]
        saved = int(lines[-1].split()[1]) + 1
        assert check_dataset(root, saved) >= saved  # plain lerobot, no repair step in between
    assert saved >= 5


def test_resume_appends_and_refuses_a_different_dataset(tmp_path):
    root = tmp_path / "ds"
    store = EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand")
    for i in range(40):
        store.add_frame(
            {"observation.state": np.full(3, i, np.float32), "action": np.zeros(3, np.float32), "task": "task 0"}
        )
    store.save_episode({})
    store.add_frame(
        {"observation.state": np.zeros(3, np.float32), "action": np.zeros(3, np.float32), "task": "task 0"}
    )  # an episode in progress, never saved
    store.close()
    with pytest.raises(GloverecError, match="--resume"):
        EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand")
    with pytest.raises(GloverecError, match="fps"):
        EpisodeStore(root, "test/crash", 50, FEATURES, "glovehand", resume=True)
    with pytest.raises(GloverecError, match="robot"):
        EpisodeStore(root, "test/crash", 30, FEATURES, "shadow", resume=True)
    other = {**FEATURES, "action": {**FEATURES["action"], "shape": (4,), "names": list("abcd")}}
    with pytest.raises(GloverecError, match="action"):
        EpisodeStore(root, "test/crash", 30, other, "glovehand", resume=True)
    store = EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand", resume=True)
    assert store.num_episodes == 1
    for i in range(40):
        store.add_frame(
            {"observation.state": np.full(3, 1000 + i, np.float32), "action": np.ones(3, np.float32), "task": "task 1"}
        )
    store.save_episode({})
    store.close()
    assert check_dataset(root, 2) == 2


def test_plain_directory_is_not_resumed(tmp_path):
    (tmp_path / "ds").mkdir()
    with pytest.raises(GloverecError, match="not a gloverec recording"):
        EpisodeStore(tmp_path / "ds", "test/crash", 30, FEATURES, "glovehand", resume=True)
