"""`gloverec generate` (policies/generate.py, envs/tasks/segments.py): the documented run (docs/recording.md: 2
human-like relocate takes recorded with the emulated glove, 2 episodes generated from them in wider scenes,
replayed, pushed, verified, trained and evaluated) and what it wrote; the segments against the recorded states;
the refusals."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from conftest import POSE_REPO, cli


def _generate_block() -> int:
    from docs_runner import ROOT, run_blocks_of

    blocks = run_blocks_of(ROOT / "docs" / "recording.md")
    return next(i for i, b in enumerate(blocks) if "gloverec generate" in b.text)


@pytest.fixture
def generated(docs_run):
    return docs_run("recording.md", _generate_block())


def _records(root) -> list[dict]:
    return [json.loads(x) for x in (root / "meta" / "gloverec" / "episodes.jsonl").read_text().splitlines() if x]


def test_a_generated_episode_names_its_source_and_replays_exactly(generated):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out, src = generated / "relocate1000", generated / "relocate10"
    records = _records(out)
    assert len(records) == 2 and all(r["success"] for r in records)
    sources = {r["episode_index"]: r for r in _records(src)}
    for r in records:
        g = r["generated"]
        assert g["from"]["root"] == str(src.resolve()) or g["from"]["root"] == str(src.absolute())
        assert sources[g["source_episode"]]["seed"] == g["source_seed"] and sources[g["source_episode"]]["success"]
        assert [s["name"] for s in g["segments"]][:2] == ["reach", "grasp"]
        assert g["moved_m"]["object"] > 0 and r["env_options"] == {"placement_m": 0.08}
        assert r["seed"] >= 10000 and r["start_device_time_s"] >= 1e6
    ds = LeRobotDataset("me/relocate1000", root=out)  # plain LeRobot loads it
    assert ds.num_episodes == 2 and len(ds) == sum(r["frames"] for r in records)
    assert (generated / "hub" / "me" / "relocate1000@v1").is_dir()  # pushed (and verified, trained, evaluated)
    assert any((generated / "relocate1000_bc").rglob("model.safetensors"))
    replayed = cli("replay", "--repo-id", "me/relocate1000", "--root", str(out), "--episode", "1", "--json")
    assert replayed.returncode == 0, replayed.stderr
    r = json.loads(replayed.stdout)
    assert r["max_abs"] == 0 and r["replayed_success"] and r["seed"] == records[1]["seed"]


def test_a_generation_goes_on_with_resume_and_refuses_other_settings(generated, tmp_path):
    out = tmp_path / "more"  # a copy of the generated dataset, its store's state folder and its link
    shutil.copytree(generated / ".relocate1000.gloverec", tmp_path / ".more.gloverec", symlinks=True)
    os.symlink(os.readlink(generated / "relocate1000").replace(".relocate1000.", ".more."), out)
    src = str(generated / "relocate10")
    again = cli("generate", "--from", src, "--out", str(out), "--episodes", "3")
    assert again.returncode == 1 and "already exists" in again.stderr and "--resume" in again.stderr
    other = cli("generate", "--from", src, "--out", str(out), "--episodes", "3", "--resume")  # no --scene this time
    assert other.returncode == 1 and "resume it with the same" in other.stderr, other.stderr
    more = cli("generate", "--from", src, "--out", str(out), "--episodes", "3", "--resume", "--scene",
               "placement_m=0.08", "--json")  # fmt: skip
    assert more.returncode == 0, more.stderr
    records = _records(out)
    first = _records(generated / "relocate1000")
    assert len(records) == 3 and records[:2] == first and records[2]["seed"] > first[1]["seed"]


def test_the_segments_match_the_events_in_the_recorded_states(generated):
    """Before the first touch the object is where it was put; its recorded height first passes 1 cm where the carry
    starts (the segmentation reads the simulator's events, checked here against the dataset's own states)."""
    from envs.tasks.registry import get_task
    from envs.tasks.segments import LIFT_M
    from policies.dataref import recorded_options, resolve
    from policies.generate import check_source, load_sources

    ref = resolve("me/relocate10", root=generated / "relocate10")
    spec, first, records = check_source(ref)
    assert spec is get_task("relocate")
    from policies.data import dataset_info

    sources = load_sources(ref, spec, records, recorded_options(dataset_info(ref.root), first), first["robot"])
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("me/relocate10", root=ref.root)
    env_state = ds.hf_dataset.with_format("numpy")[:]
    for s in sources:
        rows = env_state["observation.environment_state"][env_state["episode_index"] == s.episode]
        obj = rows[:, :3]
        names = [seg.name for seg in s.segments]
        assert names[:3] == ["reach", "grasp", "carry"], names
        touch, lift = s.segments[1].start, s.segments[2].start
        assert np.abs(obj[:touch] - obj[0]).max() < 0.005  # untouched: where it was put (settling, a ball rolling)
        rise = obj[:, 2] - obj[0, 2]
        assert rise[lift] > LIFT_M and (rise[touch:lift] <= LIFT_M).all()


def test_the_task_segmentations_split_on_their_events():
    from envs.tasks.hand_relocate import RelocateSegmentation
    from envs.tasks.hand_turn import TurnSegmentation

    touching = np.array([0, 0, 0, 1, 2, 2, 2, 2, 2, 0, 0], float)
    rise = np.array([0, 0, 0, 0, 0, 0.02, 0.05, 0.02, 0.0, 0, 0])
    segs = RelocateSegmentation().split({"touching": touching, "rise": rise})
    assert [(s.name, s.start, s.end, s.anchor) for s in segs] == [
        ("reach", 0, 3, "object"), ("grasp", 3, 5, "object"), ("carry", 5, 9, "target"), ("release", 9, 11, "target")
    ]  # fmt: skip
    never = RelocateSegmentation().split({"touching": np.zeros(5), "rise": np.zeros(5)})
    assert [(s.name, s.start, s.end) for s in never] == [("reach", 0, 5)]
    angle = np.array([0, 0, 1, 3, 10, 30, 40, 40, 40])
    segs = TurnSegmentation().split({"touching": np.array([0, 2, 2, 2, 2, 2, 2, 0, 0], float), "angle_deg": angle})
    assert [(s.name, s.start, s.end) for s in segs] == [("grip", 0, 3), ("turn", 3, 7), ("release", 7, 9)]


def test_generating_from_what_cannot_be_is_one_line_and_writes_nothing(pose_recording, tmp_path):
    src, _ = pose_recording
    out = tmp_path / "out"
    r = cli("generate", "--from", str(src), "--out", str(out))  # HandPose: no segmentation
    assert r.returncode == 1 and "the pose task has no segmentation" in r.stderr and "relocate" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()

    bare = tmp_path / "bare"
    shutil.copytree(src, bare)
    (bare / "meta" / "gloverec" / "episodes.jsonl").unlink()
    r = cli("generate", "--from", str(bare), "--out", str(out))
    assert r.returncode == 1 and "no gloverec episode records" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()

    foreign = tmp_path / "foreign"
    shutil.copytree(src, foreign)
    sidecar = foreign / "meta" / "gloverec" / "episodes.jsonl"
    sidecar.write_text("".join(json.dumps({**x, "env_task": "juggle"}) + "\n" for x in _records(foreign)))
    r = cli("generate", "--from", str(foreign), "--out", str(out))
    assert r.returncode == 1 and "unknown task 'juggle'" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not out.exists()

    r = cli("generate", "--from", str(src), "--out", str(out), "--seeds", "9-3")
    assert r.returncode == 2 and "FIRST-LAST" in r.stderr and not out.exists()
    assert POSE_REPO  # the recording is the shared one, unchanged (copied before any edit)


def test_the_review_list_shows_and_filters_by_source(generated):
    from recorder.review.session import Session

    rows = Session("me/relocate1000", root=str(generated / "relocate1000")).describe()["episodes"]
    assert all(r["source"].startswith("ep ") and r["source"].endswith(" of me/relocate10") for r in rows)
    assert not any("generated from" in (r["intent"] or "") for r in rows)  # said once, in its own column
    recorded = Session("me/relocate10", root=str(generated / "relocate10")).describe()["episodes"]
    assert all(r["source"] is None for r in recorded)
