"""Takeover recording (`gloverec record --policy DIR --takeover`, recorder/record/takeover.py): a policy drives, the
wearer takes over when their hand departs from the policy's, and both actions and the intervention flag are stored;
`gloverec train --also` trains on the demonstrations and the corrections together."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from docs_runner import ROOT, run_blocks_of

import envs
from conftest import cli
from recorder.record.takeover import POLICY, WEARER, Takeover, TakeoverConfig

FPS = 30
LOW, HIGH = np.zeros(4), np.ones(4)


def _run(takeover: Takeover, departures: list[float]) -> list[bool]:
    """The intervention flags of frames whose wearer is ``d`` away from the policy on every element."""
    return [takeover.decide(np.zeros(4), np.full(4, d)).intervention for d in departures]


def test_the_wearer_takes_over_after_the_hold_and_not_before():
    t = Takeover(TakeoverConfig(threshold=0.2, hold_s=0.1), LOW, HIGH, FPS)  # 3 frames
    flags = _run(t, [0.1, 0.3, 0.3, 0.1, 0.3, 0.3, 0.3, 0.0, 0.0])
    assert flags == [False, False, False, False, False, False, True, True, True]  # a dip below restarts the count
    assert t.summary() == {"frames_by_wearer": 3, "switches": [{"frame": 6, "to": WEARER}], "interventions": 1}


def test_the_key_gives_control_back_and_the_takeover_waits_for_the_wearer_to_come_back():
    t = Takeover(TakeoverConfig(threshold=0.2, hold_s=0.1), LOW, HIGH, FPS)
    flags = _run(t, [0.5] * 4)
    t.toggle()  # the key: back to the policy
    assert t.who == POLICY
    flags += _run(t, [0.5] * 5)  # still away: no takeover until the wearer has been back within the threshold
    flags += _run(t, [0.0, 0.5, 0.5, 0.5])
    assert flags == [False, False, True, True] + [False] * 5 + [False, False, False, True]
    t.toggle()  # the key again: back to the policy; once more: the wearer at once
    t.toggle()
    assert _run(t, [0.0]) == [True]


def test_without_auto_only_the_key_passes_control():
    t = Takeover(TakeoverConfig(threshold=0.2, hold_s=0.0, auto=False), LOW, HIGH, FPS)
    assert _run(t, [0.9, 0.9]) == [False, False]
    t.toggle()
    assert _run(t, [0.9]) == [True]


def test_departure_is_the_largest_share_of_an_elements_range():
    t = Takeover(TakeoverConfig(), np.array([-1.0, 0.0, 0.0]), np.array([1.0, 0.5, 1.0]), FPS)
    assert t.departure([0.0, 0.0, 0.0], [0.5, 0.25, 0.0]) == pytest.approx(0.5)  # 0.25 of 2, 0.25 of 0.5, 0
    assert t.departure([0.0, 0.0, 0.0], [0.0, 0.0, 0.3]) == pytest.approx(0.3)  # one element is enough
    assert t.departure([0.0, 0.0, 0.0], [9.0, 9.0, 0.0]) == 1.0  # an element counts at most its whole range


def _documented_block() -> int:
    return next(k for k, b in enumerate(run_blocks_of(ROOT / "docs" / "recording.md")) if "--takeover" in b.text)


def test_a_documented_takeover_session_stores_both_actions_and_flags_that_follow_the_rule(docs_run):
    """The commands of docs/recording.md's takeover block, as written: the flags switch to the wearer exactly where
    the stored departure has been above the threshold for the hold time, the applied action is the policy's until
    then, and training on the demonstrations with the corrections (--also) counts the wearer's frames."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    work = docs_run("recording.md", _documented_block())
    ds = LeRobotDataset("me/grasp_takeover", root=work / "grasp_takeover")
    data = ds.hf_dataset.with_format("numpy")
    frames = {k: np.asarray(data[k]) for k in ("episode_index", "intervention", "quality.departure", "action",
                                               "policy.action", "expert.action", "expert.offset")}  # fmt: skip
    # the wearer's action is kept on every frame, the policy's included (DAgger's labels: --learn-from intended)
    assert np.array_equal(frames["expert.offset"], frames["action"] - frames["expert.action"])
    need = math.ceil(TakeoverConfig().hold_s * ds.fps - 1e-9)
    space = envs.make("grasp", "glovehand").action_space
    lines = (work / "grasp_takeover/meta/gloverec/episodes.jsonl").read_text().splitlines()
    records = [json.loads(x) for x in lines if x.strip()]
    for ep, record in zip(range(ds.meta.total_episodes), records, strict=True):
        rows = np.flatnonzero(frames["episode_index"] == ep)
        flags = frames["intervention"][rows].ravel().astype(bool)
        departure = frames["quality.departure"][rows].ravel()
        above = departure > TakeoverConfig().threshold
        runs = np.convolve(above, np.ones(need), "full")[: len(above)] >= need  # `need` frames in a row above
        first = int(np.argmax(runs)) if runs.any() else len(flags)
        assert not flags[:first].any() and flags[first:].all(), (ep, first, np.flatnonzero(flags)[:3])
        applied, proposed = frames["action"][rows], frames["policy.action"][rows]
        clipped = np.clip(proposed[:first], space.low, space.high)  # the environment applies it within its limits
        assert np.allclose(applied[:first], clipped, atol=1e-5)  # the policy drove until the takeover
        wearer = frames["expert.action"][rows]
        assert np.array_equal(wearer[first:], applied[first:])  # then the wearer: the label is what was done
        span = space.high - space.low
        departure_from_label = np.max(np.abs(wearer - np.clip(proposed, space.low, space.high)) / span, axis=1)
        assert np.allclose(departure_from_label[:first], departure[:first], atol=1e-3)  # the wearer's, not the policy's
        assert record["takeover"]["frames_by_wearer"] == int(flags.sum())
        assert [s["frame"] for s in record["takeover"]["switches"]] == ([first] if first < len(flags) else [])
    summary = json.loads((work / "bc2" / "train_summary.json").read_text())
    assert summary["also"][0]["root"] == str(work / "grasp_takeover")
    assert summary["also"][0]["repo_id"] == "me/grasp_takeover"  # as recorded, not the folder's parent's name
    assert summary["frames_by_wearer"] > 0


def test_a_policy_for_another_task_or_robot_is_one_line_and_writes_nothing(docs_run, tmp_path):
    work = docs_run("recording.md", _documented_block())
    for flags, said in ((["--task", "pose"], "trained for grasp on glovehand, not pose on glovehand"),
                        (["--task", "grasp", "--robot", "shadow"], "not grasp on shadow")):  # fmt: skip
        r = cli("record", "--glove", "emulator", *flags, "--policy", str(work / "bc"), "--takeover", "--episodes",
                "1", "--root", str(tmp_path / "x"), "--view", "none")  # fmt: skip
        assert r.returncode == 1 and said in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert not (tmp_path / "x").exists()
    r = cli("record", "--glove", "emulator", "--task", "grasp", "--takeover", "--root", str(tmp_path / "x"))
    assert r.returncode == 1 and "pass --policy DIR too" in r.stderr


def test_training_refuses_a_dataset_of_another_robot_in_one_line(docs_run, pose_recording, tmp_path):
    work = docs_run("recording.md", _documented_block())
    root, _ = pose_recording
    r = cli("train", "--repo-id", "me/grasp", "--root", str(work / "grasp"), "--also", str(root), "--out",
            str(tmp_path / "out"), "--steps", "1")  # fmt: skip
    assert r.returncode == 1 and ("differs between me/grasp and" in r.stderr or "has no" in r.stderr), r.stderr
    assert not (tmp_path / "out").exists()


def test_the_key_gives_control_back_to_the_policy_mid_episode(docs_run, tmp_path):
    """A session in this process with the documented policy: the wearer (the human-like demonstrator) takes over, the
    takeover key at frame 60 gives control back, and the stored flags say so frame by frame."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from policies.evaluate import load_for_recording
    from recorder.record.config import RecordConfig
    from recorder.record.control import TAKEOVER, Control
    from recorder.record.recorder import Recorder

    work = docs_run("recording.md", _documented_block())
    control = Control(enabled=False)

    class KeyAtFrame60:  # the wearer presses t at frame 60 (the env's step count is the frame's index)
        def __init__(self, env):
            self.policy, self.env = load_for_recording(work / "bc", env, "grasp", "glovehand", FPS), env.unwrapped

        def reset(self, env, seed):
            self.policy.reset(env, seed)

        def act(self, obs):
            if self.env.steps == 59:
                control.request(TAKEOVER)  # taken after frame 59: frame 60 is the policy's again
            return self.policy.act(obs)

    cfg = RecordConfig.load(glove="emulator", task="grasp", episodes=1, seed=100, root=str(tmp_path / "ds"),
                            repo_id="me/key", view="none", log=False, demonstrator="human", failure_rate=0.0,
                            policy=str(work / "bc"), takeover=True)  # fmt: skip
    Recorder(cfg, control=control, out=None, agent=KeyAtFrame60).run()
    flags = np.asarray(LeRobotDataset("me/key", root=tmp_path / "ds").hf_dataset.with_format("numpy")["intervention"])
    flags = flags.ravel().astype(bool)
    record = json.loads((tmp_path / "ds/meta/gloverec/episodes.jsonl").read_text().splitlines()[0])["takeover"]
    switches = [(s["frame"], s["to"]) for s in record["switches"]]
    assert switches[0][1] == WEARER and switches[0][0] < 60 and switches[1] == (60, POLICY), switches
    expected = np.zeros(len(flags), bool)
    for (k, who), (k_next, _) in zip(switches, [*switches[1:], (len(flags), None)]):
        expected[k:k_next] = who == WEARER
    assert (flags == expected).all()


def test_a_takeover_recording_first_trains_with_plain_demonstrations_after_it(docs_run, tmp_path):
    """Either order: the takeover recording as the dataset and the demonstrations as --also (its extra features are
    not the policy's inputs, so they are not loaded)."""
    work = docs_run("recording.md", _documented_block())
    r = cli("train", "--repo-id", "me/grasp_takeover", "--root", str(work / "grasp_takeover"), "--also",
            str(work / "grasp"), "--out", str(tmp_path / "out"), "--steps", "2", "--json")  # fmt: skip
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout.strip().splitlines()[-1])
    assert summary["frames_by_wearer"] > 0 and summary["also"][0]["root"] == str(work / "grasp")
