"""`gloverec edit` (issue 26's curation without a browser): delete, trim and relabel episodes into a new dataset or
the hub's next version, with gloverec's episode records following their episodes; bad edits are one line and
change nothing. `gloverec repair` (issue 42): the intact episodes of a damaged dataset, written the same way."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from conftest import POSE_REPO, cli
from recorder.record.sidecar import read_sidecar


def _frames(ds: LeRobotDataset, episode: int) -> dict[str, np.ndarray]:
    rows = ds.hf_dataset.with_format(None)
    ep = ds.meta.episodes[episode]
    part = rows[int(ep["dataset_from_index"]) : int(ep["dataset_to_index"])]
    return {k: np.asarray(part[k]) for k in ("observation.state", "action", "timestamp")}


def test_edit_deletes_trims_and_relabels_into_a_new_dataset(pose_recording, tmp_path):
    src, _ = pose_recording
    out = tmp_path / "edited"
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(src), "--out", str(out), "--delete", "1",
            "--trim", "2:0.5-end", "--trim", "3:0-1", "--success", "0:no", "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["episode_map"] == {"0": 0, "2": 1, "3": 2}

    before, after = LeRobotDataset(POSE_REPO, root=src), LeRobotDataset(POSE_REPO, root=out)
    assert after.num_episodes == 3 and after.meta.total_frames == len(after)
    fps = before.meta.fps
    same, trimmed_start, trimmed_end = _frames(after, 0), _frames(after, 1), _frames(after, 2)
    np.testing.assert_array_equal(same["action"], _frames(before, 0)["action"])
    first = int(np.ceil(0.5 * fps))
    np.testing.assert_array_equal(trimmed_start["observation.state"], _frames(before, 2)["observation.state"][first:])
    assert trimmed_start["timestamp"][0] == 0.0  # the trimmed episode's clock starts again at 0
    assert len(trimmed_end["action"]) == int(1.0 * fps) + 1
    np.testing.assert_array_equal(trimmed_end["action"], _frames(before, 3)["action"][: int(fps) + 1])

    records = {r["episode_index"]: r for r in read_sidecar(out)}  # every record matches its episode
    assert sorted(records) == [0, 1, 2]
    assert records[0]["success"] is False and records[0]["seed"] == 0
    assert "seed" not in records[1] and records[1]["trimmed_s"] == [0.5, None]  # cannot replay from the reset
    assert records[2]["seed"] == 3 and records[2]["frames"] == len(trimmed_end["action"])
    assert LeRobotDataset(POSE_REPO, root=src).num_episodes == 4  # the source is untouched

    replayed = cli("replay", "--repo-id", POSE_REPO, "--root", str(out), "--episode", "2", "--json")
    assert replayed.returncode == 0 and json.loads(replayed.stdout)["reproduced"], replayed.stderr
    refused = cli("replay", "--repo-id", POSE_REPO, "--root", str(out), "--episode", "1")  # trimmed at its start
    err = refused.stderr.strip()
    assert refused.returncode == 1 and "\n" not in err and "not recorded by gloverec" not in err, err
    assert "was trimmed at its start (0.5 s, gloverec edit)" in err and "replay the original episode (2 " in err


def test_edit_on_the_hub_publishes_the_next_version_and_keeps_the_old(pose_recording, tmp_path):
    src, _ = pose_recording
    hub = tmp_path / "hub"
    assert cli("push", "--repo-id", POSE_REPO, "--root", str(src), "--hub", str(hub)).returncode == 0
    r = cli("edit", "--repo-id", POSE_REPO, "--hub", str(hub), "--delete", "0,3")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"{POSE_REPO} v2: 2 episodes"), r.stdout
    assert LeRobotDataset(POSE_REPO, root=hub / f"{POSE_REPO}@v1").num_episodes == 4
    assert LeRobotDataset(POSE_REPO, root=hub / POSE_REPO).num_episodes == 2  # the link: the newest
    verified = cli("hub", "verify", "--hub", str(hub), "--json")
    assert verified.returncode == 0, verified.stdout + verified.stderr
    trained = cli("train", "--repo-id", POSE_REPO, "--hub", str(hub), "--steps", "2", "--batch-size", "8",
                  "--out", str(tmp_path / "run"), "--json")  # fmt: skip
    assert trained.returncode == 0 and json.loads(trained.stdout)["train_episodes"] >= 1, trained.stderr


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        (["--delete", "0-3"], "would remove every episode (4)"),
        (["--trim", "1:9-end"], "leaves nothing"),
        (["--trim", "1:2-1"], "trims episode 1 to nothing"),
        (["--delete", "7"], "no episode 7: the dataset has episodes 0-3"),
        (["--delete", "one"], "bad --delete"),
        (["--success", "2:maybe"], "bad --success"),
        (["--delete", "2", "--success", "2:no"], "episode 2 is both deleted"),
        ([], "nothing to do"),
    ],
)
def test_a_bad_edit_is_one_line_and_changes_nothing(pose_recording, tmp_path, edit, says):
    src, _ = pose_recording
    out = tmp_path / "edited"
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(src), "--out", str(out), *edit)
    assert r.returncode != 0 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not out.exists()


def test_edit_refuses_an_existing_output_and_a_recording_in_place(pose_recording, tmp_path):
    src, _ = pose_recording
    (tmp_path / "taken").mkdir()
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(src), "--out", str(tmp_path / "taken"), "--delete", "1")
    assert r.returncode != 0 and "already exists" in r.stderr
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(src), "--delete", "1")
    assert r.returncode != 0 and "pass --out DIR" in r.stderr
    copy = tmp_path / "copy"
    shutil.copytree(src, copy)
    (copy / "meta" / "info.json").unlink()
    (copy / "meta" / "info.json").write_text("{")  # a damaged dataset
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(copy), "--out", str(tmp_path / "o"), "--delete", "1")
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr, r.stderr


def test_edit_then_merge_appends_other_datasets_with_their_records(pose_recording, tmp_path):
    src, _ = pose_recording
    out = tmp_path / "merged"
    r = cli("edit", "--repo-id", POSE_REPO, "--root", str(src), "--out", str(out), "--delete", "0",
            "--merge", str(src), "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["episodes"] == 3 + 4 and summary["records_carried"] == 7
    merged = LeRobotDataset(POSE_REPO, root=out)
    assert merged.num_episodes == 7
    assert [rec["seed"] for rec in read_sidecar(out)] == [1, 2, 3, 0, 1, 2, 3]
    np.testing.assert_array_equal(
        _frames(merged, 3)["action"], _frames(LeRobotDataset(POSE_REPO, root=src), 0)["action"]
    )


def _flip_a_byte(path, at: int = 8) -> None:
    """One byte of a parquet file's first page changed: its footer, and so its row counts, still read."""
    with path.open("r+b") as f:
        f.seek(at)
        byte = f.read(1)[0]
        f.seek(at)
        f.write(bytes([byte ^ 0xFF]))


def test_repair_keeps_the_intact_episodes_of_a_dataset_with_truncated_files(pose_recording, tmp_path):
    """Issue 42: with one episode's parquet cut short every command refused the dataset, `edit --delete` of that
    episode included, so the intact episodes could not be saved. (A recording has a data file per episode; here
    episode 1's is cut in half and a page of episode 3's is damaged, which only reading its frames finds.)"""
    src, _ = pose_recording
    copy = tmp_path / "damaged"
    shutil.copytree(src, copy)
    victim = copy / "data" / "chunk-000" / "file-001.parquet"
    os.truncate(victim, victim.stat().st_size // 2)
    _flip_a_byte(copy / "data" / "chunk-000" / "file-003.parquet")
    before = sorted((p.relative_to(copy), p.stat().st_size) for p in copy.rglob("*") if p.is_file())
    refused = cli("edit", "--repo-id", POSE_REPO, "--root", str(copy), "--out", str(tmp_path / "e"), "--delete", "1")
    assert refused.returncode == 1 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert "`gloverec repair` rescues its intact episodes" in refused.stderr

    out = tmp_path / "repaired"
    r = cli("repair", "--repo-id", POSE_REPO, "--root", str(copy), "--out", str(out))
    assert r.returncode == 0, r.stderr
    original, repaired = LeRobotDataset(POSE_REPO, root=src), LeRobotDataset(POSE_REPO, root=out)
    frames = sum(len(_frames(original, e)["action"]) for e in (0, 2))
    one, three, summary = r.stdout.strip().splitlines()
    assert one.startswith("episode 1 dropped: data/chunk-000/file-001.parquet is not a readable parquet file (")
    assert three.startswith("episode 3 dropped: data/chunk-000/file-003.parquet is not a readable parquet file (")
    assert summary == f"{out}: kept 2 of 4 episodes, {frames} frames (dropped 2; from {copy})"
    assert repaired.num_episodes == 2 and repaired.meta.total_frames == len(repaired)
    for new, old in enumerate((0, 2)):
        for key, values in _frames(original, old).items():
            np.testing.assert_array_equal(_frames(repaired, new)[key], values)
    records = read_sidecar(out)
    assert [(rec["seed"], rec["repaired_from"]) for rec in records] == [(0, 0), (2, 2)]
    assert (out / "meta" / "gloverec" / "hand_profile.json").is_file()
    assert sorted((p.relative_to(copy), p.stat().st_size) for p in copy.rglob("*") if p.is_file()) == before


def test_repair_on_the_hub_publishes_the_intact_episodes_as_the_next_version(pose_recording, tmp_path):
    """A hub version with a file altered after publishing: its manifest says which before anything reads it; the
    intact episodes are the next version and the damaged one stays as it was."""
    src, _ = pose_recording
    hub = tmp_path / "hub"
    assert cli("push", "--repo-id", POSE_REPO, "--root", str(src), "--hub", str(hub)).returncode == 0
    altered = hub / f"{POSE_REPO}@v1" / "data" / "chunk-000" / "file-002.parquet"
    altered.chmod(0o644)
    _flip_a_byte(altered)
    r = cli("repair", "--repo-id", POSE_REPO, "--hub", str(hub), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["version"] == "v2" and summary["episode_map"] == {"0": 0, "1": 1, "3": 2}
    assert summary["dropped"] == {"2": "data/chunk-000/file-002.parquet differs from the hub's manifest"}
    assert LeRobotDataset(POSE_REPO, root=hub / POSE_REPO).num_episodes == 3  # the link: the newest
    assert cli("hub", "verify", "--hub", str(hub), "--repo-id", POSE_REPO, "--version", "v2").returncode == 0


def test_repair_with_nothing_intact_is_one_line_and_writes_nothing(pose_recording, tmp_path):
    src, _ = pose_recording
    copy = tmp_path / "copy"
    shutil.copytree(src, copy)
    for victim in (copy / "data").rglob("*.parquet"):
        victim.unlink()
    out = tmp_path / "repaired"
    r = cli("repair", "--repo-id", POSE_REPO, "--root", str(copy), "--out", str(out))
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "no episode of" in r.stderr and "data/chunk-000/file-000.parquet is missing" in r.stderr
    assert not out.exists()
    r = cli("repair", "--repo-id", POSE_REPO, "--root", str(copy))
    assert r.returncode == 1 and "pass --out DIR: a recording is not repaired in place" in r.stderr
