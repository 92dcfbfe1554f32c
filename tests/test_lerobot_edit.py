"""gloverec datasets through lerobot-edit-dataset (lerobot's own command, run as docs/lerobot.md shows it):
the edited datasets train, and gloverec's episode records (seeds, success), which delete_episodes, split and
merge do not carry, come back with `gloverec carry-meta` and are never trusted when they describe other episodes."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import POSE_REPO, cli
from recorder.record.sidecar import SIDECAR

pytestmark = pytest.mark.process

EDIT = str(Path(sys.executable).with_name("lerobot-edit-dataset"))


def edit(*args: str) -> None:
    r = subprocess.run([EDIT, *args], capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stderr[-3000:]


def seeds(root: Path, repo_id: str = POSE_REPO) -> dict[int, int]:
    r = cli("inspect", "--repo-id", repo_id, "--root", str(root), "--no-plot", "--json")
    assert r.returncode == 0, r.stderr
    side = [json.loads(line) for line in (root / SIDECAR).read_text().splitlines()] if (root / SIDECAR).exists() else []
    return {s["episode_index"]: s["seed"] for s in side}


@pytest.mark.xdist_group("lerobot.md")  # with the docs block whose outputs it reads
def test_deleted_episodes_get_their_seeds_back_and_replay_exactly(docs_run, tmp_path):
    """docs/lerobot.md's editing block as written: record 2 episodes (seeds 0, 1), delete episode 0 with
    lerobot-edit-dataset, carry-meta, replay, lerobot-dataset-viz."""
    work = docs_run("lerobot.md", 1)
    cut = work / "demos_cut"
    assert json.loads((cut / "meta" / "info.json").read_text())["total_episodes"] == 1
    assert seeds(cut, "me/demos_cut") == {0: 1}  # the second episode, now the first, with its own seed
    r = cli("replay", "--repo-id", "me/demos_cut", "--root", str(cut), "--episode", "0", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["seed"] == 1 and out["max_abs"] == 0
    assert (work / "viz" / "me_demos_cut_episode_0.rrd").stat().st_size > 0
    bare = shutil.copytree(cut, tmp_path / "cut")  # the shared run is read-only
    shutil.rmtree(bare / "meta" / "gloverec")  # what lerobot-edit-dataset leaves: replay cannot know the scene
    r = cli("replay", "--repo-id", "me/demos_cut", "--root", str(bare), "--episode", "0")
    assert r.returncode == 1 and "has no seed" in r.stderr


def test_records_that_describe_other_episodes_are_ignored_with_a_warning(pose_recording, tmp_path):
    root, _ = pose_recording
    cut = tmp_path / "cut"
    edit("--repo_id", POSE_REPO, "--root", str(root), "--new_repo_id", "test/cut", "--new_root", str(cut),
         "--operation.type", "delete_episodes", "--operation.episode_indices", "[0]")  # fmt: skip
    (cut / SIDECAR).parent.mkdir(parents=True)
    shutil.copy(root / SIDECAR, cut / SIDECAR)  # the original's records, now one episode off
    r = cli("inspect", "--repo-id", "test/cut", "--root", str(cut), "--no-plot", "--json")
    assert r.returncode == 0
    assert [e["success"] for e in json.loads(r.stdout)["episodes"]] == [None, None, None]
    assert "do not match the dataset's episodes" in r.stderr and "gloverec carry-meta" in r.stderr
    assert cli("train", "--repo-id", "test/cut", "--root", str(cut), "--steps", "5", "--out",
               str(tmp_path / "policy")).returncode == 0  # fmt: skip
    hub = str(tmp_path / "hub")  # and it publishes and verifies like one of ours
    assert cli("push", "--repo-id", "test/cut", "--root", str(cut), "--hub", hub).returncode == 0
    verified = cli("hub", "verify", "--hub", hub)
    assert verified.returncode == 0, verified.stdout + verified.stderr


def test_a_split_merged_back_gets_every_record_from_its_parts(pose_recording, tmp_path):
    root, _ = pose_recording
    edit("--repo_id", POSE_REPO, "--root", str(root), "--new_root", str(tmp_path / "split"),
         "--operation.type", "split", "--operation.splits", '{"train": 0.5, "val": 0.5}')  # fmt: skip
    parts = [tmp_path / "split" / name for name in ("val", "train")]
    for part in parts:
        assert cli("carry-meta", "--root", str(part), "--from", str(root)).returncode == 0
    merged = tmp_path / "merged"
    edit("--new_repo_id", "test/merged", "--new_root", str(merged), "--operation.type", "merge",
         "--operation.repo_ids", '["test/val", "test/train"]',
         "--operation.roots", json.dumps([str(p) for p in parts]))  # fmt: skip
    r = cli("carry-meta", "--root", str(merged), "--from", *map(str, parts))
    assert r.returncode == 0 and "4 of 4 episodes" in r.stdout
    assert sorted(seeds(merged).values()) == [0, 1, 2, 3]


def test_carry_meta_refuses_sources_without_records_in_one_line(tmp_path):
    r = cli("carry-meta", "--root", str(tmp_path), "--from", str(tmp_path))
    assert r.returncode == 1 and "is not a LeRobot dataset" in r.stderr and "Traceback" not in r.stderr
