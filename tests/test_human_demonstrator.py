"""The human-like demonstrator (issue 26): its failure share follows the setting, its meant failures fail and its
other takes mostly succeed, through the physics; it records through the whole stack and says what it meant."""

from __future__ import annotations

import json

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

import envs
from conftest import cli
from recorder.demonstrator import make_demonstrator
from recorder.record.sidecar import read_sidecar
from recorder.rig.rollout import success_rate


@pytest.mark.parametrize("task", ["grasp", "pinch", "pose", "keys", "turn", "relocate", "pick"])
@pytest.mark.parametrize("rate", [0.15, 0.4])
def test_the_share_of_failed_takes_follows_the_setting(task, rate):
    """Over 50 takes (whether a take is meant to fail is drawn from the plan's seed alone: ``meant_failure`` says so
    without planning; the plans of a few seeds in one scene say the same)."""
    env = envs.make(task).unwrapped
    env.reset(seed=0)
    demo = make_demonstrator(task, "human", rate)
    meant = [demo.meant_failure(seed) is not None for seed in range(50)]
    assert abs(np.mean(meant) - rate) <= 0.10, np.mean(meant)
    for seed in [*meant.index(True) + np.arange(2), meant.index(False)]:
        assert (demo.plan(env, seed=int(seed)).intent["failure"] is not None) == meant[seed], seed


@pytest.mark.parametrize(("task", "good_of_6"), [("grasp", 5), ("pinch", 4), ("pose", 6), ("keys", 6), ("turn", 6),
                                                  ("relocate", 6), ("pick", 5)])  # fmt: skip
def test_meant_failures_fail_and_the_other_takes_succeed(task, good_of_6):
    failing = success_rate(task, "glovehand", 6, demonstrator="human", failure_rate=1.0)
    assert failing["successes"] == 0, [r["intent"] for r in failing["runs"]]
    kinds = {r["intent"]["failure"] for r in failing["runs"]}
    assert len(kinds) == 2, kinds  # both kinds of mistake happen
    good = success_rate(task, "glovehand", 6, seed0=100, demonstrator="human", failure_rate=0.0)
    assert good["successes"] >= good_of_6, good["runs"]  # 50 seeds: grasp 43, pinch 38, pose 50 (docs/envs.md)
    assert {r["intent"]["strategy"] for r in good["runs"]} == STRATEGIES[task]


STRATEGIES = {"grasp": {"together", "thumb first"}, "pinch": {"together", "thumb first"},
              "pose": {"together", "thumb last"}, "keys": {"quick taps", "deliberate presses"},
              "turn": {"one sweep", "two sweeps"}, "relocate": {"together", "thumb first"},
              "pick": {"together", "thumb first"}}  # fmt: skip


def test_it_moves_as_people_do_not_as_the_script():
    """Same seed, same take; its reaction times lie in people's range; its tremor is larger than the script's."""
    env = envs.make("pose").unwrapped
    env.reset(seed=4)
    human, script = make_demonstrator("pose", "human"), make_demonstrator("pose")
    a, b = human.plan(env, seed=4), human.plan(env, seed=4)
    np.testing.assert_array_equal(a.times, b.times)
    starts = []
    for seed in range(30):
        env.reset(seed=seed)
        starts.append(human.plan(env, seed=seed).times[1])
    assert 0.18 <= min(starts) and max(starts) <= 0.40 and 0.22 < np.median(starts) < 0.28
    t = np.arange(0.0, 0.15, 1 / 200.0)  # the open hand held before the reaction: tremor and wander only
    assert np.ptp(a.angles(t), axis=0).max() > 2 * np.ptp(script.plan(env, seed=4).angles(t), axis=0).max()


def test_record_with_the_human_demonstrator_keeps_what_it_meant(tmp_path):
    root = tmp_path / "ds"
    r = cli("record", "--glove", "emulator", "--task", "grasp", "--episodes", "2", "--demonstrator", "human",
            "--failure-rate", "1", "--root", str(root), "--repo-id", "test/human", "--view", "none", "--no-log",
            "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout.strip().splitlines()[-1])["success_rate"] == 0.0
    assert LeRobotDataset("test/human", root=root).num_episodes == 2
    records = read_sidecar(root)
    assert [rec["demonstration"]["failure"] in ("too loose", "lets go") for rec in records] == [True, True]
    shown = cli("inspect", "--repo-id", "test/human", "--root", str(root), "--no-plot")
    assert shown.returncode == 0 and shown.stdout.count("[meant to fail: ") == 2, shown.stdout


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--glove", "serial:/dev/null", "--demonstrator", "human"], "record with --glove emulator"),
        (["--demonstrator", "human", "--failure-rate", "2"], "failure rate 2: expected a share from 0 to 1"),
        (["--demonstrator", "robot"], "--demonstrator"),
    ],
)
def test_a_bad_demonstrator_setting_is_one_line(tmp_path, args, says):
    r = cli("record", *args, "--root", str(tmp_path / "ds"), "--episodes", "1", "--view", "none")
    assert r.returncode != 0 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "ds").exists()
