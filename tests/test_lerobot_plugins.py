"""The glove inside LeRobot's own tools: the teleoperator plugin (gloverec_glove) and the simulated-hand robot
plugin (gloverec_sim). lerobot-record, lerobot-teleoperate, lerobot-replay, `gloverec train` and lerobot-train run
as docs/lerobot.md writes them (tests/test_docs.py); here, what they made, the plugins' API, and the teleoperator
driving LeRobot's HopeJR hand."""

import json
import logging
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
from conftest import EmulatorProcess, cli, wait_for
from recorder.config import ConfigError
from recorder.hand.gestures import GESTURES
from recorder.lerobot_names import gloverec_names
from recorder.retarget.motor_map import load_motor_map

pytestmark = pytest.mark.xdist_group("lerobot.md")  # with the docs block whose outputs these tests read


@pytest.fixture(scope="module")
def lerobot_run(docs_run) -> Path:
    """docs/lerobot.md's commands, run as written (tests/test_docs.py, the conftest's docs_run): the emulated glove
    on a pseudo-terminal, lerobot-record into datasets/recordings/me/glove_pose (two short episodes),
    lerobot-teleoperate, lerobot-replay, `gloverec train` into datasets/policies/lr_bc, `gloverec eval`, and
    lerobot-train into outputs/lr_bc. Here: what they made."""
    return docs_run("lerobot.md")


@pytest.fixture(scope="module")
def recorded(lerobot_run) -> Path:
    return lerobot_run / "datasets" / "recordings" / "me" / "glove_pose"


def test_lerobot_record_with_the_glove_and_the_sim_makes_a_plain_lerobot_dataset(recorded):
    ds = LeRobotDataset("me/glove_pose", root=recorded)
    env = envs.make("pose", "glovehand", state_includes_task=True).unwrapped
    assert ds.num_episodes == 2 and ds.meta.robot_type == "gloverec_sim:pose:glovehand" and ds.fps == 30
    names = {k: ds.meta.features[k]["names"] for k in ("action", "observation.state")}
    assert all(n.endswith(".pos") for n in names["action"])  # what lerobot-rollout passes (recorder/lerobot_names.py)
    assert gloverec_names(names) == {"action": list(env.action_names), "observation.state": list(env.state_names)}
    assert any(n.startswith("goal.") for n in env.state_names)  # the task's state rides in observation.state
    assert not (recorded / "meta" / "gloverec").exists()  # a plain LeRobot dataset: no sidecar of ours
    actions = np.stack([ds[i]["action"].numpy() for i in range(0, len(ds), 10)])
    assert np.ptp(actions[:, :20], axis=0).max() > 0.1  # the glove's hand moved the robot's joints


def test_gloverec_train_and_eval_take_a_lerobot_record_dataset(lerobot_run):
    """`gloverec train` made a checkpoint of the lerobot-record dataset; eval finds its task and robot in the
    robot_type lerobot-record stored (gloverec_sim:pose:glovehand), the dataset having no sidecar."""
    r = cli("eval", "--policy", str(lerobot_run / "datasets" / "policies" / "lr_bc"), "--episodes", "1", "--json")
    assert r.returncode == 0, r.stderr
    result = json.loads(r.stdout)
    assert result["task"] == "pose" and result["robot"] == "glovehand" and result["episodes"] == 1


def test_lerobot_train_takes_a_lerobot_record_dataset(lerobot_run):
    assert (
        lerobot_run / "outputs" / "lr_bc" / "checkpoints" / "last" / "pretrained_model" / "model.safetensors"
    ).is_file()


def test_lerobot_rollout_runs_the_policy_and_records_as_lerobot_does(lerobot_run, recorded):
    """docs/lerobot.md's `lerobot-rollout --strategy.type=base` ran the lerobot-train policy on gloverec_sim for its
    duration (tests/test_docs.py), and `--strategy.type=episodic` recorded its episodes: a LeRobot dataset with
    lerobot-record's features, all of pose's state passed to the policy."""
    ds = LeRobotDataset(
        "me/rollout_glove_pose", root=lerobot_run / "datasets" / "recordings" / "me" / "rollout_glove_pose"
    )
    recorded_features = LeRobotDataset("me/glove_pose", root=recorded).meta.features
    assert ds.num_episodes == 2 and ds.meta.robot_type == "gloverec_sim:pose:glovehand" and len(ds) > 20
    for key in ("action", "observation.state"):
        assert ds.meta.features[key] == recorded_features[key]
    assert all(n.endswith((".pos", ".vel")) for n in ds.meta.features["observation.state"]["names"])


def test_every_sim_value_keeps_its_meaning_and_old_names_read_back():
    """gloverec_sim names a value ``.pos`` only where it is a position (lerobot-rollout passes those): every pose
    value, not an object's size or a flag; a dataset's names in either naming read back as the task's; an action
    in the old names (lerobot-replay of an older dataset) still drives the hand."""
    sim = GloverecSim(GloverecSimConfig(robot="glovehand", task="grasp"))
    u = sim.unwrapped
    kept = [n for n in sim.observation_features if not n.endswith((".pos", ".vel"))]
    assert kept == ["object.hx", "object.hy", "object.hz", "object.is_box", "object.is_cylinder", "object.is_sphere"]
    assert "object.qw.pos" in sim.observation_features and "palm.x.pos" in sim.observation_features
    named = {"observation.state": list(sim.observation_features), "action": list(sim.action_features)}
    ours = {"observation.state": list(u.state_names), "action": list(u.action_names)}
    assert gloverec_names(named) == ours and gloverec_names(ours) == ours
    sim.connect()
    try:
        applied = sim.send_action({n: 0.0 for n in u.action_names})
        assert list(applied) == list(sim.action_features)
    finally:
        sim.disconnect()


def test_a_teleoperator_for_another_robot_is_refused_in_one_line():
    """What lerobot-teleoperate --teleop.robot=shadow with --robot.robot=glovehand meets: gloverec_sim refuses the
    first action, naming what it lacks."""
    sim = GloverecSim(GloverecSimConfig(robot="glovehand", task="pose"))
    teleop = GloverecGlove(GloverecGloveConfig(port="emulator", robot="shadow"))
    sim.connect()
    try:
        with pytest.raises(ValueError) as info:
            sim.send_action({name: 0.0 for name in teleop.action_features})
    finally:
        sim.disconnect()
    assert "gloverec_sim drives glovehand, but the action has no 'thumb_cmc_flex.pos'" in str(info.value)
    assert "\n" not in str(info.value)


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


@pytest.mark.process
def test_a_silent_glove_gives_the_held_pose_without_waiting(tmp_path, caplog):
    emu = EmulatorProcess("--rate", "100", "--link", str(tmp_path / "glove"))
    teleop = GloverecGlove(GloverecGloveConfig(port=f"serial:{emu.port}", robot="glovehand"))
    try:
        teleop.connect()
        first = teleop.get_action()
        assert set(first) == set(teleop.action_features)
        caplog.set_level(logging.INFO)
        emu.unplug()
        stalled = lambda: any("holding the last one" in r.getMessage() for r in caplog.records)  # noqa: E731
        assert wait_for(lambda: teleop.get_action() is not None and stalled(), 30)  # the stall, as it is seen
        t = time.monotonic()
        held = [teleop.get_action() for _ in range(20)]
        assert time.monotonic() - t < 1.0  # never waits for the glove (a 50 ms wait a call would take 1 s)
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


def test_the_emulators_output_has_gloverecs_name_and_keeps_its_old_one(capsys):
    """``emulator_output`` as `gloverec emulate --output` names it; ``emulator_mode``, its old name, still sets it
    (one note on stderr); ``port`` stays LeRobot's name for the device (docs/decisions.md)."""
    assert GloverecGlove(GloverecGloveConfig(emulator_output="raw")).glove_config.mode == "raw"
    assert capsys.readouterr().err == ""
    old = GloverecGloveConfig(emulator_mode="compact")
    assert (old.emulator_output, old.emulator_mode) == ("compact", None)
    assert GloverecGlove(old).glove_config.mode == "compact"
    assert capsys.readouterr().err.count("emulator_mode is now emulator_output") == 1


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


def test_the_plugins_warn_once_when_lerobots_spoken_prompts_will_fail(monkeypatch, capsys):
    """lerobot-record speaks with spd-say unless --play_sounds=false; without spd-say the last prompt fails before
    the dataset is finalised (every episode lost). The plugins warn once, at connect."""
    from recorder import speech

    assert speech.sounds_on(["lerobot-record", "--robot.type=gloverec_sim"])
    assert not speech.sounds_on(["lerobot-record", "--play_sounds=false"])
    assert not speech.sounds_on(["lerobot-record", "--play_sounds", "False"])
    monkeypatch.setattr(speech.shutil, "which", lambda name: None)  # a plain Debian: no speech-dispatcher
    monkeypatch.setattr(speech, "_warned", False)
    monkeypatch.setattr(speech.sys, "argv", ["lerobot-record", "--robot.type=gloverec_sim"])
    sim = GloverecSim(GloverecSimConfig(robot="glovehand", task="pose"))
    sim.connect()
    sim.disconnect()
    err = capsys.readouterr().err
    assert err.count("spd-say is not installed") == 1 and "--play_sounds=false" in err
    assert speech.warn_if_prompts_will_fail("again") is None  # once per process
    monkeypatch.setattr(speech, "_warned", False)
    assert speech.warn_if_prompts_will_fail("x", ["lerobot-record", "--play_sounds=false"]) is None


@pytest.mark.parametrize("task", ["pinch", "keys", "turn"])
def test_the_sim_runs_each_dexterous_task_from_the_glove_teleoperator(task):
    """`--robot.type=gloverec_sim --robot.task=keys` with `--teleop.type=gloverec_glove`: the task's own state
    names in the observation, the actions it takes (HandKeys' base does not turn: no base.*), and the
    teleoperator's action accepted as it is."""
    sim = GloverecSim(GloverecSimConfig(robot="glovehand", task=task, seed=1))
    teleop = GloverecGlove(GloverecGloveConfig(port="emulator", robot="glovehand"))
    names = envs.make(task, "glovehand").unwrapped
    assert [n.removesuffix(".pos") for n in sim.action_features] == list(names.action_names)
    assert ("base.rz.pos" in sim.action_features) == (task != "keys")
    sim.connect()
    try:
        obs = sim.get_observation()
        assert set(names.environment_state_names) <= set(
            gloverec_names({"observation.state": list(obs)})["observation.state"]
        )
        action = {name: 0.0 for name in teleop.action_features}
        applied = sim.send_action(action)
        assert list(applied) == list(sim.action_features)
    finally:
        sim.disconnect()
