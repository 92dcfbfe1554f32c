"""The glove inside LeRobot's own tools: the teleoperator plugin (gloverec_glove) and the simulated-hand robot
plugin (gloverec_sim) with lerobot-record, lerobot-replay and lerobot-teleoperate as subprocesses, the datasets
they record trained by `gloverec train` and lerobot-train, and the teleoperator driving LeRobot's HopeJR hand."""

import json
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.robots.hope_jr.config_hope_jr import HopeJrHandConfig
from lerobot.robots.hope_jr.hope_jr_hand import HopeJrHand
from lerobot_robot_gloverec import GloverecSim, GloverecSimConfig
from lerobot_teleoperator_gloverec import GloverecGlove, GloverecGloveConfig

import envs
from conftest import EmulatorProcess, cli, gloverec
from recorder.config import ConfigError
from recorder.hand.gestures import GESTURES
from recorder.retarget.motor_map import load_motor_map

BIN = Path(sys.executable).parent


def lerobot(command: str, *args: str, timeout: int = 300) -> subprocess.CompletedProcess:
    """A LeRobot command line tool as a user runs it, headless (no display, no keyboard, no sounds)."""
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"} | {"OMP_NUM_THREADS": "1"}
    cmd = [str(BIN / f"lerobot-{command}"), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def glove(tmp_path_factory):
    emu = EmulatorProcess("--rate", "100", "--link", str(tmp_path_factory.mktemp("glove") / "glove"))
    yield emu
    emu.stop()


@pytest.fixture(scope="module")
def recorded(glove, tmp_path_factory):
    """lerobot-record: the emulated glove on a pseudo-terminal drives gloverec_sim, two short episodes."""
    root = tmp_path_factory.mktemp("lerobot") / "ds"
    r = lerobot(
        "record", "--robot.type=gloverec_sim", "--robot.robot=glovehand", "--robot.task=pose",
        "--teleop.type=gloverec_glove", f"--teleop.port=serial:{glove.port}", "--teleop.robot=glovehand",
        "--dataset.repo_id=test/lerobot_record", f"--dataset.root={root}", "--dataset.push_to_hub=false",
        "--dataset.num_episodes=2", "--dataset.episode_time_s=2", "--dataset.reset_time_s=0.5",
        "--dataset.single_task=make the gesture", "--dataset.video=false", "--play_sounds=false",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    return root


def test_lerobot_record_with_the_glove_and_the_sim_makes_a_plain_lerobot_dataset(recorded):
    ds = LeRobotDataset("test/lerobot_record", root=recorded)
    env = envs.make("pose", "glovehand", state_includes_task=True).unwrapped
    assert ds.num_episodes == 2 and ds.meta.robot_type == "gloverec_sim:pose:glovehand" and ds.fps == 30
    assert ds.meta.features["action"]["names"] == list(env.action_names)
    assert ds.meta.features["observation.state"]["names"] == list(env.state_names)
    assert any(n.startswith("goal.") for n in env.state_names)  # the task's state rides in observation.state
    actions = np.stack([ds[i]["action"].numpy() for i in range(0, len(ds), 10)])
    assert np.ptp(actions[:, :20], axis=0).max() > 0.1  # the glove's hand moved the robot's joints


def test_lerobot_replay_runs_an_episode_on_the_sim(recorded):
    r = lerobot("replay", "--robot.type=gloverec_sim", "--robot.robot=glovehand", "--robot.task=pose",
                "--dataset.repo_id=test/lerobot_record", f"--dataset.root={recorded}", "--dataset.episode=1",
                "--play_sounds=false")  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]


def test_gloverec_train_and_eval_take_a_lerobot_record_dataset(recorded, tmp_path):
    out = tmp_path / "policy"
    r = gloverec("train", "--repo-id", "test/lerobot_record", "--root", str(recorded), "--steps", "30",
                 "--out", str(out), "--json", timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr
    # no sidecar: the task and the robot come from the robot_type lerobot-record stored (gloverec_sim:pose:glovehand)
    r = gloverec("eval", "--policy", str(out), "--episodes", "2", "--json", timeout=300)
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["task"] == "pose" and result["robot"] == "glovehand" and result["episodes"] == 2


def test_lerobot_train_takes_a_lerobot_record_dataset(recorded, tmp_path):
    out = tmp_path / "lerobot_train"
    r = lerobot("train", "--policy.type=gloverec_bc", "--policy.push_to_hub=false", "--policy.device=cpu",
                "--policy.hidden_dim=64", "--dataset.repo_id=test/lerobot_record", f"--dataset.root={recorded}",
                "--steps=5", "--batch_size=8", "--save_freq=5", "--log_freq=5", "--eval_freq=0",
                "--num_workers=0", f"--output_dir={out}")  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    assert (out / "checkpoints" / "last" / "pretrained_model" / "model.safetensors").is_file()


def test_lerobot_teleoperate_drives_the_sim_and_a_robot_mismatch_is_one_line(glove):
    common = ("--robot.type=gloverec_sim", "--robot.robot=glovehand", "--teleop.type=gloverec_glove",
              f"--teleop.port=serial:{glove.port}", "--teleop_time_s=1", "--fps=30")  # fmt: skip
    r = lerobot("teleoperate", *common, "--teleop.robot=glovehand")
    assert r.returncode == 0, r.stderr[-3000:]
    r = lerobot("teleoperate", *common, "--teleop.robot=shadow")
    assert r.returncode != 0
    last = r.stderr.strip().splitlines()[-1]
    assert "gloverec_sim drives glovehand, but the action has no 'thumb_cmc_flex'" in last, last


# ---------------------------------------------------------------- the plugins' API


def test_the_teleoperator_drives_lerobots_hope_jr_hand():
    teleop = GloverecGlove(GloverecGloveConfig(port="emulator", robot="hope_jr_hand"))
    hand = HopeJrHand(HopeJrHandConfig(port="/dev/null", side="right"))  # no hardware: the bus is not opened
    assert teleop.action_features == hand.action_features
    motors = load_motor_map("hope_jr_hand")
    flat, fist, pinch = (motors(GESTURES[g]) for g in ("open", "fist", "pinch"))
    flexors = [k for k in flat if k.endswith(("_flexor.pos", "_pip_dip.pos"))]
    assert max(flat[k] for k in flexors) < 25  # open hand: tendons slack
    assert min(fist[k] for k in flexors) > 45 and fist["index_pip_dip.pos"] > 85  # a fist: all pulled
    assert 15 < pinch["index_radial_flexor.pos"] < fist["index_radial_flexor.pos"]  # a pinch: in between
    assert pinch["thumb_pip.pos"] > flat["thumb_pip.pos"] + 20  # the thumb comes in
    # abduction toward the thumb pulls the radial tendon more than the ulnar one (the splay mix)
    spread = GESTURES["open"].copy()
    spread[5] = np.radians(20.0)  # index_mcp_abd
    spread_targets = motors(spread)
    assert spread_targets["index_radial_flexor.pos"] > spread_targets["index_ulnar_flexor.pos"] + 20
    assert all(0.0 <= v <= 100.0 for t in (flat, fist, pinch) for v in t.values())


def test_a_silent_glove_gives_the_held_pose_without_waiting(tmp_path, caplog):
    emu = EmulatorProcess("--rate", "100", "--link", str(tmp_path / "glove"))
    teleop = GloverecGlove(GloverecGloveConfig(port=f"serial:{emu.port}", robot="glovehand"))
    try:
        teleop.connect()
        first = teleop.get_action()
        assert set(first) == set(teleop.action_features)
        emu.unplug()
        time.sleep(0.3)
        caplog.set_level(logging.INFO)
        t = time.monotonic()
        held = [teleop.get_action() for _ in range(20)]
        assert time.monotonic() - t < 0.2  # never waits for the glove
        assert all(a == held[0] for a in held)
        stalls = [r for r in caplog.records if "holding the last one" in r.getMessage()]
        assert len(stalls) == 1  # logged once per stall
        emu.replug()
        end = time.monotonic() + 10
        while time.monotonic() < end and teleop.get_action() == held[0]:
            time.sleep(0.05)
        assert teleop.get_action() != held[0]
        assert any("hand poses again" in r.getMessage() for r in caplog.records)
    finally:
        if teleop.is_connected:
            teleop.disconnect()
        emu.stop()


def test_a_missing_glove_and_a_bad_robot_are_one_line(tmp_path):
    teleop = GloverecGlove(GloverecGloveConfig(port=str(tmp_path / "nope"), robot="glovehand"))
    with pytest.raises(Exception) as exc:
        teleop.connect()
    assert "no such port" in str(exc.value) and "\n" not in str(exc.value)
    hands = ", ".join(envs.robot_names())
    with pytest.raises(ConfigError, match=f"unknown robot 'r2d2'; robot hands: {hands}; motor maps: hope_jr_hand"):
        GloverecGlove(GloverecGloveConfig(robot="r2d2"))
    with pytest.raises(ValueError, match="unknown robot 'r2d2'"):
        GloverecSim(GloverecSimConfig(robot="r2d2"))


def test_the_sim_resets_its_scene_when_the_task_ends():
    sim = GloverecSim(GloverecSimConfig(robot="glovehand", task="pose", seed=7))
    sim.connect()
    try:
        obs = sim.get_observation()
        assert set(obs) == set(sim.observation_features)
        still = {k: 0.0 for k in sim.action_features}  # never reaches the goal: the time limit ends the scene
        for _ in range(int(5.0 * 30) + 1):
            sim.send_action(still)
        assert sim.episodes == 1 and sim.seed == 8
    finally:
        sim.disconnect()
    grasp = GloverecSim(GloverecSimConfig(robot="glovehand", task="grasp", seed=3))
    grasp.connect()
    try:
        open_hand = {k: 0.0 for k in grasp.action_features}  # the object is never lifted: dropped, not held
        steps = 0
        while grasp.episodes == 0 and steps < 30 * 6:
            grasp.send_action(open_hand)
            steps += 1
        assert grasp.episodes == 1 and steps < 5.5 * 30  # before the task's time limit
    finally:
        grasp.disconnect()


def test_the_teleoperator_retargets_with_the_wearers_hand_profile(tmp_path):
    """`--teleop.wearer=NAME` (docs/lerobot.md), as `gloverec record --wearer NAME`: the saved profile's hand
    size reaches the retargeter; a wearer with no profile is one line before any glove opens."""
    from recorder.hand.profile import load_profile

    r = cli("calibrate", "--wearer", "ana", "--hand-length", "170", "--hand-breadth", "80", "--dir", str(tmp_path))
    assert r.returncode == 0, r.stderr
    teleop = GloverecGlove(GloverecGloveConfig(robot="shadow", wearer="ana", calibration_dir=tmp_path))
    assert teleop.target.retarget.hand_size == load_profile("ana", tmp_path).size()
    assert (
        GloverecGlove(GloverecGloveConfig(robot="shadow")).target.retarget.hand_size
        != load_profile("ana", tmp_path).size()
    )
    with pytest.raises(ConfigError, match="no hand profile for wearer 'bo'"):
        GloverecGlove(GloverecGloveConfig(robot="shadow", wearer="bo", calibration_dir=tmp_path))
