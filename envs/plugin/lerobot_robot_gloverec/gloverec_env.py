"""A gloverec task as LeRobot's environments are (`--env.type=gloverec`: config_gloverec_env.py), and its vector
environments, for lerobot-eval and lerobot-train's ``--env_eval_freq``.

LeRobot's rollout (lerobot/scripts/lerobot_eval.py) feeds the policy through ``preprocess_observation``, which knows
``agent_pos`` (-> observation.state), ``environment_state`` (-> observation.environment_state) and ``pixels``
({camera: image} -> observation.images.<camera>); it asks each environment for ``task_description`` (the episode's
instruction, which a policy that reads the task is given) and ``_max_episode_steps``, and reads ``is_success`` from
``info``. An episode ends where `gloverec eval`'s does: when the task ends it or at its time limit. lerobot-eval
counts a success at any step and `gloverec eval` at the last; a task ends its episode on success
(``terminate_on_success``), so the two agree.

Seeds: lerobot-eval seeds episode k with ``--seed`` + k whatever its ``--eval.batch_size``, as `gloverec eval` does
with its ``--seed`` (100000 by default): the same seed gives the same scenes, and a deterministic policy the same
outcomes (a sampling one draws its noise from torch, which lerobot-eval seeds once per run, not per episode).
"""

from __future__ import annotations

from functools import cache, partial

import gymnasium as gym
import numpy as np
from lerobot.envs.utils import FreezeAfterEpisodeEnd

import envs

IMAGES = "observation.images."


def _layout(task_keys: dict) -> dict:
    """A task's ``observation.*`` entries (its spaces, or one observation's values) under LeRobot's names."""
    out = {"agent_pos": task_keys["observation.state"]}
    if "observation.environment_state" in task_keys:  # absent with state_includes_task
        out["environment_state"] = task_keys["observation.environment_state"]
    cams = {k.removeprefix(IMAGES): v for k, v in task_keys.items() if k.startswith(IMAGES)}
    if cams:
        out["pixels"] = cams
    return out


class LeRobotLayout(gym.ObservationWrapper):
    """A task's ``observation.*`` renamed to what ``preprocess_observation`` reads, and the attributes the rollout
    asks for."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        layout = _layout(env.observation_space.spaces)
        if "pixels" in layout:
            layout["pixels"] = gym.spaces.Dict(layout["pixels"])
        self.observation_space = gym.spaces.Dict(layout)
        cfg = env.unwrapped.config
        # lerobot-eval writes its videos at this rate through PyAV, which takes an int, not a float
        hz = cfg.control_hz
        self.metadata = {**env.metadata, "render_fps": int(hz) if float(hz).is_integer() else hz}
        # the task truncates once t = steps / control_hz reaches episode_s (envs/tasks/base.py)
        self._max_episode_steps = int(np.ceil(cfg.episode_s * cfg.control_hz - 1e-9))
        self._ended = False
        self._end_frame = None

    def reset(self, **kwargs):
        self._ended, self._end_frame = False, None
        return super().reset(**kwargs)

    def step(self, action):
        obs, reward, terminated, truncated, info = super().step(action)
        self._ended = terminated or truncated
        return obs, reward, terminated, truncated, info

    def render(self):
        # lerobot-eval films every environment of a batch until the batch's last episode ends: an ended episode's
        # scene no longer changes, so its last frame stands for the rest (rendering is most of a filmed step's cost)
        if self._end_frame is not None:
            return self._end_frame
        frame = self.env.render()
        if self._ended:
            self._end_frame = frame
        return frame

    def observation(self, obs: dict) -> dict:
        return _layout(obs)

    @property
    def task_description(self) -> str:
        return self.env.unwrapped.instruction()

    @property
    def task(self) -> str:
        return self.env.unwrapped.task_name


def make_one(task: str, robot: str, kwargs: dict) -> gym.Env:
    # frozen once its episode ends: in a batch, a finished episode waits for the others without stepping
    return FreezeAfterEpisodeEnd(LeRobotLayout(envs.make(task, robot, **kwargs)))


@cache
def _spaces(task: str, robot: str, options: tuple) -> tuple[gym.spaces.Dict, gym.spaces.Box]:
    env = LeRobotLayout(envs.make(task, robot, **dict(options)))
    try:
        return env.observation_space, env.action_space
    finally:
        env.close()


def spaces_of(task: str, robot: str, kwargs: dict) -> tuple[gym.spaces.Dict, gym.spaces.Box]:
    """The observation (LeRobot's layout) and action spaces of ``task`` on ``robot`` with ``kwargs``; an unknown
    name or option is one ConfigError line."""
    return _spaces(task, robot, tuple(sorted(kwargs.items())))


def make_vector_env(task: str, robot: str, kwargs: dict, n_envs: int, use_async: bool) -> gym.vector.VectorEnv:
    """``n_envs`` copies, stepped together: in this process, or (``use_async``, lerobot-eval's default) one process
    each, started by a fork server as LeRobot's own environments are (a forked EGL context does not survive)."""
    fns = [partial(make_one, task, robot, kwargs)] * n_envs
    mode = gym.vector.AutoresetMode.NEXT_STEP  # with the freeze, an ended episode's autoreset builds nothing
    if use_async and n_envs > 1:
        return gym.vector.AsyncVectorEnv(fns, context="forkserver", autoreset_mode=mode)
    return gym.vector.SyncVectorEnv(fns, autoreset_mode=mode)
