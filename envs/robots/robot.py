"""A robot hand: its MJCF, where the glove's palm frame sits on it, its fingertips, and its retarget config.

Everything robot-specific lives in ``configs/robots/<name>.yaml`` next to an MJCF under ``envs/assets/``;
this class only reads them. The glove palm frame (hand model convention: origin at the wrist, x toward the
fingers, z dorsal, y toward the thumb) is the frame that the environment's base follows and that retargeting
works in, so every robot is driven the same way whatever its own body frames are.
"""

from __future__ import annotations

import importlib.util
import re
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import yaml

from recorder import quat

ASSETS = Path(__file__).resolve().parents[1] / "assets"
CONFIGS = Path(__file__).resolve().parents[2] / "configs" / "robots"
FINGER_NAMES = ("thumb", "index", "middle", "ring", "pinky")
_PLACEHOLDER = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")


@dataclass(frozen=True)
class RobotConfig:
    """The robot section of ``configs/robots/<name>.yaml`` (``retarget`` is validated by recorder.retarget).

    mjcf: path under envs/assets; ``${package}`` in it (and in its includes) is replaced by the directory of
    that installed Python package. root_body: the body that gets mounted on the environment's base.
    palm_body, palm_pos, palm_xyaxes: the glove palm frame in palm_body coordinates (origin, then its x and y
    axes), at the model's reference pose. fingertips: site per finger, thumb first. grasp_point: where a held
    object sits, glove palm frame (m)."""

    name: str
    mjcf: str
    root_body: str
    palm_body: str
    fingertips: dict
    palm_pos: tuple = (0.0, 0.0, 0.0)
    palm_xyaxes: tuple = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    grasp_point: tuple = (0.05, 0.0, -0.03)
    retarget: dict = field(default_factory=dict)
    source: str = ""  # the yaml it came from

    @classmethod
    def from_yaml(cls, path: Path) -> RobotConfig:
        raw = yaml.safe_load(Path(path).read_text()) or {}
        if not isinstance(raw, dict):
            raise ValueError(f"{path}: expected a mapping at the top level")
        known = {f for f in cls.__dataclass_fields__ if f != "source"}
        unknown = sorted(set(raw) - known)
        if unknown:
            raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)}; valid: {', '.join(sorted(known))}")
        missing = [k for k in ("name", "mjcf", "root_body", "palm_body", "fingertips") if k not in raw]
        if missing:
            raise ValueError(f"{path}: missing key(s) {', '.join(missing)}")
        tips = raw["fingertips"]
        if not isinstance(tips, dict) or tuple(tips) != FINGER_NAMES:
            raise ValueError(f"{path}: fingertips must map {', '.join(FINGER_NAMES)} (in that order) to sites")
        for key, n in (("palm_pos", 3), ("palm_xyaxes", 6), ("grasp_point", 3)):
            if key in raw and (not isinstance(raw[key], (list, tuple)) or len(raw[key]) != n):
                raise ValueError(f"{path}: {key} must be a list of {n} numbers")
            if key in raw:
                raw[key] = tuple(float(v) for v in raw[key])
        return cls(**raw, source=str(path))


def _expand(text: str) -> str:
    def package_dir(m):
        spec = importlib.util.find_spec(m.group(1))
        if spec is None or not spec.submodule_search_locations:
            raise ValueError(
                f"the robot's MJCF needs the Python package {m.group(1)!r}: pip install {m.group(1).replace('_', '-')}"
            )
        return str(Path(list(spec.submodule_search_locations)[0]))

    return _PLACEHOLDER.sub(package_dir, text)


def _pose_mul(a, b):
    """Compose rigid transforms (pos, quat): a ∘ b."""
    return a[0] + quat.rotate(a[1], b[0]), quat.mul(a[1], b[1])


def _pose_inv(a):
    qi = quat.conj(a[1])
    return -quat.rotate(qi, a[0]), qi


def _xyaxes_quat(xy) -> np.ndarray:
    x = np.asarray(xy[:3], float)
    x /= np.linalg.norm(x)
    y = np.asarray(xy[3:], float)
    y -= x * (x @ y)
    y /= np.linalg.norm(y)
    mat = np.stack((x, y, np.cross(x, y)), axis=1)  # columns: the frame's axes in the body
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.reshape(-1))
    return q


class Robot:
    """A loaded robot. ``spec()`` gives a fresh MjSpec of the hand placed so that the glove palm frame is the
    world frame (``root_body`` is moved; pass ``floating=True`` to give it a free joint); ``model`` is that
    hand alone, fixed (for kinematics and IK); ``root_in_palm`` is the root body's pose in the palm frame."""

    def __init__(self, config: RobotConfig):
        self.config = config
        self.name = config.name
        self.mjcf_path = ASSETS / config.mjcf
        if not self.mjcf_path.is_file():
            raise ValueError(f"{config.source}: mjcf {config.mjcf!r} not found under {ASSETS}")
        self._xml = _expand(self.mjcf_path.read_text())
        as_written = mujoco.MjSpec.from_string(self._xml).compile()
        data = mujoco.MjData(as_written)
        mujoco.mj_kinematics(as_written, data)
        for kind, name in [
            ("body", config.root_body),
            ("body", config.palm_body),
            *(("site", s) for s in config.fingertips.values()),
        ]:
            if mujoco.mj_name2id(as_written, getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}"), name) < 0:
                raise ValueError(f"{config.source}: no {kind} named {name!r} in {config.mjcf}")
        root, palm = as_written.body(config.root_body), as_written.body(config.palm_body)
        if as_written.body_parentid[root.id] != 0:
            raise ValueError(f"{config.source}: root_body {config.root_body!r} must be a child of the worldbody")
        if as_written.body_rootid[palm.id] != root.id:
            raise ValueError(f"{config.source}: palm_body {config.palm_body!r} is not inside {config.root_body!r}")
        if as_written.nu == 0:
            raise ValueError(f"{config.source}: {config.mjcf} has no actuators")
        world_root = (data.xpos[root.id].copy(), data.xquat[root.id].copy())
        world_palm = (data.xpos[palm.id].copy(), data.xquat[palm.id].copy())
        palm_glove = (np.asarray(config.palm_pos, float), _xyaxes_quat(config.palm_xyaxes))
        world_glove = _pose_mul(world_palm, palm_glove)
        self.root_in_palm = _pose_mul(_pose_inv(world_glove), world_root)  # (pos, quat) in the glove palm frame
        self.model = self.spec().compile()
        self.actuator_names = tuple(self.model.actuator(i).name for i in range(self.model.nu))
        self.ctrl_range = self.model.actuator_ctrlrange.copy()
        self.tip_site_ids = np.array([self.model.site(s).id for s in config.fingertips.values()])

    def spec(self, floating: bool = False) -> mujoco.MjSpec:
        """A fresh spec of the hand with the glove palm frame at the world origin. ``floating``: the root
        body gets a free joint named ``base`` and every robot body gravity compensation (the arm that would
        carry the hand holds its weight), for a scene that moves the hand with a mocap weld."""
        spec = mujoco.MjSpec.from_string(self._xml)
        root = spec.body(self.config.root_body)
        root.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        root.pos, root.quat = self.root_in_palm
        if floating:
            root.add_freejoint(name="base")
            for b in spec.bodies:
                if b.name != "world":
                    b.gravcomp = 1.0
        return spec

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {self.model.nu} actuators, {self.model.njnt} joints)"
