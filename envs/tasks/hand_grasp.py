"""HandGrasp: grasp an object from above and keep it in the hand through a scripted lift (and tilt).

Each episode draws an object (box, upright cylinder or sphere; size, mass, friction, position and yaw
randomised) resting on the table. The task scripts the hand base (the palm frame): it hovers palm down above
the object (with a small random misalignment), descends until the palm touches the object's top, waits while
the hand closes, lifts by ``lift_m`` and, in ``tilt_prob`` of the episodes, tilts by ``tilt_deg`` about a
random horizontal axis, then holds. The action's palm rotation (the glove's) is applied on top of the script.
The phase start times are in ``schedule``; the episode ends at ``episode_s``.

Success (at the end): the object is at least ``lift_m / 2`` above where it started and touches at least two
hand bodies. Reward: 1 on every step where that holds, else 0.
environment_state: object position (3), orientation (4), half extents (3), shape one-hot (3).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import mujoco
import numpy as np

from envs.tasks.base import HandEnv, TaskConfig
from envs.tasks.registry import register_task
from envs.tasks.segments import PickUpSegmentation
from recorder import quat
from recorder.config import NonNegative, Positive
from recorder.hand.motion import min_jerk

SHAPES = ("box", "cylinder", "sphere")
Range = tuple[float, float]
_GEOM = {
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
}


def draw_object(rng: np.random.Generator, cfg) -> tuple[str, np.ndarray]:
    """An object's shape and half extents (3, m) from ``cfg``'s shapes and ranges (HandGrasp's, HandPick's)."""
    shape = cfg.shapes[int(rng.integers(len(cfg.shapes)))]
    if shape == "box":
        return shape, np.array([rng.uniform(*r) for r in cfg.box_half])
    if shape == "cylinder":
        r, h = (rng.uniform(*x) for x in cfg.cylinder_size)
        return shape, np.array([r, r, h])
    return shape, np.full(3, rng.uniform(*cfg.sphere_radius))


@dataclass
class HandGraspConfig(TaskConfig):
    episode_s: Annotated[float, Positive] = 5.5
    shapes: tuple[Literal["box", "cylinder", "sphere"], ...] = SHAPES
    # half extents (m), each a (low, high) range: box (x, y, z), cylinder (radius, half height), sphere (radius)
    box_half: tuple[Range, Range, Range] = ((0.022, 0.030), (0.022, 0.030), (0.030, 0.040))
    cylinder_size: tuple[Range, Range] = ((0.022, 0.030), (0.035, 0.045))
    sphere_radius: Range = (0.030, 0.038)
    mass_kg: Range = (0.05, 0.15)
    friction: Range = (0.8, 1.2)
    placement_m: Annotated[float, NonNegative] = 0.04  # object centre uniform in ±placement_m (x and y)
    misalignment_m: Annotated[float, NonNegative] = 0.008  # base xy error relative to the object, uniform in ±
    hover_m: Annotated[float, NonNegative] = 0.08  # start this high above the grasp pose
    lift_m: float = 0.12
    tilt_deg: float = 25.0
    tilt_prob: Annotated[float, NonNegative] = 0.5
    descend_s: Annotated[float, Positive] = 1.0  # phase durations
    close_s: Annotated[float, Positive] = 1.3
    lift_s: Annotated[float, Positive] = 1.2
    tilt_s: Annotated[float, Positive] = 1.0

    def min_episode_s(self) -> float:
        """The base script: descend, close, lift and (when episodes can tilt) tilt, then at least a moment held."""
        tilts = self.tilt_prob > 0 and self.tilt_deg != 0
        return self.descend_s + self.close_s + self.lift_s + (self.tilt_s if tilts else 0.0)


@register_task("grasp", env_id="gloverec/HandGrasp-v0", demonstrator="recorder.demonstrator.grasp:GraspDemonstrator",
               segmentation=PickUpSegmentation())  # fmt: skip
class HandGraspEnv(HandEnv):
    config_class = HandGraspConfig
    workspace = (0.0, 0.0, 0.10)
    environment_state_names = (
        "object.x",
        "object.y",
        "object.z",
        "object.qw",
        "object.qx",
        "object.qy",
        "object.qz",
        "object.hx",
        "object.hy",
        "object.hz",
        *(f"object.is_{s}" for s in SHAPES),
    )

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        bad = [s for s in self.config.shapes if s not in SHAPES]
        if bad:
            raise ValueError(f"unknown shape {bad[0]!r}; valid shapes: {', '.join(SHAPES)}")
        self.object_shape = self.config.shapes[0]
        self.object_half = np.full(3, 0.03)
        self.schedule = {}

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        colours = {"box": [0.85, 0.45, 0.2, 1], "cylinder": [0.25, 0.55, 0.85, 1], "sphere": [0.35, 0.75, 0.35, 1]}
        for k, shape in enumerate(SHAPES):
            body = spec.worldbody.add_body(name=f"object_{shape}", pos=[0.3 + 0.1 * k, 0.6, 0.05])
            body.add_freejoint(name=f"object_{shape}")
            body.add_geom(
                name=f"object_{shape}",
                type=_GEOM[shape],
                size=[0.03, 0.03, 0.03],
                rgba=colours[shape],
                condim=4,
                friction=[1.0, 0.01, 0.0005],
                mass=0.1,
                solref=[0.004, 1.0],
            )

    def _init_indices(self) -> None:
        super()._init_indices()
        m = self.model
        self._obj = {
            s: (
                m.body(f"object_{s}").id,
                m.geom(f"object_{s}").id,
                m.jnt_qposadr[m.joint(f"object_{s}").id],
                m.jnt_dofadr[m.joint(f"object_{s}").id],
            )
            for s in SHAPES
        }
        self._rgba = {s: m.geom_rgba[self._obj[s][1]].copy() for s in SHAPES}

    # ------------------------------------------------------------ episode
    def _reset_task(self) -> None:
        m, d, rng, cfg = self.model, self.data, self.np_random, self.config
        shape, half = draw_object(rng, cfg)
        self.object_shape, self.object_half = shape, half
        mass = rng.uniform(*cfg.mass_kg)
        for k, s in enumerate(SHAPES):
            body, geom, qadr, dadr = self._obj[s]
            active = s == shape
            # parked objects float out of the way: no contacts, no gravity, invisible
            m.geom_contype[geom] = m.geom_conaffinity[geom] = int(active)
            m.geom_rgba[geom] = self._rgba[s] * [1, 1, 1, int(active)]
            m.body_gravcomp[body] = 0.0 if active else 1.0
            d.qpos[qadr : qadr + 7] = [1.5 + 0.2 * k, 1.5, 0.5, 1, 0, 0, 0]
        body, geom, qadr, dadr = self._obj[shape]
        size = {"box": half, "cylinder": [half[0], half[2], 0], "sphere": [half[0], 0, 0]}[shape]
        m.geom_size[geom] = size
        m.geom_rbound[geom] = np.linalg.norm(half) if shape != "sphere" else half[0]
        m.geom_aabb[geom] = [0, 0, 0, *half]
        mu = rng.uniform(*cfg.friction)
        m.geom_friction[geom] = [mu, 0.01, 0.0005]
        m.body_mass[body] = mass
        x2 = (2 * half) ** 2
        if shape == "box":
            inertia = mass / 12 * np.array([x2[1] + x2[2], x2[0] + x2[2], x2[0] + x2[1]])
        elif shape == "cylinder":
            r, h = half[0], 2 * half[2]
            inertia = mass * np.array([(3 * r * r + h * h) / 12, (3 * r * r + h * h) / 12, r * r / 2])
        else:
            inertia = np.full(3, 0.4 * mass * half[0] ** 2)
        m.body_inertia[body] = inertia
        xy = rng.uniform(-cfg.placement_m, cfg.placement_m, 2)
        yaw = rng.uniform(-np.pi, np.pi) if shape != "sphere" else 0.0
        self.object_start = np.array([xy[0], xy[1], half[2]])
        self._top = 0.0  # the object's highest rise this episode
        d.qpos[qadr : qadr + 7] = [*self.object_start, np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]
        self._object = (body, geom, qadr)

        # the base script: palm point (robot grasp_point) just above the object's top
        gp = np.array(self.robot.config.grasp_point)
        err = rng.uniform(-cfg.misalignment_m, cfg.misalignment_m, 2)
        self._grasp_pos = np.array([xy[0] + err[0], xy[1] + err[1], 2 * half[2] + 0.003]) - gp
        axis_angle = rng.uniform(0, 2 * np.pi)
        tilt = np.radians(cfg.tilt_deg) * (rng.random() < cfg.tilt_prob)
        self._tilt_axis = np.array([np.cos(axis_angle), np.sin(axis_angle), 0.0])
        self._tilt = tilt
        t = 0.0
        self.schedule = {}
        for phase, dur in (
            ("descend", cfg.descend_s),
            ("close", cfg.close_s),
            ("lift", cfg.lift_s),
            ("tilt", cfg.tilt_s if tilt else 0.0),
            ("hold", 0.0),
        ):
            self.schedule[phase] = t
            t += dur
        self.schedule["end"] = cfg.episode_s

    def _base_target(self, t: float):
        s = self.schedule
        pos = self._grasp_pos.copy()
        pos[2] += self.config.hover_m * (1.0 - min_jerk((t - s["descend"]) / self.config.descend_s))
        pos[2] += self.config.lift_m * min_jerk((t - s["lift"]) / self.config.lift_s)
        q = quat.IDENTITY.copy()
        if self._tilt:
            angle = self._tilt * min_jerk((t - s["tilt"]) / self.config.tilt_s)
            q = quat.from_axis_angle(self._tilt_axis, angle)
        return pos, q

    @property
    def object_geom(self) -> int:
        """The geom of the episode's object (what the hand must hold)."""
        return int(self._object[1])

    def displace_object(self, offset) -> None:
        """Move the object by ``offset`` (x, y, m) where it rests, at rest (a push that slid it there): the state a
        demonstrator must recover from (bench/envs.py's displacement, tests)."""
        qadr = self._object[2]
        self.data.qpos[qadr : qadr + 2] += np.asarray(offset, float)[:2]
        self.data.qvel[self.model.jnt_dofadr[self.model.body_jntadr[self._object[0]]] :][:6] = 0.0
        mujoco.mj_forward(self.model, self.data)

    def object_pose(self) -> np.ndarray:
        qadr = self._object[2]
        return self.data.qpos[qadr : qadr + 7].copy()

    def _environment_state(self) -> np.ndarray:
        onehot = np.array([s == self.object_shape for s in SHAPES], float)
        return np.concatenate((self.object_pose(), self.object_half, onehot))

    def held(self) -> bool:
        lifted = self.object_pose()[2] - self.object_start[2] >= 0.5 * self.config.lift_m
        return bool(lifted and self.hand_contacts(self._object[1]) >= 2)

    def dropped(self) -> bool:
        """The script's lift is over and the object is back near the table: it fell, or was never held."""
        if self.t < self.schedule["hold"]:
            return False
        return bool(self.object_pose()[2] - self.object_start[2] < 0.25 * self.config.lift_m)

    def failure(self) -> str | None:
        rise, bodies = self.object_pose()[2] - self.object_start[2], self.hand_contacts(self._object[1])
        if rise < 0.5 * self.config.lift_m:
            return f"dropped after a {100 * self._top:.0f} cm lift" if self._top > 0.01 else "not lifted"
        return None if bodies >= 2 else f"lifted, but held by {bodies} hand bod{'y' if bodies == 1 else 'ies'}"

    def _evaluate(self):
        self._top = max(self._top, float(self.object_pose()[2] - self.object_start[2]))  # (why a take failed)
        held = self.held()
        end = self.t >= self.config.episode_s - 1e-9
        return held and end, end, float(held)

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "object": self.object_shape}

    def instruction(self) -> str:
        return f"grasp the {self.object_shape} and keep holding it"

    def instructions(self) -> tuple[str, ...]:
        return tuple(f"grasp the {shape} and keep holding it" for shape in self.config.shapes)
