"""HandTurn: grip a knob with the fingertips and turn it by a drawn angle with the palm, then let go.

Each episode draws a knob (a cylinder 20-35 mm in radius on a vertical hinge with friction; its size and the
hinge's friction randomised, its position a little) and a target angle, ±30-90° (what a forearm's pronation and
supination reach without regrasping). The target is shown on a ring around the knob (a lit tick; the knob's top
carries a pointer). The task scripts the base as HandPinch does: it hovers palm down with the robot's pinch point
(thumb and middle fingertips closed to the knob's diameter, ``envs.tasks.hand_pinch.robot_pinch``) over the
knob's axis, descends until that
point is at the knob's mid-height, and stays. The wearer grips the knob between thumb and fingers and turns it
with the palm: the action's palm rotation turns the hand about the knob's axis (the task's ``pivot``, where the
gripping fingertips meet), up to ``max_base_angle_deg`` (110° here: the other tasks' 75° would clip a 90° turn).

Success: the knob within ``tolerance_deg`` of the target for ``hold_s``, then released (no hand body touching it,
still within tolerance); the episode then terminates. Reward: 1 on every step within tolerance, else 0.
environment_state (``turn.*``): knob position (3), radius and half height (2), knob angle (rad), target angle (rad).

Physics step: 2 ms, as the other tasks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np

from envs.tasks.base import BASE_ROTATION, HandEnv, TaskConfig
from envs.tasks.hand_pinch import robot_pinch
from envs.tasks.registry import register_task
from envs.tasks.segments import Segment, Segmentation, cut, first
from recorder import quat
from recorder.config import NonNegative, Positive
from recorder.hand.motion import min_jerk

Range = tuple[float, float]
GRIP_FINGER = "middle"  # opposes the thumb on the knob
TARGET = np.array([1.0, 0.8, 0.1, 1.0])  # the target tick: yellow
RING_MM = 14  # the ring's width beyond the knob's rim
INSTRUCTION = "turn the knob {way} to the mark"  # left: counter-clockwise from above, a positive target


@dataclass
class HandTurnConfig(TaskConfig):
    episode_s: Annotated[float, Positive] = 7.0
    max_base_angle_deg: Annotated[float, Positive] = 110.0
    radius_m: Range = (0.020, 0.035)
    half_height_m: Range = (0.010, 0.014)
    stem_m: Annotated[float, Positive] = 0.03  # the knob's bottom this high above the table
    friction_nm: Range = (0.010, 0.020)  # the hinge's dry friction, N m (a knob that stays where it is left)
    grip_friction: Range = (1.2, 1.6)  # the knob's rim against the fingertips (a knurled or rubber knob)
    target_deg: Range = (30.0, 90.0)  # the turn's size, either sign
    tolerance_deg: Annotated[float, Positive] = 8.0
    hold_s: Annotated[float, NonNegative] = 0.5
    placement_m: Annotated[float, NonNegative] = 0.02
    misalignment_m: Annotated[float, NonNegative] = 0.002
    hover_m: Annotated[float, NonNegative] = 0.06
    hover_s: Annotated[float, NonNegative] = 0.6
    descend_s: Annotated[float, Positive] = 1.0

    def min_episode_s(self) -> float:
        return self.hover_s + self.descend_s


class TurnSegmentation(Segmentation):
    """Grip (the scripted descent, the fingers closing on the knob), turn (from the knob's first 2° until the
    hand lets go) and release. The base is scripted, so nothing follows a frame: what varies is the knob's size and
    target angle. A source serves a scene turning the same way; the nearest knob in radius is taken (the grip's
    finger posture was shaped for its diameter), then the nearest target. Its palm rotation from the turn's start
    on is scaled by the new target over the source's, so the person's turn, with its timing, ends on the new mark;
    the fingers are kept."""

    TURNING_DEG = 2.0

    def observe(self, env) -> dict[str, float]:
        return {"touching": float(len(env.touching())), "angle_deg": np.degrees(env.knob_angle())}

    def split(self, trace: dict[str, np.ndarray]) -> list[Segment]:
        turn = first(np.abs(trace["angle_deg"]) > self.TURNING_DEG)
        release = first(trace["touching"] == 0, turn) if turn is not None else None
        return cut(("grip", "turn", "release"), [turn, release], len(trace["angle_deg"]), (None, None, None))

    def scene(self, env) -> dict:
        return {"radius_m": float(env.radius), "target_deg": float(np.degrees(env.target))}

    def distance(self, a: dict, b: dict) -> float:
        if np.sign(a["target_deg"]) != np.sign(b["target_deg"]):
            return float("inf")
        return abs(a["radius_m"] - b["radius_m"]) + 1e-4 * abs(a["target_deg"] - b["target_deg"])

    def adapt(self, actions: np.ndarray, segments: list[Segment], source: dict, scene: dict, env) -> np.ndarray:
        turn = next((s for s in segments if s.name == "turn"), None)
        if turn is None:
            return actions
        first_rot = env.action_names.index(BASE_ROTATION[0])
        rot = slice(first_rot, first_rot + 3)
        k = scene["target_deg"] / source["target_deg"]
        out = actions.copy()
        out[turn.start :, rot] = actions[turn.start, rot] + k * (actions[turn.start :, rot] - actions[turn.start, rot])
        return out


@register_task(
    "turn",
    env_id="gloverec/HandTurn-v0",
    demonstrator="recorder.demonstrator.turn:TurnDemonstrator",
    live={"episode_s": 1e9, "terminate_on_success": False},  # `gloverec view`: one knob until "next"
    segmentation=TurnSegmentation(),
)
class HandTurnEnv(HandEnv):
    config_class = HandTurnConfig
    view_distance_m = 0.5  # keys, knobs and marbles are small
    workspace = (0.0, 0.0, 0.06)
    environment_state_names = (
        "turn.knob.x",
        "turn.knob.y",
        "turn.knob.z",
        "turn.knob.radius",
        "turn.knob.half_height",
        "turn.knob.angle",
        "turn.target.angle",
    )

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        super().__init__(robot, render_mode, config, **overrides)
        self.radius, self.half_height, self.target = 0.025, 0.012, 0.0
        self.schedule = {}
        self._held_s = 0.0

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        wb = spec.worldbody
        knob = wb.add_body(name="turn_knob", pos=[0.0, 0.0, 0.0])
        knob.add_joint(name="turn_knob", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1], damping=0.002,
                       armature=1e-4, frictionloss=0.004)  # fmt: skip
        knob.add_geom(name="turn_knob", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.025, 0.012, 0],
                      pos=[0, 0, 0.04], rgba=[0.25, 0.27, 0.3, 1], mass=0.05, condim=4,
                      friction=[1.4, 0.01, 0.001], solref=[0.004, 1.0], priority=1)  # fmt: skip
        # looks only: the pointer on the knob's top, its stem, the ring and the target tick
        knob.add_geom(name="turn_pointer", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.012, 0.002, 0.0006],
                      pos=[0.012, 0, 0.053], rgba=[0.95, 0.95, 0.95, 1], contype=0, conaffinity=0, mass=0)  # fmt: skip
        knob.add_geom(name="turn_stem", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.008, 0.015, 0],
                      pos=[0, 0, 0.015], rgba=[0.2, 0.2, 0.22, 1], contype=0, conaffinity=0, mass=0)  # fmt: skip
        ring = wb.add_body(name="turn_ring", pos=[0.0, 0.0, 0.0])
        ring.add_geom(name="turn_ring", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.04, 0.0008, 0],
                      rgba=[0.85, 0.85, 0.8, 1], contype=0, conaffinity=0)  # fmt: skip
        ring.add_geom(name="turn_target", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.006, 0.0025, 0.001],
                      rgba=TARGET, contype=0, conaffinity=0)  # fmt: skip
        ring.add_geom(name="turn_start", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.004, 0.0012, 0.0009],
                      rgba=[0.4, 0.4, 0.4, 1], contype=0, conaffinity=0)  # fmt: skip

    def _init_indices(self) -> None:
        super()._init_indices()
        m = self.model
        self._knob_body, self._knob_geom = m.body("turn_knob").id, m.geom("turn_knob").id
        j = m.joint("turn_knob").id
        self._knob_joint, self._knob_qpos = j, m.jnt_qposadr[j]
        self._ring_body = m.body("turn_ring").id
        self._g = {n: m.geom(f"turn_{n}").id for n in ("pointer", "stem", "ring", "target", "start")}

    # ------------------------------------------------------------ episode
    def _reset_task(self) -> None:
        m, d, rng, cfg = self.model, self.data, self.np_random, self.config
        r, h = rng.uniform(*cfg.radius_m), rng.uniform(*cfg.half_height_m)
        self.radius, self.half_height = r, h
        sign = 1.0 if rng.random() < 0.5 else -1.0
        self.target = sign * np.radians(rng.uniform(*cfg.target_deg))
        xy = rng.uniform(-cfg.placement_m, cfg.placement_m, 2)
        centre_z = cfg.stem_m + h
        self.knob_centre = np.array([xy[0], xy[1], centre_z])
        m.body_pos[self._knob_body] = [xy[0], xy[1], 0.0]
        g = self._g
        m.geom_size[self._knob_geom] = [r, h, 0]
        m.geom_pos[self._knob_geom] = [0, 0, centre_z]
        m.geom_rbound[self._knob_geom] = np.hypot(r, h)
        m.geom_aabb[self._knob_geom] = [0, 0, 0, r, r, h]
        m.geom_size[g["pointer"]] = [0.45 * r, 0.002, 0.0006]
        m.geom_pos[g["pointer"]] = [0.5 * r, 0, centre_z + h + 0.0006]
        m.geom_size[g["stem"]] = [0.008, cfg.stem_m / 2, 0]
        m.geom_pos[g["stem"]] = [0, 0, cfg.stem_m / 2]
        ring_r = r + RING_MM / 1000
        m.body_pos[self._ring_body] = [xy[0], xy[1], 0.0]
        m.geom_size[g["ring"]] = [ring_r, 0.0008, 0]
        m.geom_pos[g["ring"]] = [0, 0, 0.0008]
        for name, angle in (("target", self.target), ("start", 0.0)):
            m.geom_pos[g[name]] = [(ring_r - 0.006) * np.cos(angle), (ring_r - 0.006) * np.sin(angle), 0.0025]
            m.geom_quat[g[name]] = [np.cos(angle / 2), 0, 0, np.sin(angle / 2)]
        m.dof_frictionloss[m.jnt_dofadr[self._knob_joint]] = rng.uniform(*cfg.friction_nm)
        m.geom_friction[self._knob_geom] = [rng.uniform(*cfg.grip_friction), 0.01, 0.001]
        d.qpos[self._knob_qpos] = 0.0
        self._held_s = 0.0

        # the base script: the pinch point (where thumb and middle fingertips meet) on the knob's axis
        d_mm = self.grip_gap_mm()
        point = robot_pinch(self.robot.config.name, GRIP_FINGER, d_mm, d_mm)[1]
        self.pivot = np.array(point)
        err = rng.uniform(-cfg.misalignment_m, cfg.misalignment_m, 2)
        self._grip_pos = np.array([xy[0] + err[0], xy[1] + err[1], centre_z]) - self.pivot
        self.schedule = {"hover": 0.0, "descend": cfg.hover_s, "grip": cfg.hover_s + cfg.descend_s,
                         "end": cfg.episode_s}  # fmt: skip

    def grip_gap_mm(self) -> int:
        """The knob's diameter, mm: the gap between the gripping fingertips."""
        return int(round(2000 * self.radius))

    def _base_target(self, t: float):
        pos = self._grip_pos.copy()
        pos[2] += self.config.hover_m * (1.0 - min_jerk((t - self.schedule["descend"]) / self.config.descend_s))
        return pos, quat.IDENTITY.copy()

    def knob_angle(self) -> float:
        return float(self.data.qpos[self._knob_qpos])

    def error_deg(self) -> float:
        return float(np.degrees(self.knob_angle() - self.target))

    def touching(self) -> set[int]:
        return self.hand_bodies_touching(self._knob_geom)

    def _environment_state(self) -> np.ndarray:
        return np.array([*self.knob_centre, self.radius, self.half_height, self.knob_angle(), self.target])

    def _evaluate(self):
        within = abs(self.error_deg()) <= self.config.tolerance_deg
        self._held_s = self._held_s + 1.0 / self.config.control_hz if within else 0.0
        success = within and self._held_s >= self.config.hold_s - 1e-9 and not self.touching()
        end = self.t >= self.config.episode_s - 1e-9
        return success, (success and self.config.terminate_on_success) or end, float(within)

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "target_deg": round(float(np.degrees(self.target)), 1),
                "angle_deg": round(float(np.degrees(self.knob_angle())), 1)}  # fmt: skip

    def failure(self) -> str | None:
        off = self.error_deg()
        if abs(off) > self.config.tolerance_deg:
            moved = np.degrees(self.knob_angle())
            return (
                "never turned"
                if abs(moved) < 2
                else f"ended {abs(off):.0f}° {'past' if off * self.target > 0 else 'short of'} the mark"
            )
        if self.touching():
            return "at the mark, still held"
        return "at the mark, not held there long enough" if self._held_s < self.config.hold_s else None

    def guidance(self) -> str | None:
        if self.t < self.schedule.get("grip", 0.0):
            return None
        left = -self.error_deg()
        if abs(left) > self.config.tolerance_deg:
            way = "left" if left > 0 else "right"
            if (left > 0) != (self.target > 0):  # against the instruction's way: say why, not a contradiction
                return f"past the mark: turn {abs(left):.0f}° back {way}"
            return f"turn {abs(left):.0f}° {way}"
        return "let go" if self._held_s >= self.config.hold_s else "hold it there"

    def instruction(self) -> str:
        return INSTRUCTION.format(way="left" if self.target > 0 else "right")

    def instructions(self) -> tuple[str, ...]:
        return tuple(INSTRUCTION.format(way=w) for w in ("left", "right"))
