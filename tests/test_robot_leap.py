"""The third robot, the four-fingered LEAP hand, added by an MJCF wrapper and a yaml alone: it loads from the
installed package in place, the scripted demonstrator solves its tasks, and it records (with a wearer's hand
profile, which reaches the dataset and the session log), trains and evaluates with the existing commands."""

import json
import os

import numpy as np
import pytest

import envs
from conftest import cli, gloverec
from envs.robots import load_robot, robot_names
from recorder.hand.profile import HandProfile, save_profile
from recorder.log.playback import read_log
from recorder.paths import assets_dir
from recorder.retarget import Retargeter
from recorder.rig.rollout import run_episode

REPO = "test/leap"


def test_leap_is_used_in_place_from_its_package():
    r = load_robot("leap")
    assert "leap" in robot_names()
    assert r.fingers == ("thumb", "index", "middle", "ring") and r.model.nu == 16
    assert "site-packages" in r._xml and "leap_hand/right_hand.xml" in r._xml  # the package's model, included
    assert sorted(p.name for p in (assets_dir() / "leap").iterdir()) == ["leap.xml"]  # nothing copied here
    assert all(r.model.site(s).id >= 0 for s in r.tip_sites)  # the fingertip sites the yaml adds


@pytest.mark.parametrize("task, seeds, need", [("pose", (0, 1, 2), 3), ("grasp", (0, 1, 2, 3), 3)])
def test_the_demonstrator_succeeds_on_leap(task, seeds, need):
    env = envs.make(task, "leap")
    r = Retargeter("leap", "joint", base_rotation=env.unwrapped.config.base_rotation)
    ok = sum(run_episode(env, r, seed)["success"] for seed in seeds)
    env.close()
    assert ok >= need, f"{ok}/{len(seeds)}"


def test_leaps_fist_goal_is_the_one_its_colliding_fingers_reach_from_the_open_hand():
    # LEAP's joint-mapped fist drives the thumb into the index finger: which stops the other depends on the path
    env = envs.make("pose", "leap")
    r = Retargeter("leap", "joint", base_rotation=env.unwrapped.config.base_rotation)
    runs = [run_episode(env, r, seed) for seed in (11, 14, 27)]
    env.close()
    assert {x["goal"] for x in runs} == {"fist"} and all(x["success"] for x in runs), runs


@pytest.fixture(scope="session")  # session: kept while other modules run on this worker
def recorded(tmp_path_factory):
    base = tmp_path_factory.mktemp("leap")
    cal = base / "cal"
    profile = HandProfile("ana", 172.0, 79.0, {"thumb": (46.0, 35.0, 28.0)})
    save_profile(profile, cal)
    env = {**os.environ, "GLOVEREC_CALIBRATION_DIR": str(cal)}
    root = base / "ds"
    r = gloverec(
        "record", "--glove", "emulator", "--task", "pinch", "--robot", "leap", "--episodes", "2",
        "--root", str(root), "--repo-id", REPO, "--fast", "--wearer", "ana", "--retarget", "pinch", "--json",
        timeout=180, env=env,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    return base, root, profile, env, json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.process
@pytest.mark.xdist_group("leap_recorded")  # its module fixture made once, on one worker
def test_leap_records_with_the_wearers_profile(recorded):
    base, root, profile, env, summary = recorded
    assert summary["episodes_saved"] == 2
    stored = json.loads((root / "meta" / "gloverec" / "hand_profile.json").read_text())
    assert {k: v for k, v in stored.items() if k != "created"} == {
        k: v for k, v in profile.as_dict().items() if k != "created"
    }
    sidecar = [json.loads(line) for line in (root / "meta" / "gloverec" / "episodes.jsonl").read_text().splitlines()]
    assert {s["wearer"] for s in sidecar} == {"ana"} and {s["retarget"] for s in sidecar} == {"pinch"}
    info = json.loads((root / "meta" / "info.json").read_text())
    assert info["robot_type"] == "leap" and info["features"]["action"]["shape"] == [19]  # 16 servos + palm
    assert "pinch.finger.is_index" in info["features"]["observation.environment_state"]["names"]  # LEAP pinches
    log = read_log(str(root / summary["log"]))
    assert json.loads(log.session["hand_profile"])["hand_breadth_mm"] == 79.0
    # re-recorded from its log elsewhere (no saved profile there): the profile comes with the log
    r = gloverec(
        "rerecord", "--log", str(root / summary["log"]), "--repo-id", "test/leap2", "--root", str(base / "again"),
        "--json", timeout=180, env={**env, "GLOVEREC_CALIBRATION_DIR": str(base / "empty")},
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    again = json.loads((base / "again" / "meta" / "gloverec" / "hand_profile.json").read_text())
    assert again["wearer"] == "ana" and again["segments_mm"]["thumb"] == [46.0, 35.0, 28.0]


@pytest.mark.xdist_group("leap_recorded")
def test_leap_trains_and_evaluates(recorded):
    base, root, _, env, _ = recorded
    out = base / "run"
    r = cli(
        "train", "--repo-id", REPO, "--root", str(root), "--steps", "20", "--batch-size", "32", "--out", str(out),
        "--all-episodes", "--json", env=env,  # (LEAP's pinch mostly fails: the takes as they are)
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    r = cli("eval", "--policy", str(out), "--episodes", "1", "--json", env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    result = json.loads(r.stdout.strip().splitlines()[-1])
    assert result["robot"] == "leap" and result["task"] == "pinch" and result["episodes"] == 1
    assert np.isfinite(result["mean_return"])


def test_a_missing_or_impossible_wearer_is_one_line(tmp_path):
    env = {**os.environ, "GLOVEREC_CALIBRATION_DIR": str(tmp_path)}
    (tmp_path / "wearers").mkdir()
    (tmp_path / "wearers" / "bad.json").write_text(json.dumps({"wearer": "bad", "hand_length_mm": 500}))
    for wearer, needle in [("nobody", "no hand profile for wearer 'nobody'"), ("bad", "hand length 500 mm")]:
        r = cli(
            "record", "--glove", "emulator", "--robot", "leap", "--episodes", "1", "--root", str(tmp_path / "ds"),
            "--fast", "--no-log", "--wearer", wearer, env=env,
        )  # fmt: skip
        err = r.stderr.strip()
        assert r.returncode == 1 and "\n" not in err and "Traceback" not in err and needle in err, err
        assert not (tmp_path / "ds").exists()  # refused before anything was written


def test_leaps_pinch_keeps_its_pads_off_the_table():
    # LEAP's distal links are about 20 mm thick: the pinch searched without the task's clearance left them resting
    # on the table for 89 % of the close (seeds 0-2: 96 of 108 control steps), the thumb 9 degrees short of its
    # target; with it, 3 of 108. (It does not yet hold the object through the lift: docs/envs.md says why.)
    env = envs.make("pinch", "leap")
    u = env.unwrapped
    r = Retargeter("leap", "joint", base_rotation=u.config.base_rotation)
    floor = u.model.geom("floor").id
    closing, on_table = 0, 0

    def on_step(obs, action, info):
        nonlocal closing, on_table
        if u.schedule["close"] <= u.t < u.schedule["lift"]:
            pads = {*u._distal_geoms["thumb"], *u._distal_geoms[u.finger]}
            contacts = u.data.contact[: u.data.ncon]
            closing += 1
            on_table += any(floor in (c.geom1, c.geom2) and {c.geom1, c.geom2} & pads for c in contacts)

    for seed in (0, 1, 2):
        run_episode(env, r, seed, on_step=on_step)
    env.close()
    assert closing > 0 and on_table <= 0.25 * closing, f"pads on the table {on_table} of {closing} steps"
