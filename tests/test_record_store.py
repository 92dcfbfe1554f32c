"""Crash safety of the episode store: SIGKILL at many moments never costs a saved episode."""

import threading
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


def _write_until_killed(root: str, log: str) -> None:
    """The store writing 40-frame episodes until it is killed; each saved episode is a line in ``log``."""
    store = EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand", resume=True)
    e = store.num_episodes
    with open(log, "a") as f:
        while True:
            for i in range(40):
                store.add_frame({"observation.state": np.full(3, e * 1000 + i, np.float32),
                                 "action": np.full(3, e, np.float32), "task": f"task {e % 3}"})  # fmt: skip
            store.save_episode({"marker": e})
            f.write(f"saved {e}\n")
            f.flush()
            e += 1


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
    """Each writer is a process of its own, killed with SIGKILL; they are forked by a forkserver that has imported
    the store and LeRobot once (a fresh interpreter per writer spent most of this test importing LeRobot, and the
    store imports LeRobot only when it opens)."""
    import multiprocessing

    from conftest import wait_for

    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["recorder.record.store", "lerobot.datasets.lerobot_dataset"])  # the store opens it
    root = tmp_path / "ds"
    saved = 0
    rng = np.random.default_rng(7)
    for k, delay in enumerate(rng.uniform(0.0, 1.0, 5)):  # after the writer's first save: any moment of the next ones
        log = tmp_path / f"writer{k}.log"
        log.touch()
        proc = ctx.Process(target=_write_until_killed, args=(str(root), str(log)))
        proc.start()
        assert wait_for(lambda: "saved" in log.read_text(), 120), "the writer saved no episode"  # noqa: B023
        time.sleep(delay)
        proc.kill()
        proc.join(30)
        lines = [ln for ln in log.read_text().splitlines() if ln.startswith("saved ")]
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


def test_a_session_that_saves_nothing_leaves_no_hidden_folder(tmp_path):
    """Issue 42: a failed start (a glove that does not open, a stop before the first episode) left an empty
    .ROOT.gloverec/ behind. A session waiting for the lock then makes its own; a recording with episodes keeps it."""
    root = tmp_path / "ds"
    frame = {"observation.state": np.zeros(3, np.float32), "action": np.zeros(3, np.float32), "task": "task 0"}
    first = EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand")
    first.add_frame(dict(frame))  # an episode in progress, never saved (add_frame takes the task out)
    waiting: dict = {}
    thread = threading.Thread(target=lambda: waiting.update(store=EpisodeStore(root, "test/crash", 30, FEATURES,
                                                                               "glovehand")))  # fmt: skip
    thread.start()
    time.sleep(0.3)  # the second session waits for the first one's lock
    first.close()
    thread.join(30)
    second = waiting["store"]
    for i in range(40):  # as _write_until_killed writes them, for check_dataset
        second.add_frame({**frame, "observation.state": np.full(3, i, np.float32)})
    second.save_episode({})
    second.close()
    assert check_dataset(root, 1) == 1
    resumed = EpisodeStore(root, "test/crash", 30, FEATURES, "glovehand", resume=True)
    resumed.close()  # nothing saved, but not its dataset to remove
    assert check_dataset(root, 1) == 1

    EpisodeStore(tmp_path / "empty", "test/crash", 30, FEATURES, "glovehand").close()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".ds.gloverec", "ds"]
