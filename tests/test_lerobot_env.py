"""The LeRobot environment `gloverec` (envs/plugin/lerobot_robot_gloverec: config_gloverec_env.py, gloverec_env.py):
its features are a gloverec dataset's, its observations reach a policy under the dataset's keys, and lerobot-eval
scores a policy trained on a recorded dataset seed by seed as `gloverec eval` does."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
from lerobot.envs.factory import make_env_config
from lerobot.envs.utils import NEW_ROLLOUT_OPTION, env_to_policy_features, preprocess_observation
from lerobot.utils.feature_utils import dataset_to_policy_features
from lerobot_robot_gloverec import GloverecEnvConfig
from test_policies import REPO, dataset, ok_json, trained  # noqa: F401  (the module-scoped dataset and BC policy)

from recorder.config import ConfigError

REPO_ROOT = Path(__file__).resolve().parents[1]
LEROBOT_EVAL = Path(sys.executable).with_name("lerobot-eval")
SEED = 100_000  # gloverec eval's default first seed


def test_the_env_type_has_the_features_of_a_recorded_dataset(dataset):  # noqa: F811
    cfg = make_env_config("gloverec", task="pose", robot="glovehand")
    assert isinstance(cfg, GloverecEnvConfig)
    ds = dataset_to_policy_features(LeRobotDatasetMetadata(REPO, root=dataset).features)
    env = env_to_policy_features(cfg)
    assert set(env) == {"action", "observation.state", "observation.environment_state"}
    assert {k: v.shape for k, v in env.items()} == {k: ds[k].shape for k in env}


def test_observations_reach_the_policy_under_the_dataset_keys():
    cfg = GloverecEnvConfig(task="pose", robot="glovehand", cameras=["front"], image_size=(48, 64), episode_s=1.0)
    vec = cfg.create_envs(n_envs=2)["gloverec"][0]
    try:
        obs, info = vec.reset(seed=[SEED, SEED + 1], options={NEW_ROLLOUT_OPTION: True})
        batch = preprocess_observation(obs)
        policy = env_to_policy_features(cfg)
        assert {k: tuple(v.shape[1:]) for k, v in batch.items()} == {k: v.shape for k, v in policy.items()
                                                                      if k != "action"}  # fmt: skip
        assert batch["observation.images.front"].shape == (2, 3, 48, 64)
        assert all(t.startswith("make the") for t in vec.call("task_description"))  # the episode's instruction
        assert vec.call("_max_episode_steps") == (30, 30)  # 1 s at 30 Hz, where the task truncates
        assert "is_success" in info
        # the episodes end where the task ends them (holding still, the hand makes no gesture: its time limit)
        ends = []
        for _ in range(30):
            _, _, terminated, truncated, _ = vec.step(np.zeros((2, *vec.single_action_space.shape), np.float32))
            ends.append(terminated | truncated)
        assert np.array(ends)[29].all() and not np.array(ends)[:29].any()
        # an ended episode is filmed as its last frame (LeRobot films a batch until its last episode ends)
        first = vec.envs[0].render()
        assert first.shape == (48, 64, 3) and vec.envs[0].render() is first
        vec.reset(seed=[SEED, SEED + 1], options={NEW_ROLLOUT_OPTION: True})
        assert vec.envs[0].render() is not first
    finally:
        vec.close()


def test_an_unknown_task_is_one_line():
    with pytest.raises(ConfigError, match="unknown"):
        GloverecEnvConfig(task="juggle")


@pytest.mark.process
def test_lerobot_eval_scores_each_seed_as_gloverec_eval(trained, tmp_path):  # noqa: F811
    """Two episodes in LeRobot's default vector environment (one process each): the same success and the same
    return (the same trajectory) per seed as `gloverec eval`, and success in lerobot-eval's eval_info.json."""
    out, _ = trained
    # this tree's plugins, as `make install` puts them on the path
    plugins = [str(REPO_ROOT / d / "plugin") for d in ("envs", "policies", "recorder")] + [str(REPO_ROOT)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*plugins, os.environ.get("PYTHONPATH", "")]),
           "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "OMP_NUM_THREADS": "1"}  # fmt: skip
    r = subprocess.run(
        [str(LEROBOT_EVAL), f"--policy.path={out}/checkpoints/last/pretrained_model", "--policy.device=cpu",
         "--env.type=gloverec", "--env.task=pose", "--env.robot=glovehand", "--eval.n_episodes=2",
         "--eval.batch_size=2", f"--seed={SEED}", f"--output_dir={tmp_path / 'eval'}"],
        capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr[-3000:]
    info = json.loads((tmp_path / "eval" / "eval_info.json").read_text())
    theirs = info["per_task"][0]["metrics"]
    ours = ok_json("eval", "--policy", str(out), "--episodes", "2", "--seed", str(SEED))["runs"]
    assert theirs["successes"] == [run["success"] for run in ours]
    assert [round(x, 4) for x in theirs["sum_rewards"]] == [run["return"] for run in ours]
    assert info["overall"]["pc_success"] == 50.0 * sum(run["success"] for run in ours)
