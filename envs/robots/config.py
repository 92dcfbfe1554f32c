"""The typed contents of ``configs/robots/<name>.yaml``: where the glove's palm frame sits on the robot, its
fingertips, and the ``retarget`` section (joint map, fingertip targets, couplings, IK settings). Loaded by the one
config mechanism (recorder/config.py): an unknown key, a wrong type or a missing entry is one line naming the
file and the key. What can only be checked against the robot's MuJoCo model (names of bodies, actuators, joints,
limits within the control ranges) is checked by Robot and JointMap, with the same kind of line."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

from pydantic import AfterValidator

from recorder import config
from recorder.config import STRICT, Positive

FINGER_NAMES = ("thumb", "index", "middle", "ring", "pinky")
Vec3 = tuple[float, float, float]


def _thumb_first(tips: dict) -> dict:
    names = tuple(tips)
    if names[:1] != ("thumb",) or len(names) < 2 or names != tuple(f for f in FINGER_NAMES if f in names):
        raise ValueError(
            f"must map the thumb and the fingers the robot has ({', '.join(FINGER_NAMES)}, in that order) to sites"
        )
    return tips


@dataclass(frozen=True)
class TipSite:
    """A fingertip point the MJCF has no site for: ``pos`` (m) in ``body``'s frame; the robot adds the site."""

    __pydantic_config__ = STRICT

    body: str
    pos: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class JointSource:
    """retarget.joints.<actuator>: target = clip(offset + scale * sum(weight * human angle), limits). ``source``:
    a human joint or {human joint: weight}; None: a constant target (``offset``). ``limits`` [lo, hi] rad default
    to the actuator's control range and must lie inside it."""

    __pydantic_config__ = STRICT

    source: str | dict[str, float] | None = None
    scale: float = 1.0
    offset: float = 0.0
    limits: tuple[float, float] | None = None


@dataclass(frozen=True)
class FingerTips:
    """One finger's own map of its fingertip (replacing the hand's ``scale`` and ``offset``)."""

    __pydantic_config__ = STRICT

    scale: Annotated[float, Positive] = 1.0
    offset: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class TipsConfig:
    """Human fingertip p (palm frame, m, of the 190 mm reference hand: a wearer's are scaled to it first) -> the
    robot's fingertip target scale * p + offset. ``fingers``: a finger's own scale and offset, where the robot's
    finger differs from the hand's in place and reach (a thumb); fitted by `python -m recorder.retarget.fit`."""

    __pydantic_config__ = STRICT

    scale: Annotated[float, Positive] = 1.0
    offset: Vec3 = (0.0, 0.0, 0.0)
    fingers: dict[str, FingerTips] = field(default_factory=dict)

    def of(self, finger: str) -> tuple[float, tuple]:
        """(scale, offset) of ``finger``."""
        own = self.fingers.get(finger)
        return (own.scale, own.offset) if own is not None else (self.scale, self.offset)


@dataclass(frozen=True)
class CouplingConfig:
    """A passive joint that follows an actuated one: q[joint] = ratio * q[leader] (a tendon or a linkage)."""

    __pydantic_config__ = STRICT

    joint: str
    leader: str
    ratio: float


@dataclass(frozen=True)
class IKConfig:
    """Fingertip inverse kinematics (recorder/retarget/ik.py)."""

    __pydantic_config__ = STRICT

    posture_cost: Annotated[float, Positive] = 0.05  # pull toward the joint-mapped pose (human-like solutions)
    tip_cost: Annotated[float, Positive] = 1.0
    iterations: Annotated[int, Positive] = 8  # per frame at most; warm-started from the last frame
    tolerance_m: Annotated[float, Positive] = 0.001  # stop when every fingertip is this close to its target
    damping: Annotated[float, Positive] = 1e-3  # Levenberg-Marquardt damping
    solver: str = "daqp"


@dataclass(frozen=True)
class PinchConfig:
    """The pinch-preserving optimisation (recorder/retarget/pinch.py): weights of its least-squares terms (per
    metre of fingertip residual, per radian of joint motion), when a thumb-finger pair counts as pinching
    (distances between the human's fingertips, reference hand, m), and its iteration budget."""

    __pydantic_config__ = STRICT

    tip_weight: Annotated[float, Positive] = 1.0  # fingertip positions
    vector_weight: Annotated[float, Positive] = 0.3  # thumb-to-finger vectors (DexPilot): the shape of a grasp
    pinch_weight: Annotated[float, Positive] = 30.0  # closing the pads of a pinching pair
    contact_weight: Annotated[float, Positive] = 1000.0  # finger-finger penetration (the model's own contact pairs)
    smooth_weight: Annotated[float, Positive] = 0.002  # change from the last frame (temporal smoothness)
    posture_weight: Annotated[float, Positive] = 0.002  # pull toward the joint-mapped pose (unique, human-like)
    touch_m: Annotated[float, Positive] = 0.012  # human fingertips this close: touching, the robot's pads close
    release_m: Annotated[float, Positive] = 0.04  # farther: no pinch term
    margin_m: Annotated[float, Positive] = 0.003  # contact pairs closer than this are in the problem
    iterations: Annotated[int, Positive] = 8  # Gauss-Newton steps per frame at most (warm-started)
    tolerance: Annotated[float, Positive] = 1e-4  # stop when no joint moves more than this (rad)
    improvement: Annotated[float, Positive] = 0.01  # or when a step lowered the cost by less than this fraction


@dataclass(frozen=True)
class RetargetSection:
    """The ``retarget`` section: one ``joints`` entry per actuator, none left out (checked against the model);
    ``couplings`` add to the model's own tendon couplings, which are found automatically."""

    __pydantic_config__ = STRICT

    joints: dict[str, JointSource | None]
    tips: TipsConfig = TipsConfig()
    couplings: tuple[CouplingConfig, ...] = ()
    ik: IKConfig = IKConfig()
    pinch: PinchConfig = PinchConfig()


@dataclass(frozen=True)
class RobotConfig:
    """mjcf: path under envs/assets; ``${package}`` in it (and in its includes) is replaced by the directory of
    that installed Python package. root_body: the body mounted on the environment's base. palm_body, palm_pos,
    palm_xyaxes: the glove palm frame in palm_body coordinates (origin, then its x and y axes) at the model's
    reference pose. fingertips: a site (or a TipSite) per finger the robot has, thumb first (a four-fingered hand
    has no pinky). grasp_point: where a held object sits, glove palm frame (m). ``source``: the file it came
    from."""

    __pydantic_config__ = STRICT

    name: str
    mjcf: str
    root_body: str
    palm_body: str
    fingertips: Annotated[dict[str, str | TipSite], AfterValidator(_thumb_first)]
    retarget: RetargetSection
    palm_pos: Vec3 = (0.0, 0.0, 0.0)
    palm_xyaxes: tuple[float, float, float, float, float, float] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    grasp_point: Vec3 = (0.05, 0.0, -0.03)
    source: str = field(default="", compare=False)


def load_robot_config(path: str | Path) -> RobotConfig:
    """A robot's yaml, typed and checked (ConfigError naming the file and key)."""
    return config.load(RobotConfig, path, overrides={"source": str(path)})


def retarget_section(raw: dict, source: str) -> RetargetSection:
    """A ``retarget`` mapping on its own (tools and tests that edit one), checked as in a robot's yaml."""
    return config.build(RetargetSection, raw, source, prefix="retarget")
