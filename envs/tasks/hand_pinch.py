"""HandPinch: a precision pick between the thumb and one named finger, lifted by a scripted base.

Each episode draws a small object (a marble, a coin-like disc lying flat, or a cube; size, mass, friction,
position and yaw randomised) resting on the table, and the finger that opposes the thumb (index or middle; ring
where the robot's thumb can reach it: ``fingers``). The instruction names both: "pick up the marble between your
thumb and middle finger", and the named finger's distal segment is lit in the scene (cameras see it). The task
scripts the hand base as HandGrasp does: it hovers palm down with the robot's pinch point (where its thumb and
the named finger meet, ``pinch_point``) above the object (with a small random misalignment), descends until that
point is at the object's centre, waits while the fingers close, lifts by ``lift_m``, then holds.

Success (at the end): the object is at least ``lift_m / 2`` above where it started and touches the thumb's distal
segment and the named finger's distal segment, and no other hand body (palm, other fingers): a power grasp fails
it. Reward: 1 on every step where that holds, else 0.
environment_state (``pinch.*``): object position (3), orientation (4), half extents (3), shape one-hot (3),
named finger one-hot (3: index, middle, ring).

Physics step: 2 ms, as the other tasks (``max_physics_dt``). 1 ms and 1.5 ms gave the same demonstrator
success on 20 seeds (glovehand 12/20, Shadow 13/20) at 1.6 times the cost of a control step (bench/envs.py's
step cost: glovehand 1298 against 811 us, Shadow 1644 against 1067 us); 2 ms costs what HandGrasp's step does.
LEAP did better at 1 ms (7/50 against 1/50), far from its goal either way.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Annotated, Literal

import mujoco
import numpy as np

from envs.tasks import postures
from envs.tasks.base import HandEnv, TaskConfig
from envs.tasks.registry import register_task
from envs.tasks.segments import LIFT_M, Segment, Segmentation, cut, first
from recorder import quat
from recorder.config import NonNegative, Positive
from recorder.hand.kinematics import JOINTS
from recorder.hand.motion import min_jerk

SHAPES = ("marble", "disc", "cube")
FINGERS = ("index", "middle", "ring")
Range = tuple[float, float]
_GEOM = {
    "marble": mujoco.mjtGeom.mjGEOM_SPHERE,
    "disc": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "cube": mujoco.mjtGeom.mjGEOM_BOX,
}
HIGHLIGHT = np.array([0.9, 0.2, 0.8, 1.0])  # the named finger's distal segment (magenta: no object's colour)

# --------------------------------------------------------------------------------------- the robot's pinch
# The pinch is a wearer's posture (envs/tasks/postures.py): thumb (cmc flex, cmc abd, mcp, ip) and the finger (mcp
# flex, pip), the other fingers straight. A human pinch does not close every robot's (the joint maps leave Shadow's
# 21 mm and LEAP's 60 mm open), so the posture is searched for the one whose robot fingertips are ``gap`` apart at
# one height.
PINCH_JOINTS = ("thumb_cmc_flex", "thumb_cmc_abd", "thumb_mcp", "thumb_ip", "{f}_mcp_flex", "{f}_pip")
_START = {"index": (10, 20, 25, 50, 40, 50), "middle": (15, 30, 40, 45, 35, 70), "ring": (40, 45, 10, 25, 65, 15)}


def _joints(finger: str) -> tuple[str, ...]:
    return tuple(n.format(f=finger) for n in PINCH_JOINTS)


def pinch_angles(finger: str, p) -> np.ndarray:
    """Human joint angles (20,) rad of a thumb-``finger`` pinch with parameters ``p`` (6, degrees)."""
    return postures.posture(np.zeros(len(JOINTS)), _joints(finger), p)


REFERENCE_GAP_MM = 16  # the pinch whose midpoint every other opening keeps
REACH_WEIGHT = 10.0  # a millimetre too deep costs what 3 mm of gap do (at 1 LEAP's pads stayed 1-2 mm too deep)


@lru_cache(maxsize=512)
def robot_pinch(
    robot: str, finger: str, gap_mm: int, about_mm: int = REFERENCE_GAP_MM, reach_mm: int | None = None
) -> tuple:
    """(posture parameters (6, deg), the pinch point (3, m, palm frame: the midpoint of the nearest points of the
    robot's thumb and ``finger`` pads), the gap reached (m), the pinch line (3, unit, thumb to finger)) for a gap of
    ``gap_mm`` between the two distal segments' surfaces (what an object between them must span); cached per robot,
    finger and mm. Every opening keeps the pinch point and line of the ``about_mm`` pinch (by default
    ``REFERENCE_GAP_MM``), so the fingertips open and close along one line through the object (not dragging it
    sideways), and the pinch line level. ``reach_mm``: the two pads reach at most this far below the pinch point (a
    pinch of a small object on a table must keep them off it; None: no bound)."""
    j = postures.retargeter(robot).fingers.index(finger)
    target = gap_mm / 1000.0
    if gap_mm == about_mm:  # the pinch to keep: its own midpoint, from the reference posture
        centre = line = None
        start = (
            _START[finger]
            if about_mm == REFERENCE_GAP_MM
            else robot_pinch(robot, finger, REFERENCE_GAP_MM, reach_mm=reach_mm)[0]
        )
    else:
        anchor = robot_pinch(robot, finger, about_mm, about_mm, reach_mm)
        start, centre, line = anchor[0], np.array(anchor[1]), np.array(anchor[3])

    def cost(t):
        gap, mid, direction = postures.pad_gap(robot, "thumb", finger)
        c = (gap - target) ** 2 + 0.5 * (t[j, 2] - t[0, 2]) ** 2
        if centre is not None:  # a 0.02 rad turn of the line costs what 1 mm off the centre does
            c += 0.5 * np.sum((mid - centre) ** 2) + 0.5 * 0.05**2 * np.sum((direction - line) ** 2)
        if reach_mm is not None:  # the pads' lowest point, how far below the pinch point (palm down: the table)
            bottom = min(postures.pad_bottom(robot, "thumb"), postures.pad_bottom(robot, finger))
            c += REACH_WEIGHT * max(0.0, mid[2] - bottom - reach_mm / 1000.0) ** 2
        return c

    p = postures.search(robot, np.zeros(len(JOINTS)), _joints(finger), start, cost)
    postures.robot_tips(robot, pinch_angles(finger, p))
    gap, mid, direction = postures.pad_gap(robot, "thumb", finger)
    return tuple(p), tuple(mid), gap, tuple(direction)


def pinching_fingers(
    robot: str, fingers=FINGERS, tolerance_m: float = 0.004, reach_mm: int | None = None
) -> tuple[str, ...]:
    """The fingers of ``fingers`` whose tips this robot's thumb can close on (a gap under ``tolerance_m``)."""
    have = postures.retargeter(robot).fingers
    return tuple(f for f in fingers if f in have and robot_pinch(robot, f, 0, reach_mm=reach_mm)[2] <= tolerance_m)


# --------------------------------------------------------------------------------------- the task
@dataclass
class HandPinchConfig(TaskConfig):
    episode_s: Annotated[float, Positive] = 5.5
    shapes: tuple[Literal["marble", "disc", "cube"], ...] = SHAPES
    fingers: tuple[Literal["index", "middle", "ring"], ...] = ("index", "middle")  # drawn per episode (those the
    # robot can pinch with)
    marble_radius: Range = (0.008, 0.012)
    disc_size: tuple[Range, Range] = ((0.010, 0.013), (0.007, 0.009))  # radius, half thickness (m): a thick coin, a
    # draughts piece
    cube_half: Range = (0.008, 0.010)
    mass_kg: Range = (0.005, 0.02)
    friction: Range = (0.9, 1.3)
    placement_m: Annotated[float, NonNegative] = 0.03
    yaw_deg: Annotated[float, NonNegative] = 15.0  # the cube's faces to the pinch line, uniform in ±
    misalignment_m: Annotated[float, NonNegative] = 0.003
    hover_m: Annotated[float, NonNegative] = 0.06
    min_pinch_height_m: Annotated[float, NonNegative] = 0.011  # fingertips meet at least this high
    pad_clearance_m: Annotated[float, NonNegative] = 0.001  # and the pinch posture keeps both pads this far above
    # the table there (robot_pinch's reach_mm: LEAP's thick distal links otherwise rest on it)
    hover_s: Annotated[float, NonNegative] = 0.7  # phase durations: the hand shapes the pinch high above it
    lift_m: float = 0.08
    descend_s: Annotated[float, Positive] = 1.0
    close_s: Annotated[float, Positive] = 1.2
    lift_s: Annotated[float, Positive] = 1.2

    def min_episode_s(self) -> float:
        return self.hover_s + self.descend_s + self.close_s + self.lift_s


class PinchSegmentation(Segmentation):
    """Close (until a hand body first touches the object), pinch (until it lifts 1 cm) and lift, each following the
    object where the wrist is free (recorded with --wrist). The base is scripted otherwise: what varies is the
    object (shape, width) and the named finger. A source serves a scene naming the same finger; the nearest width is
    taken, then the same shape. The grasp posture depends on the width (``robot_pinch`` searches it per millimetre,
    as the task does for its base), so it is planned again for the new object and the person's timing kept: each
    frame's actuator targets move by the difference between the robot's pinch postures for the new width and the
    source's, times how far the source's hand has closed by then (0 open, 1 at the lift)."""

    SHAPE_MM = 5.0  # another shape counts as this much more width apart

    def observe(self, env) -> dict[str, float]:
        return {"touching": float(len(env.touching())), "rise": float(env.object_pose()[2] - env.object_start[2])}

    def split(self, trace: dict[str, np.ndarray]) -> list[Segment]:
        touch = first(trace["touching"] > 0)
        lift = first(trace["rise"] > LIFT_M, touch) if touch is not None else None
        return cut(("close", "pinch", "lift"), [touch, lift], len(trace["rise"]), ("object",) * 3)

    def anchors(self, env) -> dict[str, np.ndarray]:
        return {"object": env.object_pose()[:3].copy()}  # followed by a free wrist (--wrist) only

    def scene(self, env) -> dict:
        return {"finger": env.finger, "shape": env.object_shape, "gap_mm": env.pinch_gap_mm()}

    def distance(self, a: dict, b: dict) -> float:
        if a["finger"] != b["finger"]:
            return float("inf")
        return abs(a["gap_mm"] - b["gap_mm"]) + self.SHAPE_MM * (a["shape"] != b["shape"])

    def adapt(self, actions: np.ndarray, segments: list[Segment], source: dict, scene: dict, env) -> np.ndarray:
        nu = len(env.robot.actuator_names)
        lift = next((s.start for s in segments if s.name == "lift"), len(actions) - 1)
        a = actions[:, :nu]
        close = a[lift] - a[0]
        if not close @ close:
            return actions
        progress = np.clip((a - a[0]) @ close / (close @ close), 0.0, 1.0)
        joint_map = postures.retargeter(env.robot.config.name).joint_map

        def targets(gap_mm: int) -> np.ndarray:
            return joint_map(pinch_angles(env.finger, env.robot_pinch(int(gap_mm))[0]))

        out = actions.copy()
        out[:, :nu] += progress[:, None] * (targets(scene["gap_mm"]) - targets(source["gap_mm"]))
        return out


@register_task("pinch", env_id="gloverec/HandPinch-v0", demonstrator="recorder.demonstrator.pinch:PinchDemonstrator",
               segmentation=PinchSegmentation())  # fmt: skip
class HandPinchEnv(HandEnv):
    config_class = HandPinchConfig
    view_distance_m = 0.5  # keys, knobs and marbles are small
    workspace = (0.0, 0.0, 0.08)
    environment_state_names = (
        *(f"pinch.object.{k}" for k in ("x", "y", "z", "qw", "qx", "qy", "qz", "hx", "hy", "hz")),
        *(f"pinch.object.is_{s}" for s in SHAPES),
        *(f"pinch.finger.is_{f}" for f in FINGERS),
    )

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        cfg = self.config
        self.pad_reach_mm = int(round(1000 * (cfg.min_pinch_height_m - cfg.pad_clearance_m)))
        self.fingers = pinching_fingers(self.robot.config.name, cfg.fingers, reach_mm=self.pad_reach_mm)
        if not self.fingers:
            raise ValueError(
                f"pinch task: {self.robot.config.name}'s thumb reaches none of {', '.join(self.config.fingers)}"
            )
        self.object_shape, self.finger = self.config.shapes[0], self.fingers[0]
        self.object_half = np.full(3, 0.01)
        self.schedule = {}

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        colours = {"marble": [0.3, 0.5, 0.9, 1], "disc": [0.85, 0.7, 0.3, 1], "cube": [0.8, 0.35, 0.35, 1]}
        for k, shape in enumerate(SHAPES):
            body = spec.worldbody.add_body(name=f"pinch_{shape}", pos=[0.3 + 0.1 * k, 0.6, 0.05])
            body.add_freejoint(name=f"pinch_{shape}")
            body.add_geom(
                name=f"pinch_{shape}",
                type=_GEOM[shape],
                size=[0.01, 0.01, 0.01],
                rgba=colours[shape],
                condim=6,  # torsional and rolling friction: a marble held at two points does not spin out
                friction=[1.0, 0.01, 0.001],
                mass=0.01,
                solref=[0.004, 1.0],
                priority=1,  # its friction, not the fingertip's, in its contacts
            )

    def _init_indices(self) -> None:
        super()._init_indices()
        m = self.model
        self._obj = {
            s: (m.body(f"pinch_{s}").id, m.geom(f"pinch_{s}").id, m.jnt_qposadr[m.joint(f"pinch_{s}").id])
            for s in SHAPES
        }
        self._rgba = {s: m.geom_rgba[self._obj[s][1]].copy() for s in SHAPES}
        tips = [m.site(n).id for n in self.robot.tip_sites]
        self._distal = {f: int(m.site_bodyid[t]) for f, t in zip(self.robot.fingers, tips)}
        self._distal_geoms = {f: np.flatnonzero(m.geom_bodyid == b) for f, b in self._distal.items()}
        self._rgba_all, self._matid_all = m.geom_rgba.copy(), m.geom_matid.copy()

    # ------------------------------------------------------------ episode
    def _reset_task(self) -> None:
        m, d, rng, cfg = self.model, self.data, self.np_random, self.config
        shape = cfg.shapes[int(rng.integers(len(cfg.shapes)))]
        self.finger = self.fingers[int(rng.integers(len(self.fingers)))]
        if shape == "marble":
            r = rng.uniform(*cfg.marble_radius)
            half = np.array([r, r, r])
        elif shape == "disc":
            r, h = rng.uniform(*cfg.disc_size[0]), rng.uniform(*cfg.disc_size[1])
            half = np.array([r, r, h])
        else:
            half = np.full(3, rng.uniform(*cfg.cube_half))
        self.object_shape, self.object_half = shape, half
        mass = rng.uniform(*cfg.mass_kg)
        m.geom_rgba[:], m.geom_matid[:] = self._rgba_all, self._matid_all  # the hand's own look, then the named
        for g in self._distal_geoms[self.finger]:  # finger lit (a material would hide the colour: none)
            m.geom_rgba[g], m.geom_matid[g] = HIGHLIGHT, -1
        for k, s in enumerate(SHAPES):
            body, geom, qadr = self._obj[s]
            active = s == shape
            # parked objects float out of the way: no contacts, no gravity, invisible
            m.geom_contype[geom] = m.geom_conaffinity[geom] = int(active)
            m.geom_rgba[geom] = self._rgba[s] * [1, 1, 1, int(active)]
            m.body_gravcomp[body] = 0.0 if active else 1.0
            d.qpos[qadr : qadr + 7] = [1.5 + 0.2 * k, 1.5, 0.5, 1, 0, 0, 0]
        body, geom, qadr = self._obj[shape]
        m.geom_size[geom] = {"marble": [half[0], 0, 0], "disc": [half[0], half[2], 0], "cube": half}[shape]
        m.geom_rbound[geom] = half[0] if shape == "marble" else np.linalg.norm(half)
        m.geom_aabb[geom] = [0, 0, 0, *half]
        m.geom_friction[geom] = [rng.uniform(*cfg.friction), 0.01, 0.001]
        m.body_mass[body] = mass
        if shape == "marble":
            inertia = np.full(3, 0.4 * mass * half[0] ** 2)
        elif shape == "disc":
            r, h = half[0], 2 * half[2]
            inertia = mass * np.array([(3 * r * r + h * h) / 12, (3 * r * r + h * h) / 12, r * r / 2])
        else:
            inertia = np.full(3, mass * (2 * half[0]) ** 2 / 6)
        m.body_inertia[body] = inertia

        xy = rng.uniform(-cfg.placement_m, cfg.placement_m, 2)
        yaw = np.radians(rng.uniform(-cfg.yaw_deg, cfg.yaw_deg)) if shape == "cube" else 0.0
        self.object_start = np.array([xy[0], xy[1], half[2]])
        self._top = 0.0  # the object's highest rise this episode
        d.qpos[qadr : qadr + 7] = [*self.object_start, np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]
        self._object = (body, geom, qadr)

        # the base script: the robot's pinch point at the object's centre, palm down
        point = self.robot_pinch(self.pinch_gap_mm())[1]
        err = rng.uniform(-cfg.misalignment_m, cfg.misalignment_m, 2)
        height = max(self.object_start[2], cfg.min_pinch_height_m)
        self._grasp_pos = np.array([xy[0] + err[0], xy[1] + err[1], height]) - np.array(point)
        t = 0.0
        self.schedule = {}
        phases = (("hover", cfg.hover_s), ("descend", cfg.descend_s), ("close", cfg.close_s), ("lift", cfg.lift_s),
                  ("hold", 0.0))  # fmt: skip
        for phase, dur in phases:
            self.schedule[phase] = t
            t += dur
        self.schedule["end"] = cfg.episode_s

    def robot_pinch(self, gap_mm: int, finger: str | None = None) -> tuple:
        """``robot_pinch`` for this robot and the named finger (or ``finger``), its pads clear of the table."""
        return robot_pinch(self.robot.config.name, finger or self.finger, gap_mm, reach_mm=self.pad_reach_mm)

    def pinch_gap_mm(self) -> int:
        """The object's width between the fingertips, mm (the cube's and disc's across, the marble's diameter)."""
        return int(round(2000 * self.object_half[0]))

    def _base_target(self, t: float):
        s = self.schedule
        pos = self._grasp_pos.copy()
        pos[2] += self.config.hover_m * (1.0 - min_jerk((t - s["descend"]) / self.config.descend_s))
        pos[2] += self.config.lift_m * min_jerk((t - s["lift"]) / self.config.lift_s)
        return pos, quat.IDENTITY.copy()

    @property
    def object_geom(self) -> int:
        """The geom of the episode's object (what the hand must hold)."""
        return int(self._object[1])

    def object_pose(self) -> np.ndarray:
        qadr = self._object[2]
        return self.data.qpos[qadr : qadr + 7].copy()

    def _environment_state(self) -> np.ndarray:
        shape = np.array([s == self.object_shape for s in SHAPES], float)
        finger = np.array([f == self.finger for f in FINGERS], float)
        return np.concatenate((self.object_pose(), self.object_half, shape, finger))

    def touching(self) -> set[int]:
        """The hand bodies that touch the object now."""
        return self.hand_bodies_touching(self._object[1])

    def pinched(self) -> bool:
        """Thumb and named finger distal segments on the object, no other hand body, and lifted."""
        lifted = self.object_pose()[2] - self.object_start[2] >= 0.5 * self.config.lift_m
        want = {self._distal["thumb"], self._distal[self.finger]}
        return bool(lifted and self.touching() == want)

    def failure(self) -> str | None:
        if self.object_pose()[2] - self.object_start[2] < 0.5 * self.config.lift_m:
            return f"dropped after a {100 * self._top:.0f} cm lift" if self._top > 0.01 else "not lifted"
        names = {b: self.model.body(b).name for b in self.touching()}
        want = {self._distal["thumb"]: "thumb", self._distal[self.finger]: self.finger}
        missing, extra = [n for b, n in want.items() if b not in names], [n for b, n in names.items() if b not in want]
        if missing:
            return f"lifted without the {' and '.join(missing)} pad"
        return f"lifted with {', '.join(extra)} too" if extra else None

    def _evaluate(self):
        self._top = max(self._top, float(self.object_pose()[2] - self.object_start[2]))  # (why a take failed)
        ok = self.pinched()
        end = self.t >= self.config.episode_s - 1e-9
        return ok and end, end, float(ok)

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "object": self.object_shape, "finger": self.finger}

    def instruction(self) -> str:
        return f"pick up the {self.object_shape} between your thumb and {self.finger} finger"

    def instructions(self) -> tuple[str, ...]:
        return tuple(
            f"pick up the {s} between your thumb and {f} finger" for s in self.config.shapes for f in self.fingers
        )
