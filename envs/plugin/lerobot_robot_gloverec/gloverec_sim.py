"""GloverecSim: a gloverec MuJoCo hand task as a LeRobot ``Robot`` (`--robot.type=gloverec_sim`).

Every `send_action` steps the task once (lerobot-record paces the calls at its fps, which should equal the robot's
``fps``). Observations in LeRobot's layout: every float is its own key, so lerobot-record puts the hand's joint
state, its palm pose and the task's state (the goal's joint positions, or the object's pose) together into
``observation.state`` (the task built with ``state_includes_task``); cameras are ``(H, W, 3)`` images. Keys end in
``.pos`` where the element is a position, so lerobot-rollout passes them (recorder/lerobot_names.py).
lerobot-record never resets a robot between episodes, so this one resets its scene itself when the task ends
(the gesture held, the object dropped, or the task's time limit), with the next seed, and logs it.
"""

from __future__ import annotations

import logging
from functools import cached_property

import numpy as np
from lerobot.robots.robot import Robot
from lerobot.utils.errors import DeviceAlreadyConnectedError, DeviceNotConnectedError

import envs
from lerobot_robot_gloverec.config_gloverec_sim import GloverecSimConfig
from recorder.config import ConfigError
from recorder.lerobot_names import lerobot_action_name, lerobot_state_name
from recorder.speech import warn_if_prompts_will_fail

logger = logging.getLogger(__name__)


ROBOT_TYPE = "gloverec_sim"


def dataset_robot_type(task: str, robot: str) -> str:
    """``gloverec_sim:TASK:ROBOT``, the robot_type of a lerobot-record dataset of this robot."""
    return f"{ROBOT_TYPE}:{task}:{robot}"


class GloverecSim(Robot):
    config_class = GloverecSimConfig
    name = ROBOT_TYPE

    def __init__(self, config: GloverecSimConfig):
        super().__init__(config)
        self.config = config
        sizes = {(c.height, c.width) for c in config.cameras.values()}
        if len(sizes) > 1:
            raise ConfigError(f"gloverec_sim: cameras must all be the same size, got {sorted(sizes)}")
        options = {"control_hz": float(config.fps), "cameras": tuple(config.cameras), "state_includes_task": True}
        if sizes:
            options["image_size"] = sizes.pop()
        self.env = envs.make(config.task, config.robot, **options)  # a wrong name or option: one line
        self.unwrapped = self.env.unwrapped
        # lerobot-record stores ``robot.name`` as the dataset's robot_type: with the task and the robot in it,
        # `gloverec eval` reads what a policy trained on the dataset runs in from its metadata (dataset_robot_type)
        self.name = dataset_robot_type(config.task, config.robot)
        self.cameras = dict(config.cameras)  # lerobot-record sizes its image writer by len(robot.cameras)
        self.seed = config.seed
        self.episodes = 0  # scenes finished since connect
        self.state_keys = [lerobot_state_name(n) for n in self.unwrapped.state_names]
        self.action_keys = [lerobot_action_name(n) for n in self.unwrapped.action_names]
        self._obs: dict | None = None

    # ------------------------------------------------------------ features
    @cached_property
    def observation_features(self) -> dict:
        h, w = self.unwrapped.config.image_size
        return {**{name: float for name in self.state_keys}, **{cam: (h, w, 3) for cam in self.cameras}}

    @cached_property
    def action_features(self) -> dict:
        return {name: float for name in self.action_keys}

    # ------------------------------------------------------------ lifecycle
    @property
    def is_connected(self) -> bool:
        return self._obs is not None

    def connect(self, calibrate: bool = True) -> None:
        if self.is_connected:
            raise DeviceAlreadyConnectedError(f"{self} is already connected")
        warn_if_prompts_will_fail(ROBOT_TYPE)
        self._obs, _ = self.env.reset(seed=self.seed)
        logger.info("%s: %s on %s, scene seed %d", self, self.config.task, self.config.robot, self.seed)

    @property
    def is_calibrated(self) -> bool:
        return True  # a simulation needs no calibration

    def calibrate(self) -> None:
        pass

    def configure(self) -> None:
        pass

    def disconnect(self) -> None:
        if not self.is_connected:
            raise DeviceNotConnectedError(f"{self} is not connected")
        self._obs = None
        self.env.close()

    # ------------------------------------------------------------ the loop
    def get_observation(self) -> dict:
        if not self.is_connected:
            raise DeviceNotConnectedError(f"{self} is not connected")
        obs = dict(zip(self.state_keys, self._obs["observation.state"].tolist()))
        for cam in self.cameras:
            obs[cam] = self._obs[f"observation.images.{cam}"]
        return obs

    def send_action(self, action: dict) -> dict:
        """Step the task with ``action`` (the robot's action keys, or the plain actuator names of a dataset recorded
        before them, as lerobot-replay sends; another robot's are refused in one line); returns the action as
        applied (clipped to the action space)."""
        if not self.is_connected:
            raise DeviceNotConnectedError(f"{self} is not connected")
        keys = self.action_keys
        old = action.keys() >= set(self.unwrapped.action_names) and not action.keys() & set(keys)
        names = self.unwrapped.action_names if old else keys
        missing = [n for n in names if n not in action]
        if missing:
            raise ConfigError(
                f"gloverec_sim drives {self.config.robot}, but the action has no {missing[0]!r} (it has "
                f"{', '.join(list(action)[:4])}, ...): the teleoperator or policy drives another robot"
            )
        self._obs, _, terminated, truncated, info = self.env.step(np.array([action[n] for n in names], np.float32))
        ended = "the task's time limit" if truncated else "done" if terminated else None
        if ended is None and getattr(self.unwrapped, "dropped", lambda: False)():
            ended = "object dropped"
        if ended is not None:
            self._next_scene(ended, bool(info["is_success"]))
        return dict(zip(keys, info["applied_action"].tolist()))

    def __str__(self) -> str:
        return f"gloverec_sim({self.config.task} on {self.config.robot})"

    def _next_scene(self, why: str, success: bool) -> None:
        self.episodes += 1
        self.seed += 1
        logger.info("%s: scene ended (%s, success=%s): reset with seed %d", self, why, success, self.seed)
        self._obs, _ = self.env.reset(seed=self.seed)
