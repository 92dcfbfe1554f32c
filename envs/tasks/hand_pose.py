"""HandPose: reach a target gesture and hold it.

Each episode draws a gesture (recorder.hand.gestures.GESTURES); its goal, in ``observation.environment_state``,
is where the robot's actuated joints come to rest when its joint-mapped targets (the robot's joint map,
envs/robots/joint_map.py) move from the open hand to the gesture's in a minimum-jerk reach, as a wearer's would,
and then hold; found once per gesture by simulation: a gesture whose fingers collide (the thumb on a curled
finger) so gets a goal the robot can actually reach, and the one it reaches from where episodes start (where
colliding fingers come to rest depends on which arrives first). Success: every actuated joint within
``tolerance_deg`` of its target, continuously for ``hold_s``; the episode then terminates. The hand starts
near the open hand; its base hovers, palm down, and rotates with the glove's palm.
Reward: 1 while every joint is within tolerance, else -mean joint error (rad).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np
from pydantic import AfterValidator

from envs.tasks.base import HandEnv, TaskConfig
from envs.tasks.registry import register_task
from recorder import quat
from recorder.config import ConfigError, NonNegative, Positive
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import LIMITS, interpolate_dip
from recorder.hand.motion import min_jerk

REACH_S = 0.85  # the goal's reach from the open hand (s): a wearer's typical movement time
SETTLE_S = 1.5  # then held this long


def _gesture(name: str) -> str:
    if name not in GESTURES:
        raise ValueError(f"unknown gesture {name!r}; valid gestures: {', '.join(GESTURES)}")
    return name


@dataclass
class HandPoseConfig(TaskConfig):
    episode_s: Annotated[float, Positive] = 5.0
    gestures: tuple[Annotated[str, AfterValidator(_gesture)], ...] = (
        "fist",
        "pinch",
        "point",
        "two_fingers",
        "spiderman",
    )
    tolerance_deg: Annotated[float, Positive] = 8.0
    hold_s: Annotated[float, NonNegative] = 0.5
    start_noise_deg: Annotated[float, NonNegative] = 3.0  # joint noise of the starting (open) pose


@register_task(
    "pose",
    env_id="gloverec/HandPose-v0",
    demonstrator="recorder.demonstrator.pose:PoseDemonstrator",
    live={"episode_s": 1e9, "terminate_on_success": False},  # `gloverec view`: one scene until "next"
)
class HandPoseEnv(HandEnv):
    config_class = HandPoseConfig
    workspace = (0.0, 0.0, 0.25)

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        if not self.config.gestures:
            raise ConfigError("pose task: gestures: at least one gesture is needed")
        self._map = self.robot.joint_map
        self._goals = {}
        self.goal_name = self.config.gestures[0]
        self.goal_angles = GESTURES[self.goal_name]
        self.goal = self._map(self.goal_angles)
        self._held = 0

    def settled_goal(self, gesture: str) -> np.ndarray:
        """Actuated joint positions (nu,) after reaching from the open hand to ``gesture``'s joint-mapped targets
        in REACH_S (minimum jerk) and holding them for SETTLE_S."""
        if gesture not in self._goals:
            d = mujoco.MjData(self.model)
            d.qpos[:] = self.model.qpos0
            d.mocap_pos[self._mocap] = self.workspace
            d.mocap_quat[self._mocap] = quat.IDENTITY
            rp, rq = self.robot.root_in_palm
            d.qpos[self._base_qpos : self._base_qpos + 3] = np.array(self.workspace) + rp
            d.qpos[self._base_qpos + 3 : self._base_qpos + 7] = rq
            start, end = GESTURES["open"], GESTURES[gesture]
            d.qpos[self._jq] = self._robot_qpos(self._map(start))
            dt = self.model.opt.timestep
            reach = int(round(REACH_S / dt))
            for k in range(reach + int(round(SETTLE_S / dt))):
                d.ctrl[:] = self._map(start + min_jerk(min(k / reach, 1.0)) * (end - start))
                mujoco.mj_step(self.model, d)
            self._goals[gesture] = d.actuator_length.copy()
        return self._goals[gesture]

    def _robot_qpos(self, ctrl: np.ndarray) -> np.ndarray:
        """The hand's joint positions (in ``joint_names`` order) with its actuators at ``ctrl``."""
        q = self._map.qpos(ctrl)
        robot = self.robot.model
        return q[robot.jnt_qposadr[[robot.joint(n).id for n in self.joint_names]]]

    @property
    def environment_state_names(self):
        return tuple(f"goal.{n}" for n in self.robot.actuator_names)

    def _reset_task(self) -> None:
        rng = self.np_random
        self.goal_name = self.config.gestures[int(rng.integers(len(self.config.gestures)))]
        self.goal_angles = GESTURES[self.goal_name].copy()
        self.goal = self.settled_goal(self.goal_name)
        start = GESTURES["open"] + rng.normal(0.0, np.radians(self.config.start_noise_deg), len(LIMITS))
        start = interpolate_dip(np.clip(start, LIMITS[:, 0], LIMITS[:, 1]))
        self.data.qpos[self._jq] = self._robot_qpos(self._map(start))
        self._held = 0

    def _base_target(self, t: float):
        return np.array(self.workspace, float), quat.IDENTITY.copy()

    def _environment_state(self) -> np.ndarray:
        return self.goal

    def goal_qpos(self, qpos: np.ndarray, goal: np.ndarray | None = None) -> np.ndarray:
        """``qpos`` with the hand's actuated joints at ``goal`` (default: this episode's) and the joints coupled to
        them following: the robot holding the target gesture where it stands (a view draws it as a ghost)."""
        q = np.array(qpos, float)
        q[self._act_qpos] = self.goal if goal is None else goal
        m = self.model
        for c in self.robot.joint_map.couplings:
            q[m.jnt_qposadr[m.joint(c.joint).id]] = c.ratio * q[m.jnt_qposadr[m.joint(c.leader).id]]
        return q

    def joint_errors(self) -> np.ndarray:
        return np.abs(self.actuated_positions() - self.goal)

    def _evaluate(self):
        err = self.joint_errors()
        within = bool(np.all(err < np.radians(self.config.tolerance_deg)))
        self._held = self._held + 1 if within else 0
        success = self._held >= int(np.ceil(self.config.hold_s * self.config.control_hz - 1e-9))
        reward = 1.0 if within else -float(err.mean())
        return success, success and self.config.terminate_on_success, reward

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "goal": self.goal_name}

    def instruction(self) -> str:
        return self.instruction_for(self.goal_name)

    def instructions(self) -> tuple[str, ...]:
        return tuple(self.instruction_for(g) for g in self.config.gestures)

    @staticmethod
    def instruction_for(gesture: str) -> str:
        return f"make the {gesture.replace('_', ' ')} gesture"
