"""A dataset recorded by an older gloverec on lerobot 0.4.4 keeps working on the lerobot installed now.

tests/fixtures/lerobot044_pose is such a dataset as `gloverec record` wrote it (glovehand, pose task, 2
episodes, 100 frames, two data files; made with commit c5adb59, Python 3.11, lerobot 0.4.4, see
tests/fixtures/README.md): lerobot loads it frame for frame, the hub takes it, training and inspect read it."""

import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from conftest import cli

FIXTURE = Path(__file__).parent / "fixtures" / "lerobot044_pose"
REPO = "old/pose"


@pytest.fixture
def old(tmp_path) -> Path:
    root = tmp_path / "old_pose"
    shutil.copytree(FIXTURE, root)
    return root


def test_the_fixture_was_recorded_by_lerobot_044_in_the_format_of_today():
    info = json.loads((FIXTURE / "meta" / "info.json").read_text())
    assert info["codebase_version"] == "v3.0" and info["total_episodes"] == 2 and info["total_frames"] == 100
    assert len(list((FIXTURE / "data").rglob("*.parquet"))) == 2  # episodes split over files, as the store writes


def test_lerobot_loads_an_044_dataset_frame_for_frame(old):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset(REPO, root=old, video_backend="pyav")
    assert ds.num_episodes == 2 and ds.num_frames == 100
    table = pq.read_table(sorted((old / "data").rglob("*.parquet"))).to_pydict()
    actions = np.stack([ds[i]["action"].numpy() for i in range(len(ds))])
    np.testing.assert_array_equal(actions, np.asarray(table["action"], np.float32))
    assert [int(ds[i]["episode_index"]) for i in (0, 99)] == [0, 1]
    assert {ds[i]["task"] for i in range(len(ds))} == {"make the spiderman gesture", "make the two fingers gesture"}


def ok(*args: str) -> dict | None:
    r = cli(*args)
    assert r.returncode == 0 and "Traceback" not in r.stderr and "WARNING" not in r.stderr, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1]) if "--json" in args else None


def test_an_044_dataset_is_inspected_pushed_verified_and_trained_on(old, tmp_path):
    summary = ok("inspect", "--repo-id", REPO, "--root", str(old), "--json")
    assert [e["frames"] for e in summary["episodes"]] == [47, 53]

    hub = tmp_path / "hub"
    assert ok("push", "--repo-id", REPO, "--root", str(old), "--hub", str(hub), "--json")["version"] == "v1"
    ok("hub", "verify", "--hub", str(hub))

    out = tmp_path / "policy"
    args = ("--repo-id", REPO, "--hub", str(hub), "--all-episodes", "--val-fraction", "0", "--steps", "30")
    trained = ok("train", *args, "--out", str(out), "--json")
    assert trained["train_episodes"] == 2 and trained["steps"] == 30
    assert (out / "checkpoints" / "last" / "pretrained_model" / "model.safetensors").is_file()
