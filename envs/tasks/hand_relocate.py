"""HandRelocate: pick an object up and put it down inside a target circle drawn on the table (ADROIT's relocate,
on our robots, with the target on the table).

A free-wrist task: the action carries the palm position (``base_position``, the wearer's wrist from a tracker,
recorder/wrist), so the wearer does the approach, the lift, the carry and the release; nothing is scripted but
the start, palm down ``hover_m`` above the object. Each episode draws an object as HandGrasp does (box, upright
cylinder or sphere; size, mass, friction, position and yaw randomised) and a target circle ``target_distance_m``
away in a random direction.

Success: the object rests (below ``rest_m`` above its start height) with its centre inside the circle for
``settle_s``; the episode then ends. Reward: 1 on every step the object is inside the circle, else 0.
environment_state: HandGrasp's (object pose, half extents, shape one-hot), then the target's centre (x, y).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np

from envs.tasks.hand_grasp import HandGraspConfig, HandGraspEnv
from envs.tasks.registry import register_task
from envs.tasks.segments import LIFT_M, PickUpSegmentation, Segment, cut, first
from recorder import quat
from recorder.config import Positive

Range = tuple[float, float]


@dataclass
class HandRelocateConfig(HandGraspConfig):
    base_position: bool = True  # a free wrist: the task cannot be done otherwise
    episode_s: Annotated[float, Positive] = 8.0
    tilt_prob: float = 0.0  # no scripted tilt: the wearer holds the palm
    target_distance_m: Range = (0.12, 0.18)  # from the object's start to the circle's centre
    target_radius_m: Annotated[float, Positive] = 0.04
    rest_m: Annotated[float, Positive] = 0.01
    settle_s: Annotated[float, Positive] = 0.5

    def min_episode_s(self) -> float:
        return 0.0  # nothing scripted


class RelocateSegmentation(PickUpSegmentation):
    """Reach and grasp follow the object; the carry (lift, carry, put down) and the release follow the target
    circle. The carry starts where the object lifts, the release where the hand lets go of it on the table. A
    source serves a scene with the same shape; the nearest in size is taken, then the one whose circle lies in
    the most similar direction and distance from the object (the carry is bent the least)."""

    names = ("reach", "grasp", "carry", "release")

    def split(self, trace: dict[str, np.ndarray]) -> list[Segment]:
        touching, rise = trace["touching"], trace["rise"]
        touch = first(touching > 0)
        lift = first(rise > LIFT_M, touch) if touch is not None else None
        down = first(rise < LIFT_M, lift) if lift is not None else None
        release = first(touching == 0, down) if down is not None else None
        return cut(self.names, [touch, lift, release], len(touching), ("object", "object", "target", "target"))

    def anchors(self, env) -> dict[str, np.ndarray]:
        return {**super().anchors(env), "target": np.array([*env.target, 0.0])}

    def scene(self, env) -> dict:
        return {**super().scene(env), "target_offset_m": [float(x) for x in env.target - env.object_start[:2]]}

    def distance(self, a: dict, b: dict) -> float:
        offset = float(np.linalg.norm(np.subtract(a["target_offset_m"], b["target_offset_m"])))
        return super().distance(a, b) + 0.1 * offset


@register_task(
    "relocate",
    env_id="gloverec/HandRelocate-v0",
    demonstrator="recorder.demonstrator.relocate:RelocateDemonstrator",
    live={"terminate_on_success": False},
    segmentation=RelocateSegmentation(),
)
class HandRelocateEnv(HandGraspEnv):
    config_class = HandRelocateConfig
    workspace = (0.0, 0.0, 0.10)
    reach_m = (0.3, 0.3, 0.25)
    environment_state_names = (*HandGraspEnv.environment_state_names, "target.x", "target.y")

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        if not self.config.base_position:
            raise config.ConfigError(
                "relocate task: base_position must stay on: it scripts no base, the wrist moves it"
            )
        self.target = np.zeros(2)
        self._inside_since = None

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        super()._build_task(spec)
        for geom in spec.geoms:  # rolling friction: a ball put down stays where it was put, as on a real table
            if geom.name.startswith("object_"):
                geom.condim = 6
        spec.worldbody.add_body(name="target", mocap=True, pos=[0, 0, 0.0005]).add_geom(
            name="target",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[self.config.target_radius_m, 0.0005, 0],
            rgba=[0.95, 0.85, 0.2, 0.6],
            contype=0,
            conaffinity=0,
        )

    def _reset_task(self) -> None:
        super()._reset_task()
        rng, cfg = self.np_random, self.config
        geom = self._object[1]
        self.model.geom_friction[geom, 2] = 0.002  # m: rolling, about a rubber ball's on a tabletop
        angle = rng.uniform(-np.pi, np.pi)
        self.target = self.object_start[:2] + rng.uniform(*cfg.target_distance_m) * np.array(
            [np.cos(angle), np.sin(angle)]
        )
        self.data.mocap_pos[self.model.body_mocapid[self.model.body("target").id]] = [*self.target, 0.0005]
        self._inside_since = None
        self.schedule = {}  # nothing scripted: the view has no "lift in" to say

    def _base_target(self, t: float):
        pos = self._grasp_pos.copy()
        pos[2] += self.config.hover_m
        return pos, quat.IDENTITY.copy()

    def _environment_state(self) -> np.ndarray:
        return np.concatenate((super()._environment_state(), self.target))

    def inside(self) -> bool:
        """The object's centre is inside the circle."""
        return bool(np.linalg.norm(self.object_pose()[:2] - self.target) < self.config.target_radius_m)

    def resting(self) -> bool:
        return bool(self.object_pose()[2] - self.object_start[2] < self.config.rest_m)

    def dropped(self) -> bool:
        return False

    def failure(self) -> str | None:
        off = float(np.linalg.norm(self.object_pose()[:2] - self.target))
        if not self.resting():
            return "still held up" if self.hand_contacts(self._object[1]) else "not resting on the table"
        if off >= self.config.target_radius_m:
            moved = float(np.linalg.norm(self.object_pose()[:2] - self.object_start[:2]))
            where = "never moved" if moved < 0.02 else f"put down {100 * off:.1f} cm from the circle's centre"
            return where
        return "in the circle, not yet settled when the episode ended" if self._inside_since is not None else None

    def _evaluate(self):
        cfg = self.config
        inside = self.inside()
        if inside and self.resting():
            self._inside_since = self.t if self._inside_since is None else self._inside_since
        else:
            self._inside_since = None
        success = self._inside_since is not None and self.t - self._inside_since >= cfg.settle_s - 1e-9
        end = self.t >= cfg.episode_s - 1e-9
        return success, (success and cfg.terminate_on_success) or end, float(inside)

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "target": [round(float(x), 4) for x in self.target]}

    def guidance(self) -> str | None:
        if self.inside() and self.resting():
            return "let go"
        held = self.hand_contacts(self._object[1]) >= 2 and not self.resting()
        return f"carry the {self.object_shape} to the circle" if held else f"pick up the {self.object_shape}"

    def instruction(self) -> str:
        return f"put the {self.object_shape} in the circle"

    def instructions(self) -> tuple[str, ...]:
        return tuple(f"put the {shape} in the circle" for shape in self.config.shapes)
