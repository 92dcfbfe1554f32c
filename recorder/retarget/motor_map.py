"""A motor map: the glove's joint angles -> the named motor targets of a real hand that has no simulation model
(LeRobot's HopeJR hand: tendon motors driven 0..100). ``configs/retarget/<name>.yaml``:

    robot: hope_jr_hand                  # the LeRobot robot type whose action keys these are
    joints:                              # a glove joint (degrees) -> a normalised value: its range ``deg``
      index_mcp_flex: {deg: [0, 90]}     # onto ``to`` (default [0, 100]), clipped
      index_mcp_abd: {deg: [-25, 25], to: [-100, 100]}
    motors:                              # a motor key -> {normalised joint: weight}; the sum is clipped to 0..100
      index_radial_flexor.pos: {index_mcp_flex: 0.7, index_mcp_abd: 0.3}

Checked on load like every config (recorder/config.py): unknown glove joints, motors whose terms name a joint
that has no range, unknown keys: one line naming the file and the key.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from recorder import config
from recorder.config import STRICT, ConfigError
from recorder.hand.kinematics import JOINTS
from recorder.hand.pose import HandPose
from recorder.paths import config_file

OUTPUT = (0.0, 100.0)  # every motor target is clipped to this


@dataclass(frozen=True)
class JointRange:
    __pydantic_config__ = STRICT

    deg: tuple[float, float]
    to: tuple[float, float] = (0.0, 100.0)


@dataclass(frozen=True)
class MotorMapConfig:
    __pydantic_config__ = STRICT

    robot: str
    joints: dict[str, JointRange]
    motors: dict[str, dict[str, float]]


class MotorMap:
    """``targets = motor_map(pose)``: {motor key: value in 0..100} for a HandPose (or joint angles, rad)."""

    def __init__(self, cfg: MotorMapConfig, source: str = "motor map"):
        bad = [j for j in cfg.joints if j not in JOINTS]
        if bad:
            raise ConfigError(f"{source}: joints.{bad[0]}: unknown glove joint; valid: {', '.join(JOINTS)}")
        for j, r in cfg.joints.items():
            if not r.deg[0] < r.deg[1]:
                raise ConfigError(f"{source}: joints.{j}.deg: low {r.deg[0]:g} must be below high {r.deg[1]:g}")
        for motor, terms in cfg.motors.items():
            missing = [j for j in terms if j not in cfg.joints]
            if missing:
                raise ConfigError(f"{source}: motors.{motor}.{missing[0]}: no range for it under joints")
        self.robot = cfg.robot
        self.names = tuple(cfg.motors)
        self._index = np.array([JOINTS.index(j) for j in cfg.joints])
        lo, hi = np.radians([r.deg for r in cfg.joints.values()]).T
        to_lo, to_hi = np.array([r.to for r in cfg.joints.values()], float).T
        self._scale = (to_hi - to_lo) / (hi - lo)
        self._offset = to_lo - self._scale * lo
        self._clip = (np.minimum(to_lo, to_hi), np.maximum(to_lo, to_hi))
        order = list(cfg.joints)
        self._weights = np.zeros((len(self.names), len(order)))
        for i, terms in enumerate(cfg.motors.values()):
            for j, w in terms.items():
                self._weights[i, order.index(j)] = w

    def normalised(self, angles) -> np.ndarray:
        """The mapped joints' normalised values (each joint's range onto its ``to``, clipped)."""
        a = np.asarray(angles, float)[self._index]
        return np.clip(self._offset + self._scale * a, *self._clip)

    def __call__(self, pose: HandPose | np.ndarray) -> dict[str, float]:
        angles = pose.angles if isinstance(pose, HandPose) else pose
        values = np.clip(self._weights @ self.normalised(angles), *OUTPUT)
        return dict(zip(self.names, values.tolist()))


def motor_map_names() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in (config_file("retarget", "x").parent).glob("*.yaml")))


def load_motor_map(name: str | Path) -> MotorMap:
    """The motor map ``name`` (configs/retarget/<name>.yaml) or a yaml path; one-line ConfigError otherwise."""
    path = Path(name) if str(name).endswith((".yaml", ".yml")) else config_file("retarget", str(name))
    if not path.is_file():
        raise ConfigError(f"unknown motor map {str(name)!r}; valid: {', '.join(motor_map_names())}")
    return MotorMap(config.load(MotorMapConfig, path), str(path))
