"""The frame cache on disk (policies/diskcache.py): `gloverec train --frame-cache disk` draws the same batches as
from memory (history windows and action chunks included) and so trains the same weights, bit for bit; a cache that
a crash left partial is never served."""

import json
import os
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from conftest import cli, gloverec

REPO = "test/cam"


@pytest.fixture(scope="module")
def camera_dataset(shared) -> Path:
    """2 pose episodes of 2 s with one 32 px camera, recorded once per run."""

    def build(path: Path) -> None:
        r = gloverec("record", "--glove", "emulator", "--task", "pose", "--episodes", "2", "--episode-time-s", "2",
                     "--cameras", "front", "--image-size", "32,32", "--root", str(path), "--repo-id", REPO, "--fast",
                     "--no-log", "--json", timeout=120)  # fmt: skip
        assert r.returncode == 0, r.stderr

    return shared("camera_32px", build)


def _history_keys(root: Path):
    """A history policy's keys and delta timestamps on the dataset, as `gloverec train` makes them."""
    from lerobot.datasets.factory import resolve_delta_timestamps

    from policies.bc import BCConfig
    from policies.data import load_meta, resolve
    from policies.train import history_deltas

    ref = resolve(REPO, root=root)
    meta = load_meta(ref)
    cfg = BCConfig(device="cpu", n_obs_steps=3, obs_stride=2, chunk_size=5)
    cfg.input_features = {k: None for k in ("observation.state", "observation.images.front")}
    keys = [*cfg.input_features, "action", "task"]
    return ref, meta, keys, history_deltas(resolve_delta_timestamps(cfg, meta), keys)


def test_the_disk_cache_gives_the_batches_from_memory_and_trains_the_same_weights(camera_dataset, tmp_path):
    import shutil

    from policies.data import FrameCache

    root = tmp_path / "ds"
    shutil.copytree(camera_dataset, root)  # the cache is written beside the dataset
    ref, meta, keys, delta = _history_keys(root)
    memory = FrameCache(ref, [0, 1], keys, delta, progress=False)
    disk = FrameCache(ref, [0, 1], keys, delta, progress=False, store="disk")
    again = FrameCache(ref, [0, 1], keys, delta, progress=False, store="disk")  # read back, nothing decoded
    assert list(disk.data) == list(memory.data) and len(disk) == len(memory) > 0
    assert disk.data["observation.state"].shape == memory.data["observation.state"].shape  # (N, 3, D): windows
    picked = torch.randint(len(memory), (16,), generator=torch.Generator().manual_seed(0))
    for cache in (disk, again):
        a, b = memory.batch(picked), cache.batch(picked)
        assert a["task"] == b["task"]
        for k in memory.data:
            assert a[k].dtype == b[k].dtype and torch.equal(a[k], b[k]), k
    joined = FrameCache.join([disk, again])  # several datasets' caches, as `--also` makes them
    assert torch.equal(joined.batch(torch.tensor([len(disk)]))["action"], memory.batch(torch.tensor([0]))["action"])
    assert memory.stats(keys, {}).keys() == disk.stats(keys, {}).keys()
    for k, s in memory.stats(keys, {}).items():
        assert all((s[m] == disk.stats(keys, {})[k][m]).all() for m in s), k

    # end to end: the same first batches, so the same weights after a few steps
    weights = {}
    for where in ("memory", "disk"):
        out = tmp_path / where
        r = cli("train", "--repo-id", REPO, "--root", str(root), "--steps", "3", "--batch-size", "8",
                "--frame-cache", where, "--out", str(out), "--json")  # fmt: skip
        assert r.returncode == 0, r.stderr[-2000:]
        assert f"frame cache {'on disk' if where == 'disk' else 'in memory'}" in r.stderr
        weights[where] = load_file(out / "checkpoints" / "last" / "pretrained_model" / "model.safetensors")
    assert weights["memory"].keys() == weights["disk"].keys()
    assert all(torch.equal(weights["memory"][k], weights["disk"][k]) for k in weights["memory"])


def test_a_partial_cache_is_never_served_and_is_rebuilt(camera_dataset, tmp_path, monkeypatch):
    import shutil

    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from policies import diskcache
    from policies.data import FrameCache

    root = tmp_path / "ds"
    shutil.copytree(camera_dataset, root)
    ref, _, keys, delta = _history_keys(root)
    what = {"episodes": [0], "keys": keys, "delta": delta, "action_from": "action"}
    folder = diskcache.folder_for(root, what)
    # a build killed mid-write (no process left to clean up) leaves a partial folder
    dead = folder.with_name(f"{folder.name}.partial-{2**22 + 1}")
    (dead / "0.bin").parent.mkdir(parents=True)
    (dead / "0.bin").write_bytes(b"\0" * 10)
    # a build that fails mid-write leaves nothing
    real, calls = LeRobotDataset.__getitem__, []

    def failing(self, i):
        calls.append(i)
        if len(calls) > 5:
            raise KeyboardInterrupt
        return real(self, i)

    monkeypatch.setattr(LeRobotDataset, "__getitem__", failing)
    with pytest.raises(KeyboardInterrupt):
        FrameCache(ref, [0], keys, delta, progress=False, store="disk")
    monkeypatch.setattr(LeRobotDataset, "__getitem__", real)
    assert diskcache.read(folder) is None and not dead.exists()
    assert [p.name for p in folder.parent.iterdir()] == []
    built = FrameCache(ref, [0], keys, delta, progress=False, store="disk")
    manifest = json.loads((folder / diskcache.MANIFEST).read_text())
    assert manifest["columns"]["observation.images.front"]["rows"] == len(built) > 5
    assert os.path.getsize(folder / manifest["columns"]["observation.images.front"]["file"]) == len(built) * 32 * 32 * 3


def test_auto_goes_to_disk_above_half_the_available_memory():
    from policies.diskcache import choose

    assert choose("auto", 6 * 10**9, 10 * 10**9)[0] == "disk"
    assert choose("auto", 4 * 10**9, 10 * 10**9)[0] == "memory"
    assert choose("memory", 6 * 10**9, 10 * 10**9) == ("memory", "about 6.00 GB decoded; --frame-cache memory")
