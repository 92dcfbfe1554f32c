"""HandPick: of two objects on the table, a red one and a blue one, pick up the one the instruction names: a grasp
that must be aimed.

HandGrasp gives itself away: its script hovers the palm over the only object, and its instruction names the shape,
so a fist closed on cue succeeds and a policy with its images blanked does as well as one with cameras. Here nothing
is scripted: the wrist is free (``base_position``, the wearer's from a tracker) and the hand starts at a fixed home
pose, palm down ``home_m`` above the table's centre, whatever the layout. Each episode draws two objects, each a box,
upright cylinder or sphere with HandGrasp's sizes, masses and frictions, coloured red and blue, anywhere within
``placement_m`` of the centre and at least ``separation_y_m`` apart across the hand (in y: the hand lies along x,
wrist to fingertips, so an object beside the one grasped is clear of the palm, the fingers and Shadow's forearm),
and the target colour. The instruction names the colour only ("pick up the red one"), so what to reach for and
where is in the cameras (and in environment_state).

Success: the target is at least ``lift_m / 2`` above where it started, touches at least two hand bodies, and the
other object is not lifted (less than ``other_lift_m`` above its start), all for ``settle_s``; the episode then ends
(``episode_s`` at most). Reward: 1 on every step where that holds, else 0.
environment_state, per colour (red, then blue): position (3), orientation (4), half extents (3), shape one-hot (3),
then the target's colour one-hot (2).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import mujoco
import numpy as np

from envs.tasks.base import HandEnv, TaskConfig
from envs.tasks.hand_grasp import _GEOM, SHAPES, HandGraspConfig, draw_object
from envs.tasks.registry import register_task
from envs.tasks.segments import PickUpSegmentation
from recorder import quat
from recorder.config import ConfigError, NonNegative, Positive

Range = tuple[float, float]
COLOURS = ("red", "blue")
_RGBA = {"red": (0.85, 0.12, 0.12, 1.0), "blue": (0.12, 0.3, 0.9, 1.0)}
_PARKED = (1.5, 1.5, 0.5)  # where the shapes not drawn wait: out of reach and sight, no contacts, no gravity
_KEYS = ("x", "y", "z", "qw", "qx", "qy", "qz", "hx", "hy", "hz")


@dataclass
class HandPickConfig(TaskConfig):
    base_position: bool = True  # a free wrist: the wearer reaches (the task cannot be done otherwise)
    episode_s: Annotated[float, Positive] = 6.0
    targets: tuple[Literal["red", "blue"], ...] = COLOURS  # the colours an instruction may name
    shapes: tuple[Literal["box", "cylinder", "sphere"], ...] = SHAPES
    box_half: tuple[Range, Range, Range] = HandGraspConfig.box_half  # each object's sizes, masses and frictions:
    cylinder_size: tuple[Range, Range] = HandGraspConfig.cylinder_size  # HandGrasp's
    sphere_radius: Range = HandGraspConfig.sphere_radius
    mass_kg: Range = HandGraspConfig.mass_kg
    friction: Range = HandGraspConfig.friction
    placement_m: tuple[Annotated[float, NonNegative], Annotated[float, NonNegative]] = (0.15, 0.18)  # centres, ±x, ±y
    separation_y_m: Annotated[float, NonNegative] = 0.12  # the two centres at least this far apart in y
    home_m: Annotated[float, Positive] = 0.15  # the start: the robot's grasp point this high above the table's centre
    lift_m: Annotated[float, Positive] = 0.10
    other_lift_m: Annotated[float, Positive] = 0.02  # the other object higher than this above its start: lifted
    settle_s: Annotated[float, NonNegative] = 0.5


@dataclass(frozen=True)
class PickObject:
    """One object of an episode: its shape, half extents (m) and where it started (its centre, m, world)."""

    shape: str
    half: np.ndarray
    start: np.ndarray


@register_task("pick", env_id="gloverec/HandPick-v0", demonstrator="recorder.demonstrator.pick:PickDemonstrator",
               live={"terminate_on_success": False}, segmentation=PickUpSegmentation(position_weight=0.3))  # fmt: skip
class HandPickEnv(HandEnv):
    config_class = HandPickConfig
    workspace = (0.0, 0.0, 0.10)
    reach_m = (0.3, 0.3, 0.25)  # as HandRelocate's: the whole table the objects lie on, and above it
    environment_state_names = (
        *(f"pick.{c}.{k}" for c in COLOURS for k in (*_KEYS, *(f"is_{s}" for s in SHAPES))),
        *(f"pick.target.is_{c}" for c in COLOURS),
    )

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        cfg = self.config
        if not cfg.base_position:
            raise ConfigError("pick task: base_position must stay on: nothing scripts the base, the wrist moves it")
        if not cfg.targets or not cfg.shapes:
            raise ConfigError("pick task: targets and shapes need at least one entry each")
        if 2 * cfg.placement_m[1] < cfg.separation_y_m:
            raise ConfigError(
                f"pick task: separation_y_m {cfg.separation_y_m:g} does not fit in ±{cfg.placement_m[1]:g} m"
            )
        self.target = cfg.targets[0]
        self.objects = {c: PickObject(SHAPES[0], np.full(3, 0.03), np.zeros(3)) for c in COLOURS}
        self._held_since = None

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        for colour in COLOURS:  # every colour in every shape: an episode shows one shape of each, parks the others
            for shape in SHAPES:
                name = f"pick_{colour}_{shape}"
                body = spec.worldbody.add_body(name=name, pos=list(_PARKED))
                body.add_freejoint(name=name)
                body.add_geom(name=name, type=_GEOM[shape], size=[0.03, 0.03, 0.03], rgba=list(_RGBA[colour]),
                              condim=4, friction=[1.0, 0.01, 0.0005], mass=0.1, solref=[0.004, 1.0])  # fmt: skip

    def _init_indices(self) -> None:
        super()._init_indices()
        m = self.model
        self._ids = {
            (c, s): (m.body(f"pick_{c}_{s}").id, m.geom(f"pick_{c}_{s}").id, m.jnt_qposadr[m.joint(f"pick_{c}_{s}").id])
            for c in COLOURS
            for s in SHAPES
        }
        self._rgba = {k: m.geom_rgba[ids[1]].copy() for k, ids in self._ids.items()}

    # ------------------------------------------------------------ episode
    def _reset_task(self) -> None:
        rng, cfg = self.np_random, self.config
        # one draw for the target whatever ``targets`` holds, so that a seed lays out the same table for either
        # colour (a demonstration for the other colour, replayed on the same layout, must fail)
        self.target = cfg.targets[int(rng.random() * len(cfg.targets))]
        (px, py), sep = cfg.placement_m, cfg.separation_y_m
        while True:
            xy = rng.uniform([-px, -py], [px, py], (2, 2))
            if abs(xy[0, 1] - xy[1, 1]) >= sep:
                break
        for colour, shape in self._ids:
            self._park(colour, shape)
        for k, colour in enumerate(COLOURS):
            self.objects[colour] = self._place(colour, xy[k])
        self._held_since = None

    def _park(self, colour: str, shape: str) -> None:
        body, geom, qadr = self._ids[colour, shape]
        m = self.model
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 0
        m.geom_rgba[geom] = self._rgba[colour, shape] * [1, 1, 1, 0]
        m.body_gravcomp[body] = 1.0
        self.data.qpos[qadr : qadr + 7] = [*_PARKED, 1, 0, 0, 0]

    def _place(self, colour: str, xy: np.ndarray) -> PickObject:
        """Draw ``colour``'s shape, size, mass and friction (HandGrasp's ranges) and put it on the table at ``xy``."""
        m, rng, cfg = self.model, self.np_random, self.config
        shape, half = draw_object(rng, cfg)
        body, geom, qadr = self._ids[colour, shape]
        m.geom_contype[geom] = m.geom_conaffinity[geom] = 1
        m.geom_rgba[geom] = self._rgba[colour, shape]
        m.body_gravcomp[body] = 0.0
        m.geom_size[geom] = {"box": half, "cylinder": [half[0], half[2], 0], "sphere": [half[0], 0, 0]}[shape]
        m.geom_rbound[geom] = np.linalg.norm(half) if shape != "sphere" else half[0]
        m.geom_aabb[geom] = [0, 0, 0, *half]
        m.geom_friction[geom] = [rng.uniform(*cfg.friction), 0.01, 0.0005]
        mass = rng.uniform(*cfg.mass_kg)
        m.body_mass[body] = mass
        x2 = (2 * half) ** 2
        if shape == "box":
            m.body_inertia[body] = mass / 12 * np.array([x2[1] + x2[2], x2[0] + x2[2], x2[0] + x2[1]])
        elif shape == "cylinder":
            r2, h2 = half[0] ** 2, x2[2]
            m.body_inertia[body] = mass * np.array([(3 * r2 + h2) / 12, (3 * r2 + h2) / 12, r2 / 2])
        else:
            m.body_inertia[body] = np.full(3, 0.4 * mass * half[0] ** 2)
        yaw = rng.uniform(-np.pi, np.pi) if shape != "sphere" else 0.0
        start = np.array([xy[0], xy[1], half[2]])
        self.data.qpos[qadr : qadr + 7] = [*start, np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]
        return PickObject(shape, half, start)

    def _base_target(self, t: float):
        """The home pose: palm down, the robot's grasp point ``home_m`` above the table's centre (every episode)."""
        return np.array([0.0, 0.0, self.config.home_m]) - self.robot.config.grasp_point, quat.IDENTITY.copy()

    # ------------------------------------------------------------ state
    def other(self) -> str:
        """The colour not asked for."""
        return next(c for c in COLOURS if c != self.target)

    def object_pose(self, colour: str | None = None) -> np.ndarray:
        """``colour``'s object's pose (position, wxyz), by default the target's."""
        qadr = self._ids[colour or self.target, self.objects[colour or self.target].shape][2]
        return self.data.qpos[qadr : qadr + 7].copy()

    @property
    def object_geom(self) -> int:
        """The target's geom (what the hand must hold), as HandGrasp's ``object_geom``."""
        return int(self._ids[self.target, self.objects[self.target].shape][1])

    @property
    def object_shape(self) -> str:
        """The target's shape, as HandGrasp's ``object_shape``."""
        return self.objects[self.target].shape

    @property
    def object_half(self) -> np.ndarray:
        """The target's half extents (m), as HandGrasp's ``object_half``."""
        return self.objects[self.target].half

    @property
    def object_start(self) -> np.ndarray:
        """Where the target started (its centre), as HandGrasp's ``object_start``."""
        return self.objects[self.target].start

    def displace_object(self, offset) -> None:
        """Move the target by ``offset`` (x, y, m) where it rests, at rest, as HandGrasp's ``displace_object``."""
        body, _, qadr = self._ids[self.target, self.objects[self.target].shape]
        self.data.qpos[qadr : qadr + 2] += np.asarray(offset, float)[:2]
        dof = self.model.jnt_dofadr[self.model.body_jntadr[body]]
        self.data.qvel[dof : dof + 6] = 0.0
        mujoco.mj_forward(self.model, self.data)

    def lifted(self, colour: str) -> float:
        """How far ``colour``'s object is above where it started (m)."""
        return float(self.object_pose(colour)[2] - self.objects[colour].start[2])

    def _environment_state(self) -> np.ndarray:
        parts = []
        for colour in COLOURS:
            o = self.objects[colour]
            parts += [self.object_pose(colour), o.half, [float(o.shape == s) for s in SHAPES]]
        parts.append([float(c == self.target) for c in COLOURS])
        return np.concatenate(parts)

    def held(self) -> bool:
        """The target is lifted and held (two hand bodies on it), and the other object is not lifted."""
        cfg = self.config
        return bool(
            self.lifted(self.target) >= 0.5 * cfg.lift_m
            and self.hand_contacts(self.object_geom) >= 2
            and self.lifted(self.other()) < cfg.other_lift_m
        )

    def _evaluate(self):
        cfg = self.config
        held = self.held()
        self._held_since = (self._held_since if self._held_since is not None else self.t) if held else None
        success = self._held_since is not None and self.t - self._held_since >= cfg.settle_s - 1e-9
        end = self.t >= cfg.episode_s - 1e-9
        return success, (success and cfg.terminate_on_success) or end, float(held)

    def failure(self) -> str | None:
        cfg = self.config
        if self.lifted(self.other()) >= cfg.other_lift_m:
            return f"lifted the {self.other()} one"
        if self.lifted(self.target) < 0.5 * cfg.lift_m:
            moved = float(np.linalg.norm(self.object_pose()[:2] - self.objects[self.target].start[:2]))
            return f"not lifted (pushed {100 * moved:.0f} cm)" if moved > 0.02 else "not lifted"
        bodies = self.hand_contacts(self.object_geom)
        if bodies < 2:
            return f"lifted, but held by {bodies} hand bod{'y' if bodies == 1 else 'ies'}"
        return "held up, not yet for long enough when the episode ended" if self._held_since is not None else None

    def _info(self, success: bool) -> dict:
        shapes = {c: self.objects[c].shape for c in COLOURS}
        return {**super()._info(success), "target": self.target, "object": shapes[self.target], "shapes": shapes}

    def guidance(self) -> str | None:
        return "hold it up" if self.lifted(self.target) >= 0.5 * self.config.lift_m else self.instruction()

    def instruction(self) -> str:
        return f"pick up the {self.target} one"

    def instructions(self) -> tuple[str, ...]:
        return tuple(f"pick up the {c} one" for c in self.config.targets)
