"""Robots and tasks: loading, kinematics, spaces, seeding, clipping, rendering, names."""

from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import envs
from envs.robots import load_robot, robot_names
from envs.robots.glovehand import OUT, build
from envs.tasks import make_task
from recorder.hand import kinematics as kin
from recorder.hand.gestures import GESTURES
from recorder.hand.skeleton import FINGERS

ROBOTS = ("glovehand", "shadow")


def test_robots_are_registered():
    assert set(ROBOTS) <= set(robot_names())


@pytest.mark.parametrize("robot", ROBOTS)
def test_robot_loads_and_steps(robot):
    r = load_robot(robot)
    assert r.model.nu == 20
    env = gym.make("gloverec/HandPose-v0", robot=robot)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    state0 = obs["observation.state"].copy()
    target = env.unwrapped.goal
    a = np.concatenate((target, np.zeros(3))).astype(np.float32)
    for _ in range(10):
        obs, reward, terminated, truncated, info = env.step(a)
    assert env.observation_space.contains(obs)
    assert np.isfinite(obs["observation.state"]).all()
    assert not np.allclose(obs["observation.state"], state0)  # the fingers moved toward the goal
    env.close()


def test_glovehand_kinematics_match_the_hand_model():
    m = mujoco.MjModel.from_xml_path(str(OUT))
    d = mujoco.MjData(m)
    qadr = [m.joint(j).qposadr[0] for j in kin.JOINTS]
    rng = np.random.default_rng(0)
    poses = list(GESTURES.values()) + [rng.uniform(kin.LIMITS[:, 0], kin.LIMITS[:, 1]) for _ in range(20)]
    for a in poses:
        d.qpos[qadr] = a
        mujoco.mj_kinematics(m, d)
        tips = np.array([d.site(f"{f}_tip").xpos for f in FINGERS])
        _, _, expected = kin.forward(a, [1, 0, 0, 0])
        np.testing.assert_allclose(tips, expected, atol=1e-6)
    np.testing.assert_allclose(m.jnt_range[[m.joint(j).id for j in kin.JOINTS]], kin.LIMITS, atol=1e-6)


def test_glovehand_mjcf_is_up_to_date():
    assert OUT.read_text() == build(), "regenerate with: python -m envs.robots.glovehand"


def test_glovehand_is_a_plausible_hand():
    m = load_robot("glovehand").model
    assert 0.25 < m.body_subtreemass[m.body("palm").id] < 0.6  # kg, an adult hand


def test_shadow_uses_the_shipped_model_with_its_couplings():
    from envs.robots import tendon_couplings

    r = load_robot("shadow")
    assert r.model.njnt == 24 and r.model.nu == 20
    couplings = tendon_couplings(r.model)
    assert {c.leader for c in couplings} == {f"robot0:{f}FJ1" for f in "FMRL"}
    assert all(abs(c.ratio - 0.00805 / 0.00705) < 1e-9 for c in couplings)


def test_unknown_robot_is_one_line_listing_the_valid_ones():
    with pytest.raises(ValueError) as exc:
        gym.make("gloverec/HandPose-v0", robot="nohand")
    msg = str(exc.value)
    assert "\n" not in msg and "nohand" in msg and all(r in msg for r in ROBOTS)


def test_unknown_task_is_one_line_listing_the_valid_ones():
    for make in (envs.make, make_task):
        with pytest.raises(ValueError) as exc:
            make("juggle")
        msg = str(exc.value)
        assert "\n" not in msg and "pose" in msg and "grasp" in msg


def test_unknown_task_option_and_camera():
    with pytest.raises(ValueError, match="pose task: control_rate: unknown key; valid: control_hz, "):
        envs.make("pose", "glovehand", control_rate=30)
    with pytest.raises(ValueError, match="pose task: cameras.0: Input should be 'front', 'top' or 'side'"):
        envs.make("pose", "glovehand", cameras=("ceiling",))
    with pytest.raises(ValueError, match="grasp task: episode_s: Input should be greater than 0"):
        envs.make("grasp", "glovehand", episode_s=0)
    with pytest.raises(ValueError, match="unknown gesture 'wave'; valid gestures: open, fist"):
        envs.make("pose", "glovehand", gestures=("fist", "wave"))


@pytest.mark.parametrize("task", ["pose", "grasp"])
def test_seeded_resets_are_deterministic(task):
    a, b = envs.make(task, "glovehand"), envs.make(task, "glovehand")
    oa, _ = a.reset(seed=7)
    ob, _ = b.reset(seed=7)
    act = a.action_space.sample()
    for _ in range(5):
        oa, *_ = a.step(act)
        ob, *_ = b.step(act)
    for k in oa:
        np.testing.assert_array_equal(oa[k], ob[k])
    goals = {tuple(b.reset(seed=s)[0]["observation.environment_state"]) for s in range(6)}
    assert len(goals) > 1  # and other seeds give other episodes


def test_actions_are_clipped_and_reported():
    env = envs.make("pose", "shadow")
    env.reset(seed=0)
    a = np.full(env.action_space.shape, 10.0, np.float32)
    _, _, _, _, info = env.step(a)
    applied = info["applied_action"]
    nu = env.unwrapped.model.nu
    np.testing.assert_allclose(applied[:nu], env.unwrapped.model.actuator_ctrlrange[:, 1], rtol=1e-6)
    assert np.linalg.norm(applied[nu:]) <= np.radians(env.unwrapped.config.max_base_angle_deg) + 1e-5
    np.testing.assert_allclose(env.unwrapped.data.ctrl, applied[:nu], rtol=1e-6)


def test_control_rate_is_configurable():
    env = envs.make("pose", "glovehand", control_hz=50)
    env.reset(seed=0)
    u = env.unwrapped
    assert abs(u.n_substeps * u.model.opt.timestep - 1 / 50) < 1e-12
    env.step(np.zeros(env.action_space.shape, np.float32))
    assert abs(u.data.time - 1 / 50) < 1e-9


def test_base_follows_the_palm_rotation():
    env = envs.make("pose", "glovehand")
    env.reset(seed=0)
    u = env.unwrapped
    a = np.concatenate((u.goal, [0.0, 0.4, 0.0])).astype(np.float32)  # 0.4 rad about the palm's y
    for _ in range(15):
        obs, *_ = env.step(a)
    q = obs["observation.state"][-4:]
    angle = 2 * np.arccos(min(1.0, abs(q[0])))
    assert abs(angle - 0.4) < 0.03 and abs(q[2]) > 0.19


@pytest.mark.parametrize("robot", ROBOTS)
def test_camera_images(robot):
    env = envs.make("grasp", robot, cameras=("front", "top"), image_size=(64, 96))
    obs, _ = env.reset(seed=0)
    for cam in ("front", "top"):
        img = obs[f"observation.images.{cam}"]
        assert img.shape == (64, 96, 3) and img.dtype == np.uint8 and img.std() > 5
    assert env.observation_space.contains(obs)
    env.close()


def test_the_cameras_render_without_multisampling_unless_asked():
    """camera_samples: 0 by default (MuJoCo's 4x multisampling costs 2.6x the rendering on a CPU); 4 smooths the
    edges of the same picture, and the model's own setting, which the videos people watch use, is kept."""
    images = {}
    for samples in (0, 4):
        env = envs.make("grasp", "glovehand", cameras=("front",), image_size=(64, 64), camera_samples=samples)
        obs, _ = env.reset(seed=2)
        images[samples] = obs["observation.images.front"].astype(float)
        assert env.unwrapped.model.vis.quality.offsamples == 4
        env.close()
    diff = np.abs(images[0] - images[4])
    assert diff.max() > 20  # the edges differ ...
    assert diff.mean() < 2.0  # ... the picture does not


def test_a_perturbed_scene_looks_different_and_moves_the_same():
    """eval --perturb: light, the objects' colour and the cameras change what the cameras see, never the physics."""

    def run(perturb):
        env = envs.make("grasp", "glovehand", cameras=("front",), image_size=(48, 48), perturb=perturb)
        obs, _ = env.reset(seed=3)
        images, states = [obs["observation.images.front"]], []
        for k in range(5):
            obs, *_ = env.step(np.full(env.action_space.shape, 0.1 * k, np.float32))
            states.append(obs["observation.state"])
        env.close()
        return np.stack(images).astype(float), np.stack(states)

    plain_images, plain_states = run(())
    for what in ("light", "colour", "camera"):
        images, states = run((what,))
        assert np.array_equal(states, plain_states), what
        assert np.abs(images - plain_images).max() > 40, what  # the object alone, for colour: a few pixels


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("task", ["pose", "grasp"])
def test_zero_action_does_not_succeed(task, robot):
    env = envs.make(task, robot)
    for seed in range(3):
        env.reset(seed=seed)
        zero = np.zeros(env.action_space.shape, np.float32)
        while True:
            _, _, terminated, truncated, info = env.step(zero)
            if terminated or truncated:
                break
        assert not info["is_success"]


def test_grasp_randomises_objects():
    env = envs.make("grasp", "glovehand")
    seen, sizes = set(), set()
    for seed in range(12):
        env.reset(seed=seed)
        seen.add(env.unwrapped.object_shape)
        sizes.add(tuple(np.round(env.unwrapped.object_half, 4)))
    assert seen == {"box", "cylinder", "sphere"} and len(sizes) == 12


@pytest.mark.process
def test_a_task_from_outside_the_package_records_through_the_cli(tmp_path):
    """A task is one module (tests/plugins/toy_task.py: its environment, its demonstrator, its instruction, and
    @register_task) plus one config entry, GLOVEREC_PLUGINS (recorder/plugins.py): a command in a child process
    lists it, records it with the emulated glove and its demonstrator, and stores its instruction."""
    import json
    import os
    import shutil

    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from conftest import gloverec

    shutil.copy(Path(__file__).parent / "plugins" / "toy_task.py", tmp_path / "my_toy_task.py")
    env = {**os.environ, "GLOVEREC_PLUGINS": "my_toy_task", "PYTHONPATH": str(tmp_path)}
    r = gloverec("record", "--task", "juggle", "--root", str(tmp_path / "x"), env=env)
    assert r.returncode == 1 and "valid: grasp, keys, pick, pinch, pose, relocate, turn, toy_fist" in r.stderr, r.stderr
    root = tmp_path / "ds"
    r = gloverec("record", "--task", "toy_fist", "--episodes", "1", "--root", str(root), "--repo-id", "test/toy",
                 "--json", env=env, timeout=120)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["success_rate"] == 1.0
    ds = LeRobotDataset("test/toy", root=root)
    assert ds.meta.features["observation.environment_state"]["names"] == ["toy.closure"]
    assert ds[0]["task"] == "make a fist"
    r = gloverec("record", "--task", "toy_fist", "--root", str(tmp_path / "y"), env={**env, "GLOVEREC_PLUGINS": "nope"})
    assert r.returncode == 1 and "cannot load the plugin nope ($GLOVEREC_PLUGINS)" in r.stderr, r.stderr


def test_a_physics_blow_up_is_flagged_from_its_step_to_the_episode_s_end():
    """MuJoCo resets a simulation whose state went bad ("Nan, Inf or huge value in QVEL ...") and goes on: the
    episode's info says when it happened (eval's --json shows it; the recorder's saved line and sidecar too)."""
    env = envs.make("pose", "glovehand")
    u = env.unwrapped
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape)
    assert "physics_unstable_s" not in env.step(zero)[-1]
    u.data.qvel[0] = np.nan  # what a physics explosion leaves
    info = env.step(zero)[-1]
    assert info["physics_unstable_s"] == round(2 / u.config.control_hz, 3)  # the second step
    assert env.step(zero)[-1]["physics_unstable_s"] == info["physics_unstable_s"]  # kept: the first time
    _, info = env.reset(seed=0)
    assert "physics_unstable_s" not in info and "physics_unstable_s" not in env.step(zero)[-1]
    env.close()
