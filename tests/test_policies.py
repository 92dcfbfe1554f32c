"""Behaviour cloning end to end on a tiny dataset recorded by `gloverec record` (emulated glove, real MuJoCo):
the policy as LeRobot sees it, `gloverec train` (checkpoints, split, resume), `gloverec eval` (a metric that can
fail and succeed, refused mismatches) and `gloverec replay` (exact reproduction, and a detected divergence)."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
from safetensors.torch import load_file

import envs
from conftest import cli, gloverec

REPO = "test/pose"


def ok_json(*args: str) -> dict:
    r = cli(*args, "--json")  # in this process (the docs' commands run as a user runs them: tests/test_docs.py)
    assert r.returncode == 0, r.stderr[-3000:]
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1, f"stdout must be exactly one JSON object, got: {r.stdout[:500]}"
    return json.loads(lines[0])


def one_line_error(r: subprocess.CompletedProcess, needle: str, code: int = 1) -> str:
    err = r.stderr.strip()
    assert r.returncode == code, (r.returncode, err[-2000:])
    assert "\n" not in err and "Traceback" not in err and needle in err, err[-2000:]
    return err


@pytest.fixture(scope="module")
def dataset(pose_recording) -> Path:
    return pose_recording[0]  # 4 HandPose episodes on glovehand, seeds 0-3, recorded once per run (conftest)


@pytest.fixture(scope="module")
def trained(dataset, tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("bc") / "run"
    summary = ok_json(
        "train",
        "--repo-id",
        REPO,
        "--root",
        str(dataset),
        "--steps",
        "40",
        "--save-every",
        "20",
        "--batch-size",
        "64",
        "--out",
        str(out),
    )
    return out, summary


def _bc_policy(dataset):
    """A BC policy as lerobot-train makes it: the policy factory over the dataset's features and statistics."""
    from lerobot.datasets.factory import resolve_delta_timestamps
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    from policies.bc import BCConfig

    meta = LeRobotDatasetMetadata(REPO, root=dataset)
    policy = make_policy(BCConfig(device="cpu", push_to_hub=False, hidden_dim=64, n_layers=2), ds_meta=meta)
    pre, post = make_pre_post_processors(policy.config, dataset_stats=meta.stats)
    ds = LeRobotDataset(REPO, root=dataset, delta_timestamps=resolve_delta_timestamps(policy.config, meta))
    return policy, pre, post, ds


# ---------------------------------------------------------------- the policy, as LeRobot sees it


def test_lerobot_factory_knows_the_policy_and_drops_the_glove_input(dataset):
    from lerobot.policies.factory import get_policy_class

    from policies.bc import BCPolicy

    assert get_policy_class("gloverec_bc") is BCPolicy
    policy, pre, post, ds = _bc_policy(dataset)
    # observation.glove (the human hand) is a dataset input LeRobot offers; a deployed robot has no glove, and no
    # environment state either: by default the policy reads the joint state and the instruction
    assert set(policy.config.input_features) == {"observation.state"} and policy.config.reads_task
    batch = pre(torch.utils.data.default_collate([ds[i] for i in range(8)]))
    assert batch["action"].shape == (8, policy.config.chunk_size, 23)
    loss, info = policy.forward(batch)
    assert loss.item() > 0 and np.isfinite(info["l1_loss"])
    # the loss ignores the padding past an episode's end: the last frame's chunk is mostly padding
    last = pre(torch.utils.data.default_collate([ds[len(ds) - 1]]))
    assert last["action_is_pad"].sum() == policy.config.chunk_size - 1
    last["action"][:, 1:] += 100.0
    padded_loss, _ = policy.forward(last)
    last["action"][:, 1:] -= 100.0
    assert torch.isclose(padded_loss, policy.forward(last)[0])


def test_saved_checkpoint_reloads_to_identical_actions(dataset, tmp_path):
    from policies.evaluate import PolicyAgent, load_policy

    policy, pre, post, ds = _bc_policy(dataset)
    batch = pre(torch.utils.data.default_collate([ds[i] for i in range(0, len(ds), 3)]))
    opt = torch.optim.Adam(policy.parameters(), lr=1e-3)
    for _ in range(5):
        loss, _ = policy.forward(batch)
        opt.zero_grad()
        loss.backward()
        opt.step()
    ckpt = tmp_path / "pretrained_model"
    policy.save_pretrained(ckpt)
    pre.save_pretrained(ckpt)
    post.save_pretrained(ckpt)
    assert json.loads((ckpt / "config.json").read_text())["type"] == "gloverec_bc"

    original, reloaded = PolicyAgent(policy, pre, post, ckpt, {}), load_policy(ckpt)
    env = envs.make("pose", "glovehand")
    obs, _ = env.reset(seed=123)
    original.reset(env, 123)
    reloaded.reset(env, 123)
    actions = []
    for _ in range(20):  # temporal ensembling carries state across steps: compare a whole stretch
        a, b = original.act(obs), reloaded.act(obs)
        assert np.array_equal(a, b)
        actions.append(a)
        obs, *_ = env.step(a)
    assert np.ptp(np.stack(actions), axis=0).max() > 0  # not a constant output


# ---------------------------------------------------------------- gloverec train


def test_train_writes_a_lerobot_checkpoint_split_by_episode(trained, dataset):
    out, summary = trained
    last = out / "checkpoints" / "last"
    assert last.is_symlink() and last.resolve().name == "000040"
    assert (out / "checkpoints" / "000020" / "pretrained_model" / "model.safetensors").is_file()
    model = last / "pretrained_model"
    for name in (
        "config.json",
        "model.safetensors",
        "train_config.json",
        "policy_preprocessor.json",
        "policy_postprocessor.json",
        "gloverec.json",
    ):
        assert (model / name).is_file(), name
    assert (last / "training_state" / "optimizer_state.safetensors").is_file()
    train_cfg = json.loads((model / "train_config.json").read_text())
    assert train_cfg["policy"]["type"] == "gloverec_bc" and train_cfg["dataset"]["repo_id"] == REPO
    split = json.loads((out / "split.json").read_text())
    assert split["validation"] and not set(split["train"]) & set(split["validation"])
    assert sorted(split["train"] + split["validation"]) == [0, 1, 2, 3]
    assert train_cfg["dataset"]["episodes"] == split["train"]
    assert summary["val_episodes"] == len(split["validation"]) and summary["final_val_loss"] > 0
    assert (out / "loss_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    history = json.loads((last / "loss_history.json").read_text())
    assert [h["step"] for h in history][-1] == 40 and history[-1]["train_loss"] < history[0]["train_loss"]


def test_resume_after_an_interruption_continues_exactly(trained, dataset, tmp_path):
    out, _ = trained
    # the same run, "interrupted" after its step-20 checkpoint: resuming must reproduce step 40 bit for bit
    crashed = tmp_path / "crashed"
    shutil.copytree(out, crashed, symlinks=True)
    shutil.rmtree(crashed / "checkpoints" / "000040")
    (crashed / "checkpoints" / "last").unlink()
    (crashed / "checkpoints" / "last").symlink_to("000020")
    summary = ok_json(
        "train",
        "--repo-id",
        REPO,
        "--root",
        str(dataset),
        "--steps",
        "40",
        "--save-every",
        "20",
        "--batch-size",
        "64",
        "--out",
        str(crashed),
        "--resume",
    )
    assert summary["start_step"] == 20
    straight = load_file(out / "checkpoints" / "000040" / "pretrained_model" / "model.safetensors")
    resumed = load_file(crashed / "checkpoints" / "000040" / "pretrained_model" / "model.safetensors")
    assert straight.keys() == resumed.keys()
    assert all(torch.equal(straight[k], resumed[k]) for k in straight)
    first = load_file(out / "checkpoints" / "000020" / "pretrained_model" / "model.safetensors")
    assert not all(torch.equal(first[k], straight[k]) for k in first)  # training did move the weights


def test_a_history_policy_trains_reloads_and_forgets_its_window_at_reset(dataset, tmp_path):
    """n_obs_steps > 1: a window of past observations (LeRobot's observation deltas) in training; at inference the
    window is kept across steps and cleared by reset(): an episode run after another acts as it does alone."""
    from policies.evaluate import load_policy

    (tmp_path / "history.yaml").write_text("policy: {n_obs_steps: 3, obs_stride: 2, hidden_dim: 64, n_layers: 2}\n")
    out = tmp_path / "run"
    ok_json("train", "--repo-id", REPO, "--root", str(dataset), "--steps", "20", "--batch-size", "32",
            "--out", str(out), "--config", str(tmp_path / "history.yaml"), "--inputs", "state")  # fmt: skip
    config = json.loads((out / "checkpoints" / "last" / "pretrained_model" / "config.json").read_text())
    assert (config["n_obs_steps"], config["obs_stride"]) == (3, 2)

    def episode(agent, env, seed: int) -> np.ndarray:
        obs, _ = env.reset(seed=seed)
        agent.reset(env, seed)
        actions = []
        for _ in range(12):
            actions.append(agent.act(obs))
            obs, *_ = env.step(actions[-1])
        return np.stack(actions)

    env = envs.make("pose", "glovehand")
    after_another = load_policy(out)
    episode(after_another, env, 7)
    second = episode(after_another, env, 8)
    alone = episode(load_policy(out), env, 8)
    assert np.array_equal(second, alone)
    # the window is an input: the same newest observation after another past gives another action
    policy = after_another.policy
    x = {k: torch.zeros(1, ft.shape[0]) for k, ft in policy.config.input_features.items()}
    policy.reset()
    still = policy.predict_action_chunk({k: v.unsqueeze(1).repeat(1, 3, 1) for k, v in x.items()})
    moved = policy.predict_action_chunk({k: torch.cat([v.unsqueeze(1) + 1, v.unsqueeze(1).repeat(1, 2, 1)], 1)
                                         for k, v in x.items()})  # fmt: skip
    assert not torch.equal(still, moved)
    env.close()


def test_input_noise_perturbs_training_only():
    from lerobot.configs.types import FeatureType, PolicyFeature

    from policies.bc import BCConfig, BCPolicy

    def policy(noise: float):
        cfg = BCConfig(device="cpu", inputs=["state", "environment"], hidden_dim=16, n_layers=1, input_noise=noise)
        cfg.input_features = {"observation.state": PolicyFeature(FeatureType.STATE, (4,))}
        cfg.output_features = {"action": PolicyFeature(FeatureType.ACTION, (3,))}
        torch.manual_seed(0)
        return BCPolicy(cfg)

    batch = {"observation.state": torch.randn(8, 4), "action": torch.randn(8, 10, 3)}
    noisy, plain = policy(0.5), policy(0.0)
    noisy.train()
    plain.train()
    assert noisy.forward(batch)[0] != noisy.forward(batch)[0]  # a fresh draw each batch
    assert plain.forward(batch)[0] == plain.forward(batch)[0]
    noisy.reset()
    assert torch.equal(noisy.predict_action_chunk(batch), noisy.predict_action_chunk(batch))  # none at inference


def test_a_history_window_loads_no_camera_history():
    from policies.train import history_deltas

    delta = {"observation.state": [-0.2, -0.1, 0.0], "observation.images.front": [-0.2, -0.1, 0.0],
             "observation.glove": [-0.2, -0.1, 0.0], "action": [0.0, 0.1]}  # fmt: skip
    keys = ["observation.state", "observation.images.front", "action"]
    assert history_deltas(delta, keys) == {"observation.state": [-0.2, -0.1, 0.0], "action": [0.0, 0.1]}


@pytest.mark.process
def test_a_policy_type_from_a_plugin_module_trains_and_evaluates(dataset, tmp_path):
    """A policy type is one module (tests/plugins/tiny_policy.py: config, policy and processors, registered with
    PreTrainedConfig.register_subclass) named in GLOVEREC_PLUGINS: `gloverec train --policy NAME` trains it and
    `gloverec eval` loads it back, each command in a process of its own."""
    shutil.copy(Path(__file__).parent / "plugins" / "tiny_policy.py", tmp_path / "my_policy.py")
    path = os.pathsep.join(p for p in (str(tmp_path), os.environ.get("PYTHONPATH")) if p)
    env = {**os.environ, "GLOVEREC_PLUGINS": "my_policy", "PYTHONPATH": path}
    out = tmp_path / "run"
    r = gloverec("train", "--repo-id", REPO, "--root", str(dataset), "--policy", "tiny_linear", "--steps", "3",
                 "--batch-size", "16", "--lr", "0.01", "--out", str(out), "--json", env=env)  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads(r.stdout)
    assert (summary["policy_type"], summary["inputs"]) == ("tiny_linear", "observation.state")
    model = out / "checkpoints" / "000003" / "pretrained_model"
    assert json.loads((model / "config.json").read_text())["optimizer_lr"] == 0.01 and summary["final_train_loss"] > 0
    r = gloverec("eval", "--policy", str(out), "--episodes", "1", "--json", env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    result = json.loads(r.stdout)
    assert (result["policy_type"], result["task"], result["robot"], result["episodes"]) == (
        "tiny_linear", "pose", "glovehand", 1)  # fmt: skip
    # the control: without the module nothing knows the type, and the line says where one registers
    one_line_error(gloverec("eval", "--policy", str(out), "--episodes", "1"),
                   "type 'tiny_linear', which LeRobot does not know here")  # fmt: skip


def test_an_unknown_or_undrivable_policy_type_is_one_line(dataset, tmp_path):
    """`--policy` takes any registered type: an unknown name lists them; a registered type this trainer cannot drive
    (TD-MPC, reinforcement learning: its forward wants rewards and frame indices) says so before writing anything."""
    train = ("train", "--repo-id", REPO, "--root", str(dataset), "--out", str(tmp_path / "x"), "--steps", "2")
    err = one_line_error(cli(*train, "--policy", "nosuch"), "unknown policy 'nosuch'; known: bc (gloverec_bc), act, ")
    assert "diffusion" in err and "tdmpc" in err
    r = cli(*train, "--policy", "tdmpc", "--batch-size", "4", "--json")  # after what it read: the last line
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr[-2000:]
    assert r.stderr.strip().splitlines()[-1].startswith("gloverec: error: cannot train a tdmpc policy: its forward")
    assert not (tmp_path / "x").exists()


@pytest.mark.process
def test_ctrl_c_keeps_the_step_under_way_and_resume_continues_from_it(dataset, tmp_path):
    """Ctrl-C long before the first checkpoint (every 100000 steps here) saves the step under way, so the same
    command with --resume continues from it: no folder left that neither a fresh run nor --resume accepts."""
    out = tmp_path / "run"
    args = ["train", "--repo-id", REPO, "--root", str(dataset), "--batch-size", "16", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "recorder.cli", *args, "--steps", "100000"],
                            stderr=subprocess.PIPE)  # fmt: skip
    seen = b""
    try:  # the progress bar's count says training is under way: wait for it, not for a time
        while not re.search(rb"\| *([3-9]|\d\d+)/100000", seen):
            chunk = os.read(proc.stderr.fileno(), 4096)
            assert chunk, f"training ended before its third step: {seen.decode()[-2000:]}"
            seen += chunk
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    err = (seen + err).decode()
    said = re.search(r"interrupted at step (\d+) \(checkpoint: step (\d+)\); the same command with --resume", err)
    assert proc.returncode == 130 and said and said[1] == said[2], err[-2000:]
    step = int(said[1])
    assert (out / "checkpoints" / "last" / "pretrained_model" / "model.safetensors").is_file()
    summary = ok_json(*args, "--steps", str(step + 2), "--resume")
    assert summary["start_step"] == step and summary["steps"] == step + 2


def test_a_second_ctrl_c_stops_training_at_once():
    from policies.train import StopRequest

    before = signal.getsignal(signal.SIGINT)
    with StopRequest() as stop:
        os.kill(os.getpid(), signal.SIGINT)  # the first: asked to stop after the step under way
        assert stop.requested
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)  # the second: at once
    assert signal.getsignal(signal.SIGINT) is before


# ---------------------------------------------------------------- gloverec eval


def test_metric_succeeds_for_the_demonstrator_and_fails_for_random_actions():
    from policies.evaluate import DemonstratorAgent, RandomAgent, evaluate, make_env

    env = make_env("pose", "glovehand")
    demo = evaluate(DemonstratorAgent("pose", "glovehand"), env, episodes=4, seed=100_000)
    rand = evaluate(RandomAgent(), env, episodes=4, seed=100_000)
    assert demo["success_rate"] == 1.0 and rand["success_rate"] == 0.0
    assert demo["mean_return"] > rand["mean_return"] and rand["episode_lengths"] == [150] * 4
    assert all(n < 150 for n in demo["episode_lengths"])  # HandPose ends on success


def test_eval_says_how_each_episode_of_a_dexterous_task_ended():
    from policies.evaluate import DemonstratorAgent, RandomAgent, evaluate, make_env

    env = make_env("keys", "glovehand")
    run = evaluate(RandomAgent(), env, episodes=1, seed=100_000)["runs"][0]
    assert not run["success"] and run["failed"].endswith("key pressed") and run["sequence"].count("-") >= 2
    run = evaluate(DemonstratorAgent("turn", "glovehand"), make_env("turn", "glovehand"), 1, 100_000)["runs"][0]
    assert run["success"] and abs(run["angle_deg"] - run["target_deg"]) <= 8


def test_eval_json_of_an_untrained_policy_reports_failure(dataset, tmp_path):
    policy, pre, post, _ = _bc_policy(dataset)
    ckpt = tmp_path / "untrained"
    for part in (policy, pre, post):
        part.save_pretrained(ckpt)
    video = tmp_path / "films" / "first.mp4"  # a FILE.mp4: the first episode, filmed into it
    out = ok_json("eval", "--policy", str(ckpt), "--task", "pose", "--robot", "glovehand", "--episodes", "3",
                  "--video", str(video))  # fmt: skip
    assert out["success_rate"] == 0.0 and out["episodes"] == 3 and out["policy_type"] == "gloverec_bc"
    assert out["episode_lengths"] == [150, 150, 150] and isinstance(out["mean_return"], float)
    assert out["videos"] == [str(video)] and video.stat().st_size > 1000
    r = cli("eval", "--policy", str(ckpt), "--task", "pose", "--robot", "glovehand", "--video", str(video),
            "--videos", "2")  # fmt: skip
    one_line_error(r, "is one file: it films one episode (pass a folder for --videos 2)")


def test_eval_takes_task_robot_and_rate_from_the_checkpoint(trained):
    out, _ = trained
    result = ok_json("eval", "--policy", str(out), "--episodes", "2", "--seed", "7")
    assert (result["task"], result["robot"], result["seeds"]) == ("pose", "glovehand", [7, 8])
    assert result["policy"].endswith("000040/pretrained_model")


@pytest.mark.parametrize(
    "args, needle",
    [
        (
            ["--robot", "shadow"],
            "feature observation.state differs: the policy expects shape (47,), pose on shadow gives (55,)",
        ),
        (
            ["--task", "grasp"],
            "does not know the instruction 'grasp the box and keep holding it', which grasp can "
            "draw: it was trained for pose",
        ),
    ],
)
def test_mismatched_features_are_refused_in_one_line(trained, args, needle):
    out, _ = trained
    one_line_error(cli("eval", "--policy", str(out), "--episodes", "1", *args), needle)


def test_same_shapes_with_other_feature_names_are_refused(trained, tmp_path):
    out, _ = trained
    ckpt = tmp_path / "renamed"
    shutil.copytree(out / "checkpoints" / "last" / "pretrained_model", ckpt)
    extras = json.loads((ckpt / "gloverec.json").read_text())
    extras["names"]["action"][0] = "robot0:A_WRJ1"  # as if trained on another hand with as many actuators
    (ckpt / "gloverec.json").write_text(json.dumps(extras))
    one_line_error(
        cli("eval", "--policy", str(ckpt), "--episodes", "1"),
        "feature action differs: element 0 is 'robot0:A_WRJ1' for the policy but 'thumb_cmc_flex'",
    )


# ---------------------------------------------------------------- gloverec replay


def test_replay_reproduces_the_recorded_states(dataset, tmp_path):
    n = LeRobotDatasetMetadata(REPO, root=dataset).episodes[1]["length"]
    films = tmp_path / "films"  # a folder: --video's one rule across commands (recorder.paths.video_file)
    out = ok_json("replay", "--repo-id", REPO, "--root", str(dataset), "--episode", "1", "--video", str(films))
    assert out["video"] == str(films / "episode001_replay.mp4") and Path(out["video"]).stat().st_size > 1000
    assert out["reproduced"] and out["frames"] == n and len(out["max_abs_per_step"]) == n
    assert out["state_max_abs"] <= 1e-6 and out["environment_state_max_abs"] <= 1e-6
    assert out["seed"] == 1 and out["replayed_success"] == out["recorded_success"] is True


def test_replay_detects_a_divergence(dataset, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(dataset, copy)
    side = copy / "meta" / "gloverec" / "episodes.jsonl"
    rows = [json.loads(line) for line in side.read_text().splitlines()]
    rows[1]["seed"] = 999  # another start: the same actions from there no longer give the recorded states
    side.write_text("".join(json.dumps(r) + "\n" for r in rows))
    r = cli("replay", "--repo-id", REPO, "--root", str(copy), "--episode", "1", "--json")
    assert r.returncode == 1 and "diverged from the recording at step 0" in r.stderr
    out = json.loads(r.stdout)
    assert not out["reproduced"] and out["state_max_abs"] > 1e-3


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "args, needle, code",
    [
        (
            ["train", "--repo-id", REPO, "--root", "/nonexistent", "--out", "x", "--steps", "1"],
            "not a LeRobot dataset",
            1,
        ),
        (["train", "--repo-id", "../evil", "--root", ".", "--out", "x"], "bad repo id", 1),
        (["train", "--repo-id", REPO, "--hub", "/nonexistent-hub", "--out", "x"], "no hub at /nonexistent-hub", 1),
        (["train", "--repo-id", REPO, "--out", "x", "--steps", "0"], "must be positive", 2),
        (["eval", "--policy", "/nonexistent", "--episodes", "1"], "holds no LeRobot policy", 1),
        (["eval", "--policy", "random", "--episodes", "1"], "needs --task and --robot", 1),
        (["eval", "--policy", "demonstrator", "--task", "juggle", "--robot", "glovehand"], "unknown task", 1),
    ],
)
def test_bad_input_is_one_line(args, needle, code):
    one_line_error(cli(*args), needle, code)


def test_bad_input_on_real_data_is_one_line(dataset, trained, tmp_path):
    out, _ = trained
    one_line_error(
        cli("replay", "--repo-id", REPO, "--root", str(dataset), "--episode", "9"),
        "has no episode 9 (it has 4: 0..3)",
    )
    one_line_error(
        cli("train", "--repo-id", REPO, "--root", str(dataset), "--out", str(out)), "already exists: pass --resume"
    )
    one_line_error(
        cli("train", "--repo-id", REPO, "--root", str(dataset), "--out", str(tmp_path / "new"), "--resume"),
        "nothing to resume",
    )
    # a named input the dataset lacks, or an unknown name: one line before anything is written
    one_line_error(cli("train", "--repo-id", REPO, "--root", str(dataset), "--out", str(tmp_path / "n"),
                       "--inputs", "state,images"), "--inputs state,images: the dataset has no cameras")  # fmt: skip
    one_line_error(cli("train", "--repo-id", REPO, "--root", str(dataset), "--out", str(tmp_path / "n"),
                       "--inputs", "state,wrist"), "--inputs: unknown input 'wrist'")  # fmt: skip
    assert not (tmp_path / "n").exists()


def test_a_recording_not_yet_pushed_is_named_when_the_hub_lacks_it(dataset, tmp_path):
    """`record` writes datasets/recordings/USER/NAME, `train` and `replay` read the hub: the error says where the
    recording is and how to use it (each test runs in an empty folder of its own)."""
    shutil.copytree(dataset, Path("datasets/recordings") / REPO)
    for args in (["train", "--out", str(tmp_path / "out")], ["replay", "--episode", "0"]):
        r = cli(*args, "--repo-id", REPO)
        err = one_line_error(r, "but a recording of it is at datasets/recordings/test/pose: pass --root")
        assert "gloverec push --repo-id test/pose --root datasets/recordings/test/pose" in err
    assert not (tmp_path / "out").exists()


def test_a_dataset_without_a_successful_episode_names_all_episodes(dataset, tmp_path):
    """Every take marked failed: the error says how to train on them anyway."""
    copy = tmp_path / "failed"
    shutil.copytree(dataset, copy)  # the recording's newest snapshot, as plain files
    sidecar = copy / "meta/gloverec/episodes.jsonl"
    lines = [json.loads(line) for line in sidecar.read_text().splitlines()]
    sidecar.write_text("".join(json.dumps({**e, "success": False}) + "\n" for e in lines))
    r = cli("train", "--repo-id", REPO, "--root", str(copy), "--steps", "2", "--out", str(tmp_path / "out"))
    one_line_error(r, "has no successful episodes to train on (the recorder marked all 4 unsuccessful)")
    assert "--all-episodes" in r.stderr
    r = cli("train", "--repo-id", REPO, "--root", str(copy), "--steps", "2", "--out", str(tmp_path / "out"),
            "--all-episodes", "--json")  # fmt: skip
    assert r.returncode == 0 and json.loads(r.stdout)["train_episodes"] == 4 - json.loads(r.stdout)["val_episodes"]


# ---------------------------------------------------------------- cameras


@pytest.mark.process
def test_a_camera_dataset_trains_an_image_policy_that_eval_gives_its_camera(tmp_path):
    root = tmp_path / "cam"
    r = gloverec(
        "record",
        "--glove",
        "emulator",
        "--task",
        "pose",
        "--episodes",
        "2",
        "--cameras",
        "front",
        "--image-size",
        "64,64",
        "--root",
        str(root),
        "--repo-id",
        "test/cam",
        "--fast",
        "--no-log",
        "--json",
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    out = tmp_path / "run"
    ok_json(
        "train", "--repo-id", "test/cam", "--root", str(root), "--steps", "5", "--batch-size", "8", "--out", str(out)
    )
    config = json.loads((out / "checkpoints" / "last" / "pretrained_model" / "config.json").read_text())
    assert config["input_features"]["observation.images.front"]["shape"] == [3, 64, 64]
    # the default inputs are a robot's: joint state, camera, instruction; no environment state, no glove
    assert set(config["input_features"]) == {"observation.state", "observation.images.front"}
    assert config["inputs"] == ["state", "images", "task"]
    from policies.data import resolve
    from policies.replay import replay

    # eval gives each episode the instruction the recorder would have written (all the task's are known, two
    # trained: the others' episodes are a guess, and eval says so); one the policy does not know is one line
    drawn = envs.make("pose", "glovehand").unwrapped.instructions()
    n = len(drawn)
    assert len(config["instructions"]) == n and len(config["trained_instructions"]) == 2  # seeds 0 and 1 differ
    r = cli("eval", "--policy", str(out), "--episodes", "1", "--video", str(tmp_path / "v"), "--videos", "1", "--json")
    assert r.returncode == 0 and f"{n - 2} of the task's {n} instructions never came up in the policy's" in r.stderr
    result = json.loads(r.stdout)
    assert result["episodes"] == 1 and Path(result["videos"][0]).stat().st_size > 1000
    import imageio.v3 as iio  # the video at a size people watch, not the policy's 64 px input

    assert iio.improps(result["videos"][0], plugin="pyav").shape[1:3] == (384, 512)
    config_file = out / "checkpoints" / "last" / "pretrained_model" / "config.json"
    unknown = next(t for t in drawn if t not in config["trained_instructions"])
    config["instructions"] = [f"{t}, slowly" if t == unknown else t for t in config["instructions"]]
    config_file.write_text(json.dumps(config))  # as if trained where the task's text for that gesture was another
    one_line_error(cli("eval", "--policy", str(out), "--episodes", "1"), f"does not know the instruction {unknown!r}, "
                   "which pose can draw: it was trained for pose with another task config")  # fmt: skip
    # images only: the checkpoint reads the camera and nothing else
    only = tmp_path / "images_only"
    ok_json("train", "--repo-id", "test/cam", "--root", str(root), "--steps", "2", "--batch-size", "8",
            "--inputs", "images", "--out", str(only))  # fmt: skip
    config = json.loads((only / "checkpoints" / "last" / "pretrained_model" / "config.json").read_text())
    assert list(config["input_features"]) == ["observation.images.front"]
    # workers: the same per-seed results as one process
    runs = [ok_json("eval", "--policy", str(only), "--episodes", "2", "--workers", w)["runs"] for w in ("1", "2")]
    assert runs[0] == runs[1] and len(runs[0]) == 2
    replayed = replay(resolve("test/cam", root=root), 1)  # states only: no video is decoded
    assert replayed["reproduced"] and replayed["max_abs"] == 0.0

    # gloverec edit on a camera dataset: the trimmed episode's frames decoded and encoded again, still its own
    edited = tmp_path / "cam_edited"
    r = cli("edit", "--repo-id", "test/cam", "--root", str(root), "--out", str(edited), "--trim", "1:0.5-end")
    assert r.returncode == 0, r.stderr
    before, after = LeRobotDataset("test/cam", root=root), LeRobotDataset("test/cam", root=edited)
    skip = int(np.ceil(0.5 * before.meta.fps))
    assert after.num_episodes == 2 and after.meta.episodes[1]["length"] == before.meta.episodes[1]["length"] - skip
    first_kept = before[int(before.meta.episodes[1]["dataset_from_index"]) + skip]["observation.images.front"]
    first_now = after[int(after.meta.episodes[1]["dataset_from_index"])]["observation.images.front"]
    later = before[int(before.meta.episodes[1]["dataset_to_index"]) - 1]["observation.images.front"]
    same, other = (first_now - first_kept).abs().mean(), (first_now - later).abs().mean()  # 0.004 vs 0.018 here
    assert same < 0.01 and 3 * same < other, (same, other)  # the kept frame (through a second encoding)
