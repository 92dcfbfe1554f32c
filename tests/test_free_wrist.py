"""The free wrist (issue 24): the base position in the action, the relocate task and its demonstrator, the wrist's
fusion with the palm IMU (heading, the planar ambiguity, a lost marker), eval's robot identification,
`gloverec record --task relocate --wrist marker:VIDEO` on a rendered webcam video, grasp and pinch with a free wrist,
and datasets with and without a tracker refused by `gloverec merge`."""

import json
import shutil

import numpy as np
import pytest
import torch

import envs
from conftest import cli, gloverec
from recorder import quat
from recorder.retarget import Retargeter
from recorder.rig.rollout import run_episode
from recorder.wrist.format import WristPose
from recorder.wrist.fusion import FusionConfig, WristFusion

START = np.array([0.0, 0.0, 0.15])


def _fusion(**kw) -> WristFusion:
    f = WristFusion(FusionConfig(camera_noise=False, **kw))
    f.imu(0.0, quat.IDENTITY)
    f.tracker(WristPose(0, 0.0, np.array([0.0, 0.0, 0.5]), quat.IDENTITY.copy()))
    assert f.zero(0.0, START)
    return f


def test_a_free_wrist_task_acts_on_the_base_position_and_names_it():
    env = envs.make("grasp", base_position=True)
    u = env.unwrapped
    assert u.action_names[-6:] == ("base.rx", "base.ry", "base.rz", "base.x", "base.y", "base.z")
    env.reset(seed=0)
    a = np.zeros(env.action_space.shape, np.float32)
    a[-3:] = u.palm_pose()[0] + [0.05, -0.03, 0.04]
    for _ in range(15):
        env.step(a)
    np.testing.assert_allclose(u.palm_pose()[0], a[-3:], atol=3e-3)
    a[-3:] = [5.0, 0.0, -1.0]  # outside the workspace: clipped to its bounds
    _, _, _, _, info = env.step(a)
    np.testing.assert_allclose(info["applied_action"][-3:], [u.base_bounds[1][0], 0.0, u.base_bounds[0][2]], atol=1e-6)
    assert envs.make("grasp").unwrapped.action_names[-1] == "base.rz"  # without a tracker: as before


def test_relocate_is_done_by_its_demonstrator_and_not_by_holding_still():
    env = envs.make("relocate")
    r = Retargeter.for_env(env)
    runs = [run_episode(env, r, seed) for seed in (1, 2)]
    assert all(x["success"] for x in runs), runs
    u = env.unwrapped
    env.reset(seed=1)
    still = np.concatenate((u.actuated_positions(), np.zeros(3), u.palm_pose()[0])).astype(np.float32)
    done = False
    while not done:
        _, _, term, trunc, info = env.step(still)
        done = term or trunc
    assert not info["is_success"]


def test_a_marker_hidden_for_a_second_is_held_flagged_and_comes_back_no_faster_than_the_limit():
    f = _fusion(reacquire_mps=0.2)
    out, dt = [], 1 / 30
    for k in range(1, 150):
        t = k * dt
        f.imu(t, quat.IDENTITY)
        x = 0.1 * min(t, 1.0)  # moves 10 cm in 1 s, then stays
        hidden = 1.0 <= t < 2.0 or 0.5 <= t < 1.0
        if not hidden:
            f.tracker(WristPose(k, t, np.array([x, 0.0, 0.5]), quat.IDENTITY.copy()))
        out.append(f.pose(t))
    pos = np.array([o.position for o in out])
    tracked = np.array([o.tracked for o in out])
    times = np.arange(1, 150) * dt
    lost = (times >= 0.5 + 0.2 + dt) & (times < 2.0)
    assert not tracked[lost].any()  # flagged while hidden
    assert np.ptp(pos[lost], axis=0).max() < 1e-9  # and held
    steps = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    back = times[1:] >= 2.0
    assert steps[back].max() <= 0.2 * dt + 1e-9  # no jump back faster than the limit
    assert tracked[-1] and abs(pos[-1, 0] - 0.1) < 2e-3  # and it got there, tracked again


def test_the_imu_picks_the_right_one_of_the_two_poses_a_square_allows():
    f = _fusion(settle_s=0.0)  # past the first second's settling
    true = quat.from_axis_angle([1.0, 0, 0], 0.4)
    wrong = quat.from_axis_angle([1.0, 0, 0], -0.4)
    f.imu(0.1, true)
    f.tracker(WristPose(1, 0.1, np.array([0.0, 0.0, 0.5]), wrong, True, (np.array([0.0, 0.0, 0.5]), true)))
    assert f.flips == 1


def test_the_tracker_removes_the_imu_s_heading_drift():
    f = _fusion(heading_tau_s=2.0)
    drift = np.radians(3.0) / 60  # rad/s: 3°/min
    errs = []
    for k in range(1, 30 * 120):
        t = k / 30
        truth = quat.from_axis_angle([0, 0, 1.0], 0.5 * np.sin(0.5 * t))
        f.imu(t, quat.mul(quat.from_axis_angle([0, 0, 1.0], drift * t), truth))
        f.tracker(WristPose(k, t, np.array([0.0, 0.0, 0.5]), truth))
        errs.append(np.degrees(quat.angle_between(f.pose(t).quat, truth)))
    assert drift * 120 > np.radians(5.9)  # the IMU alone would be 6° off by now
    assert max(errs[30 * 20 :]) < 0.5


def test_eval_knows_the_robot_from_a_free_wrist_policy_s_action_names():
    from policies.evaluate import trained_setup

    names = list(envs.make("relocate", "shadow").unwrapped.action_names)
    assert trained_setup({"robot": None, "names": {"action": names}}) == (None, "shadow")


@pytest.fixture(scope="session")  # session: kept while other modules run on this worker
def wrist_video(tmp_path_factory):
    """Two relocate demonstrations' wrist paths, filmed by the emulated webcam: a lossless video and its camera."""
    from recorder.demonstrator import make_demonstrator
    from recorder.wrist.emulated import EmulatedCamera

    folder = tmp_path_factory.mktemp("wrist")
    env = envs.make("relocate")
    u = env.unwrapped
    pos, qs = [], []
    for seed in (0, 1):
        env.reset(seed=seed)
        b = make_demonstrator("relocate").plan(u, seed=seed).at(np.arange(0, 9.0, 1 / 30))
        pos += list(b.palm_pos)
        qs += list(b.palm_quat)
    cam = EmulatedCamera()
    cam.record(folder / "wrist.mkv", pos, qs)
    cam.camera.save(folder / "camera.json")
    cam.close()
    return folder


@pytest.mark.process
@pytest.mark.xdist_group("wrist_video")  # its module fixture made once, on one worker (20 s a worker)
def test_record_relocate_with_a_marker_video_stores_the_base_position(tmp_path, wrist_video):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root = tmp_path / "ds"
    r = gloverec("record", "--task", "relocate", "--wrist", f"marker:{wrist_video / 'wrist.mkv'}", "--wrist-camera",
                 str(wrist_video / "camera.json"), "--episodes", "2", "--root", str(root), "--repo-id", "test/reloc",
                 timeout=120)  # fmt: skip
    assert r.returncode == 0, r.stderr
    ds = LeRobotDataset("test/reloc", root=root)
    assert ds.num_episodes == 2
    assert ds.meta.features["action"]["names"][-3:] == ["base.x", "base.y", "base.z"]
    tracked = np.array(ds.hf_dataset["quality.wrist_tracked"])
    assert tracked.mean() > 0.95
    wrist = np.array(ds.hf_dataset["observation.wrist"])
    assert np.ptp(wrist[:, 2]) > 0.05  # the wrist went down to the object and up again


@pytest.mark.xdist_group("wrist_video")
@pytest.mark.parametrize(
    ("wrist", "camera", "says"),
    [
        ("marker:{d}/missing.mkv", "{d}/camera.json", "cannot open the camera or video"),
        ("marker:{d}/camera.json", "{d}/camera.json", "cannot open the camera or video"),  # not a video
        ("marker:{d}/wrist.mkv", "{d}/wrist.mkv", "bad camera calibration"),
        ("laser:3", "{d}/camera.json", "unknown wrist source"),
        ("marker:emulated", "{d}/camera.json", "--wrist-camera is a marker camera's calibration"),  # it uses none
    ],
)
def test_a_bad_wrist_is_one_line_before_anything_is_recorded(tmp_path, wrist_video, wrist, camera, says):
    root = tmp_path / "ds"
    d = str(wrist_video)
    r = cli("record", "--view", "none", "--task", "relocate", "--wrist", wrist.format(d=d), "--wrist-camera",
            camera.format(d=d), "--episodes", "1", "--root", str(root), "--repo-id", "test/bad")  # fmt: skip
    assert r.returncode != 0 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (root / "data").exists()


@pytest.mark.process
def test_resuming_a_dataset_without_a_tracker_with_one_is_refused_in_one_line(shared, tmp_path):
    shutil.copytree(_recording(shared, "plain_grasp")[0].parent, tmp_path / "rec", symlinks=True)  # a recording's
    root = tmp_path / "rec" / "ds"  # root is a link into its snapshot store beside it
    args = ("record", "--task", "grasp", "--episodes", "1", "--root", str(root), "--repo-id", "test/plain_grasp")
    r = gloverec(*args, "--resume", "--wrist", "marker:emulated")
    assert r.returncode != 0 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "features differ" in r.stderr and "observation.wrist" in r.stderr


@pytest.mark.parametrize("task", ["grasp", "pinch"])
def test_with_a_free_wrist_the_grasp_and_pinch_demonstrators_do_the_script_s_moves(task):
    from recorder.demonstrator import make_demonstrator

    scripted, free = envs.make(task).unwrapped, envs.make(task, base_position=True).unwrapped
    for seed in (0, 1, 2):
        scripted.reset(seed=seed)
        free.reset(seed=seed)
        plan, alone = make_demonstrator(task).plan(free, seed), make_demonstrator(task).plan(scripted, seed)
        times = (0.0, free.schedule["lift"], free.config.episode_s)  # the start, down on the object, lifted
        b = plan.at(np.array(times))
        start, down, end = (free._base_target(t)[0] for t in times)
        np.testing.assert_allclose(b.palm_pos[0], start, atol=1e-9)  # where the task puts the hand
        for got, want in ((b.palm_pos[1], down), (b.palm_pos[2], end)):  # on the script's path, a few mm off
            assert np.linalg.norm(got - want) < 0.011 and abs(got[2] - want[2]) < 1e-6
        after = np.arange(1.3, 6.0, 0.1)  # past the descent: the fingers close and hold as without a tracker
        np.testing.assert_allclose(plan.keyframe_angles(after), alone.keyframe_angles(after), atol=1e-12)


RECORDINGS = {  # what the tests below record, as a user types it
    "free_grasp": "--task grasp --wrist marker:emulated --episodes 2 --fast --glove emulator",
    "plain_grasp": "--task grasp --episodes 1",
}


def _recording(shared, name: str) -> tuple:
    """``gloverec record RECORDINGS[name]``, once per test run (shared read-only): (root, the command's summary)."""

    def build(path) -> None:
        r = gloverec("record", *RECORDINGS[name].split(), "--root", str(path / "ds"), "--repo-id", f"test/{name}",
                     "--json", timeout=120)  # fmt: skip
        assert r.returncode == 0, r.stderr
        (path / "summary.json").write_text(r.stdout.strip().splitlines()[-1])

    path = shared(name, build)
    return path / "ds", json.loads((path / "summary.json").read_text())


@pytest.mark.process
def test_record_grasp_with_the_emulated_webcam_s_wrist(shared):
    """The whole camera path with a free wrist on a scripted task (pinch's wrist plan, the same code, is checked
    above without recording)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    root, summary = _recording(shared, "free_grasp")
    ds = LeRobotDataset("test/free_grasp", root=root)
    assert ds.meta.features["action"]["names"][-3:] == ["base.x", "base.y", "base.z"]
    assert summary["success_rate"] > 0  # the demonstrator reached, closed and lifted through the whole stack
    wrist = np.array(ds.hf_dataset["observation.wrist"])
    assert np.ptp(wrist[:, 2]) > 0.05  # the wearer's descent and lift


@pytest.mark.process
def test_datasets_with_and_without_a_tracker_are_not_merged(shared, tmp_path):
    (tracked, _), (plain, _) = _recording(shared, "free_grasp"), _recording(shared, "plain_grasp")
    r = cli("merge", "--root", str(tmp_path / "both"), "--from", str(plain), str(tracked))
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "action: 23 vs 26" in r.stderr and f"only in {tracked}: observation.wrist" in r.stderr, r.stderr
    assert not (tmp_path / "both").exists()
    r = cli("merge", "--root", str(tmp_path / "twice"), "--from", str(tracked), str(tracked))  # one kind merges
    assert r.returncode == 0 and "4 episodes" in r.stdout and "records carried for 4" in r.stdout, r.stderr


@pytest.mark.parametrize("palm_frame", [True, False])
def test_bc_on_a_free_wrist_predicts_the_base_target_in_the_palm_s_frame(palm_frame, tmp_path):
    """Palm, object and target moved together across the table: in the palm frame the network sees the same
    inputs and the base target it predicts moves with them, exactly (and survives a save and a reload);
    predicted absolutely, it does not."""
    from lerobot.configs.types import FeatureType, PolicyFeature

    from policies.bc import BCConfig, BCPolicy

    u = envs.make("relocate").unwrapped
    names = {"observation.state": u.state_names, "observation.environment_state": u.environment_state_names,
             "action": u.action_names}  # fmt: skip
    kinds = {"observation.state": FeatureType.STATE, "observation.environment_state": FeatureType.ENV,
             "action": FeatureType.ACTION}  # fmt: skip
    rng = np.random.default_rng(0)
    stats = {k: {"mean": rng.normal(0, 0.1, len(n)), "std": rng.uniform(0.02, 0.2, len(n))} for k, n in names.items()}
    cfg = BCConfig(device="cpu", push_to_hub=False, hidden_dim=32, n_layers=2, palm_frame=palm_frame)
    cfg.input_features = {k: PolicyFeature(kinds[k], (len(n),)) for k, n in names.items() if k != "action"}
    cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (len(names["action"]),))}
    cfg.set_dataset_feature_metadata({k: {"names": list(n)} for k, n in names.items()})
    policy = BCPolicy(cfg, dataset_stats=stats)
    assert (policy.palm_frame is not None) == palm_frame

    def normalised(key, x):
        return torch.as_tensor((x - stats[key]["mean"]) / stats[key]["std"], dtype=torch.float32)[None]

    state0 = rng.normal(0, 0.1, len(u.state_names))
    env0 = rng.normal(0, 0.1, len(u.environment_state_names))

    def base_target(dx, dy):
        """The base targets predicted with palm, object and target moved by (dx, dy) m."""
        state, env = state0.copy(), env0.copy()
        for axis, d in (("x", dx), ("y", dy)):
            state[u.state_names.index(f"palm.{axis}")] += d
            for thing in ("object", "target"):
                env[u.environment_state_names.index(f"{thing}.{axis}")] += d
        batch = {"observation.state": normalised("observation.state", state),
                 "observation.environment_state": normalised("observation.environment_state", env)}  # fmt: skip
        base = [u.action_names.index(f"base.{a}") for a in "xyz"]
        chunk = policy.predict_action_chunk(batch)[0, :, base].numpy()
        return chunk * stats["action"]["std"][base] + stats["action"]["mean"][base]

    here = base_target(0.0, 0.0)
    there = base_target(0.07, -0.05)
    moved = np.abs(there - here - [0.07, -0.05, 0.0]).max()
    assert (moved < 1e-5) == palm_frame, moved
    if palm_frame:
        policy.save_pretrained(tmp_path / "p")
        policy = BCPolicy.from_pretrained(tmp_path / "p")
        assert policy.palm_frame is not None and np.allclose(base_target(0.07, -0.05), there, atol=1e-6)


def test_bc_without_a_free_wrist_has_no_palm_frame():
    from lerobot.configs.types import FeatureType, PolicyFeature

    from policies.bc import BCConfig, BCPolicy

    u = envs.make("grasp").unwrapped
    cfg = BCConfig(device="cpu", push_to_hub=False, hidden_dim=32, n_layers=2)
    cfg.input_features = {"observation.state": PolicyFeature(FeatureType.STATE, (len(u.state_names),))}
    cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (len(u.action_names),))}
    cfg.set_dataset_feature_metadata({"observation.state": {"names": list(u.state_names)},
                                      "action": {"names": list(u.action_names)}})  # fmt: skip
    assert BCPolicy(cfg).palm_frame is None
