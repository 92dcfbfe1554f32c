"""HandKeys: finger individuation. A row of sprung keys lies under the fingertips; each episode lights a sequence
of three to five of them, one at a time, and each must be pressed by its own finger.

The hand's base is fixed above the keys, palm down, its fingers curved as on a keyboard (``rest_angles``). There is
one key under each fingertip of the robot that can push its key down (``key_layout``): the four fingers on
glovehand and Shadow, three on LEAP. No robot's thumb gets one: palm down, a joint-mapped thumb moves across
under the palm, and none lowers its tip far enough (11-17 mm, 26 needed) while staying over a key.
A key is a plank under the finger, hinged at its end toward the palm and held up by a spring, with ``travel_m`` of
travel under the fingertip; it counts as pressed when it is down by ``threshold`` of that travel. The lit key is
yellow in the scene (cameras see it) and flagged in ``environment_state``; when it is pressed by its own finger
the next one lights. Sequences never light the same key twice in a row.

Success: every key of the sequence pressed, in order, each by its own finger (at the moment it crosses its
threshold, that finger's distal, middle or proximal segment is the hand surface nearest to it, within 4 mm: a
struck key can leave the fingertip for a moment), and no other key pressed past its threshold. A wrong key, or the
lit key pressed by another finger, is a failure. Either ends the episode (unless ``terminate_on_success`` is off,
as in a live view). Reward: 1 for each correct press.
environment_state (``keys.*``), one slot per finger thumb..pinky (a slot the robot lacks stays 0): which key is
lit (5), how far each key is down as a fraction of its travel (5), and the presses still to make (1, count / 5).

Physics step: 2 ms, as the other tasks.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Annotated

import mujoco
import numpy as np

from envs.tasks import postures
from envs.tasks.base import HandEnv, TaskConfig
from envs.tasks.registry import register_task
from recorder import quat
from recorder.config import NonNegative, Positive
from recorder.hand.kinematics import JOINTS
from recorder.protocol.layout import FINGERS

LIT = np.array([1.0, 0.85, 0.1, 1.0])  # the lit key: yellow
UNLIT = np.array([0.92, 0.92, 0.88, 1.0])
# The wearer's hand over the keys: fingers curved, the thumb tucked under the palm's edge.
REST = {"thumb_cmc_flex": 15, "thumb_cmc_abd": 35, "thumb_mcp": 15, "thumb_ip": 15,
        **{f"{f}_{j}": v for f in FINGERS[1:] for j, v in (("mcp_flex", 20), ("pip", 30))}}  # fmt: skip
PRESS_JOINTS = {"thumb": ("thumb_cmc_flex", "thumb_cmc_abd", "thumb_mcp", "thumb_ip"),
                **{f: (f"{f}_mcp_flex", f"{f}_pip") for f in FINGERS[1:]}}  # fmt: skip
CLEARANCE_M = 0.006  # the fingertip pads above the keys at rest
KEY_LENGTH_M = (0.018, 0.030)  # a key reaches this far from under the fingertip: toward the palm, to its hinge
KEY_THICKNESS_M = 0.008


def rest_angles() -> np.ndarray:
    return postures.posture(np.zeros(len(JOINTS)), REST, REST.values())


@lru_cache(maxsize=64)
def press_posture(robot: str, finger: str, depth_m: float) -> tuple[tuple, float]:
    """(the values of ``PRESS_JOINTS[finger]`` (deg) that lower the robot's ``finger`` tip ``depth_m`` below its
    rest position and keep it over the same spot, how far below it got, m)."""
    r = postures.retargeter(robot)
    j = r.fingers.index(finger)
    rest = rest_angles()
    tip = postures.robot_tips(robot, rest)[j]
    joints = PRESS_JOINTS[finger]
    start = [REST[n] for n in joints]

    along = 0.02 if finger != "thumb" else 0.5  # a finger's press curls it back along its long key, the thumb's not

    def cost(t):  # sideways it must stay on its key
        return (t[j, 2] - (tip[2] - depth_m)) ** 2 + (t[j, 1] - tip[1]) ** 2 + along * (t[j, 0] - tip[0]) ** 2

    p = postures.search(robot, rest, joints, start, cost)
    got = postures.robot_tips(robot, postures.posture(rest, joints, p))[j]
    return tuple(p), float(tip[2] - got[2])


def press_angles(robot: str, finger: str, depth_m: float) -> np.ndarray:
    """The wearer's angles (20,) rad that press ``finger``'s key ``depth_m`` below its rest tip."""
    return postures.posture(rest_angles(), PRESS_JOINTS[finger], press_posture(robot, finger, depth_m)[0])


@dataclass(frozen=True)
class Key:
    """One key of a robot's row: where its top meets the fingertip pad at rest (3, m, palm frame), its width (m),
    and how far the finger's tip site drops from rest before its pad touches the key (m)."""

    spot: np.ndarray
    width: float
    contact_drop: float


@lru_cache(maxsize=8)
def key_layout(robot: str, travel_m: float) -> dict[str, Key]:
    """The keys of ``robot``'s row, by finger: one under each rest fingertip that reaches ``travel_m`` past the key
    top (the thumb only where it can push down)."""
    r = postures.retargeter(robot)
    m, d = r.model, r.data
    tips = postures.robot_tips(robot, rest_angles())  # leaves the retargeter's data at the rest posture
    spots = {}
    for j, f in enumerate(r.fingers):
        # the pad: the first hand surface straight below the tip site (mj_ray looks up from under the hand)
        start = np.array([tips[j, 0], tips[j, 1], tips[j, 2] - 0.1])
        hit = mujoco.mj_ray(m, d, start, np.array([0.0, 0.0, 1.0]), None, 1, -1, np.zeros(1, np.int32))
        pad = tips[j, 2] if hit < 0 else start[2] + hit
        contact = tips[j, 2] - pad + CLEARANCE_M
        if press_posture(robot, f, round(contact + 1.6 * travel_m, 4))[1] >= contact + 1.6 * travel_m - 0.002:
            spots[f] = (np.array([tips[j, 0], tips[j, 1], pad - CLEARANCE_M]), contact)
    ys = np.sort([spots[f][0][1] for f in spots if f != "thumb"])
    spacing = float(np.min(np.diff(ys))) if len(ys) > 1 else 0.02
    width = min(0.8 * spacing, 0.018)
    return {f: Key(spot, width, contact) for f, (spot, contact) in spots.items()}


@dataclass
class HandKeysConfig(TaskConfig):
    episode_s: Annotated[float, Positive] = 7.0
    base_rotation: bool = False  # the base is fixed over the keys: a palm that turns would slide the fingers onto
    # the neighbouring keys (3 degrees of heading move a fingertip 5 mm, a third of a key)
    presses: tuple[Annotated[int, Positive], Annotated[int, Positive]] = (3, 5)  # sequence length, uniform
    travel_m: Annotated[float, Positive] = 0.006  # under the fingertip
    threshold: Annotated[float, Positive] = 0.6  # pressed past this fraction of the travel
    stiffness: tuple[float, float] = (0.02, 0.04)  # the key's spring, N m/rad (0.3-0.6 N under the fingertip, pressed)
    first_key_s: Annotated[float, NonNegative] = 0.8  # the first key lights then
    placement_m: Annotated[float, NonNegative] = 0.002  # the key row's offset from the hand, uniform in ± (x, y)
    height_m: Annotated[float, Positive] = 0.06  # the key tops this high above the table


@register_task(
    "keys",
    env_id="gloverec/HandKeys-v0",
    demonstrator="recorder.demonstrator.keys:KeysDemonstrator",
    live={"episode_s": 1e9, "terminate_on_success": False},  # `gloverec view`: one sequence until "next"
)
class HandKeysEnv(HandEnv):
    config_class = HandKeysConfig
    view_distance_m = 0.5  # keys, knobs and marbles are small
    workspace = (0.02, 0.0, 0.08)
    environment_state_names = (
        *(f"keys.lit.{f}" for f in FINGERS),
        *(f"keys.down.{f}" for f in FINGERS),
        "keys.remaining",
    )

    def __init__(self, robot: str = "glovehand", render_mode=None, config=None, **overrides):
        self.layout = None
        super().__init__(robot, render_mode, config, **overrides)
        lo, hi = self.config.presses
        if not 1 <= lo <= hi:
            raise ValueError(f"keys task: presses {self.config.presses} is not a range of at least one press")
        self.sequence: tuple[str, ...] = ()
        self.done = 0
        self.failed = None

    # ------------------------------------------------------------ scene
    def _build_task(self, spec: mujoco.MjSpec) -> None:
        cfg = self.config
        self.layout = key_layout(self.robot.config.name, cfg.travel_m)
        self.key_fingers = tuple(f for f in self.robot.fingers if f in self.layout)
        lowest = min(k.spot[2] for k in self.layout.values())
        self._palm_pos = np.array([0.0, 0.0, cfg.height_m - lowest])  # the fixed base: key tops at height_m
        self._key_under = {}
        for f in self.key_fingers:
            spot, width = self.layout[f].spot, self.layout[f].width
            length = KEY_LENGTH_M[1] if f != "thumb" else KEY_LENGTH_M[0]
            # hinged at the end toward the palm, ``length`` from under the fingertip: a press turns it by travel/length
            arm = length + KEY_LENGTH_M[0]
            hinge = self._palm_pos + spot + [-length, 0.0, -KEY_THICKNESS_M / 2]
            body = spec.worldbody.add_body(name=f"key_{f}", pos=hinge)
            body.add_joint(name=f"key_{f}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
                           range=[0.0, 1.5 * cfg.travel_m / length], limited=True, stiffness=cfg.stiffness[0],
                           springref=-0.2, damping=0.002, armature=1e-5)  # fmt: skip
            # contype 2, conaffinity 1: keys touch the hand, not each other
            body.add_geom(name=f"key_{f}", type=mujoco.mjtGeom.mjGEOM_BOX,
                          size=[arm / 2, width / 2, KEY_THICKNESS_M / 2], pos=[arm / 2, 0, 0], rgba=UNLIT,
                          mass=0.004, friction=[1.0, 0.01, 0.001], solref=[0.004, 1.0],
                          contype=2, conaffinity=1)  # fmt: skip
            self._key_under[f] = length  # from the hinge to under the fingertip
        # the key bed: looks only
        xs = [self._palm_pos[0] + k.spot[0] for k in self.layout.values()]
        ys = [self._palm_pos[1] + k.spot[1] for k in self.layout.values()]
        bed_top = cfg.height_m - KEY_THICKNESS_M - 0.004
        spec.worldbody.add_geom(
            name="key_bed", type=mujoco.mjtGeom.mjGEOM_BOX, contype=0, conaffinity=0, rgba=[0.15, 0.15, 0.17, 1],
            pos=[(min(xs) + max(xs)) / 2 - 0.01, (min(ys) + max(ys)) / 2, bed_top / 2],
            size=[(max(xs) - min(xs)) / 2 + 0.04, (max(ys) - min(ys)) / 2 + 0.02, bed_top / 2],
        )  # fmt: skip

    def _init_indices(self) -> None:
        super()._init_indices()
        m = self.model
        ids = {f: (m.joint(f"key_{f}").id, m.geom(f"key_{f}").id, m.body(f"key_{f}").id) for f in self.key_fingers}
        self._keys = ids
        self._key_pos0 = {f: m.body_pos[b].copy() for f, (_, _, b) in self._keys.items()}
        tips = {f: int(m.site_bodyid[m.site(n).id]) for f, n in zip(self.robot.fingers, self.robot.tip_sites)}
        chains = {f: self._chain(b, set(tips.values())) for f, b in tips.items()}
        self._finger_geoms = {f: [g for g in self._robot_geoms if m.geom_bodyid[g] in c and m.geom_contype[g]]
                              for f, c in chains.items()}  # fmt: skip

    def _chain(self, body: int, tip_bodies: set[int]) -> set[int]:
        """``body`` and its parents up to (not including) the first that carries another finger's tip."""
        m = self.model
        out = set()
        while body > 0:
            below = {t for t in tip_bodies if self._is_below(t, body)}
            if len(below) > 1:
                break
            out.add(body)
            body = int(m.body_parentid[body])
        return out

    def _is_below(self, body: int, ancestor: int) -> bool:
        while body > 0:
            if body == ancestor:
                return True
            body = int(self.model.body_parentid[body])
        return False

    # ------------------------------------------------------------ episode
    def _reset_task(self) -> None:
        m, rng, cfg = self.model, self.np_random, self.config
        offset = rng.uniform(-cfg.placement_m, cfg.placement_m, 2)
        for f, (jnt, _, body) in self._keys.items():
            m.body_pos[body] = self._key_pos0[f] + [offset[0], offset[1], 0.0]
            m.jnt_stiffness[jnt] = rng.uniform(*cfg.stiffness)
        n = int(rng.integers(cfg.presses[0], cfg.presses[1] + 1))
        seq = []
        for _ in range(n):
            choices = [f for f in self.key_fingers if not seq or f != seq[-1]]
            seq.append(choices[int(rng.integers(len(choices)))])
        self.sequence = tuple(seq)
        self.done = 0
        self.failed = None
        self._was_down = {f: False for f in self.key_fingers}
        self._light(self.lit())

    def _light(self, lit: str | None) -> None:
        """Light ``lit``'s key (None: none), the others not."""
        for f, (_, geom, _) in self._keys.items():
            self.model.geom_rgba[geom] = LIT if f == lit else UNLIT

    def show_state(self, environment_state: np.ndarray) -> None:
        on = [f for k, f in enumerate(FINGERS) if environment_state[k] > 0.5]
        self._light(on[0] if on else None)

    def lit(self) -> str | None:
        """The finger whose key is lit now (None before the first lights and after the last press)."""
        if self.t < self.config.first_key_s - 1e-9 or self.done >= len(self.sequence):
            return None
        return self.sequence[self.done]

    def _base_target(self, t: float):
        return self._palm_pos.copy(), quat.IDENTITY.copy()

    def key_down(self, finger: str) -> float:
        """How far ``finger``'s key is down under the fingertip, as a fraction of the travel."""
        jnt = self._keys[finger][0]
        angle = self.data.qpos[self.model.jnt_qposadr[jnt]]
        return float(angle * self._key_under[finger] / self.config.travel_m)

    def pressed_by(self, finger: str, within_m: float = 0.004) -> str | None:
        """The finger nearest to ``finger``'s key, if one is within ``within_m`` of it (a struck key can leave the
        fingertip for a moment, so a contact now is not required)."""
        m, d = self.model, self.data
        key = self._keys[finger][1]
        best, nearest = within_m, None
        for f, geoms in self._finger_geoms.items():
            for g in geoms:
                dist = mujoco.mj_geomDistance(m, d, key, int(g), within_m, None)
                if dist < best:
                    best, nearest = dist, f
        return nearest

    def _environment_state(self) -> np.ndarray:
        lit = self.lit()
        out = np.zeros(len(self.environment_state_names))
        for k, f in enumerate(FINGERS):
            if f in self._keys:
                out[k] = float(f == lit)
                out[len(FINGERS) + k] = self.key_down(f)
        out[-1] = (len(self.sequence) - self.done) / 5.0
        return out

    def _evaluate(self):
        reward = 0.0
        for f in self.key_fingers:
            down = self.key_down(f) >= self.config.threshold
            if down and not self._was_down[f] and self.failed is None:
                if f == self.lit() and self.pressed_by(f) == f:
                    self.done += 1
                    reward += 1.0
                else:
                    self.failed = f"{f} key pressed" + ("" if f != self.lit() else " by another finger")
            self._was_down[f] = down
        self._light(self.lit())
        success = self.failed is None and self.done == len(self.sequence)
        end = self.t >= self.config.episode_s - 1e-9
        over = (success or self.failed is not None) and self.config.terminate_on_success
        return success, over or end, reward

    def _info(self, success: bool) -> dict:
        return {**super()._info(success), "sequence": "-".join(self.sequence), "pressed": self.done,
                "failed": self.failed}  # fmt: skip

    def guidance(self) -> str | None:
        lit = self.lit()
        if lit is None:
            return None
        return f"press with your {lit}: key {self.done + 1} of {len(self.sequence)}"

    def instruction(self) -> str:
        return "press each key as it lights up, with its own finger"

    def instructions(self) -> tuple[str, ...]:
        return (self.instruction(),)
