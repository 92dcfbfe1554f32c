"""A robot hand: its MJCF, where the glove's palm frame sits on it, its fingertips, and its retarget config.

Everything robot-specific lives in ``configs/robots/<name>.yaml`` next to an MJCF under ``envs/assets/``;
this class only reads them. The glove palm frame (hand model convention: origin at the wrist, x toward the
fingers, z dorsal, y toward the thumb) is the frame that the environment's base follows and that retargeting
works in, so every robot is driven the same way whatever its own body frames are.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import mujoco
import numpy as np

from envs.robots.config import RobotConfig, TipSite
from envs.robots.joint_map import JointMap
from recorder import quat
from recorder.config import ConfigError
from recorder.paths import assets_dir

_PLACEHOLDER = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}")


def _expand(text: str) -> str:
    def package_dir(m):
        spec = importlib.util.find_spec(m.group(1))
        if spec is None or not spec.submodule_search_locations:
            raise ConfigError(
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
        self.mjcf_path = assets_dir() / config.mjcf
        if not self.mjcf_path.is_file():
            raise ConfigError(f"{config.source}: mjcf: {config.mjcf!r} not found under {assets_dir()}")
        self._xml = _expand(self.mjcf_path.read_text())
        as_written = mujoco.MjSpec.from_string(self._xml).compile()
        data = mujoco.MjData(as_written)
        mujoco.mj_kinematics(as_written, data)
        for kind, name in [
            ("body", config.root_body),
            ("body", config.palm_body),
            *(("body", t.body) if isinstance(t, TipSite) else ("site", t) for t in config.fingertips.values()),
        ]:
            if mujoco.mj_name2id(as_written, getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}"), name) < 0:
                raise ConfigError(f"{config.source}: no {kind} named {name!r} in {config.mjcf}")
        root, palm = as_written.body(config.root_body), as_written.body(config.palm_body)
        if as_written.body_parentid[root.id] != 0:
            raise ConfigError(f"{config.source}: root_body {config.root_body!r} must be a child of the worldbody")
        if as_written.body_rootid[palm.id] != root.id:
            raise ConfigError(f"{config.source}: palm_body {config.palm_body!r} is not inside {config.root_body!r}")
        if as_written.nu == 0:
            raise ConfigError(f"{config.source}: {config.mjcf} has no actuators")
        world_root = (data.xpos[root.id].copy(), data.xquat[root.id].copy())
        world_palm = (data.xpos[palm.id].copy(), data.xquat[palm.id].copy())
        palm_glove = (np.asarray(config.palm_pos, float), _xyaxes_quat(config.palm_xyaxes))
        world_glove = _pose_mul(world_palm, palm_glove)
        self.root_in_palm = _pose_mul(_pose_inv(world_glove), world_root)  # (pos, quat) in the glove palm frame
        self.fingers = tuple(config.fingertips)  # thumb first; a four-fingered hand has no pinky
        self.tip_sites = tuple(
            f"gloverec:{f}_tip" if isinstance(t, TipSite) else t for f, t in config.fingertips.items()
        )
        self.model = self.spec().compile()
        self.actuator_names = tuple(self.model.actuator(i).name for i in range(self.model.nu))
        self.ctrl_range = self.model.actuator_ctrlrange.copy()
        self.tip_site_ids = np.array([self.model.site(s).id for s in self.tip_sites])
        self.joint_map = JointMap.compile(config.retarget, self.model, config.source)

    def spec(self, floating: bool = False) -> mujoco.MjSpec:
        """A fresh spec of the hand with the glove palm frame at the world origin. ``floating``: the root
        body gets a free joint named ``base`` and every robot body gravity compensation (the arm that would
        carry the hand holds its weight), for a scene that moves the hand with a mocap weld."""
        spec = mujoco.MjSpec.from_string(self._xml)
        root = spec.body(self.config.root_body)
        root.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        root.pos, root.quat = self.root_in_palm
        for site, tip in zip(self.tip_sites, self.config.fingertips.values()):
            if isinstance(tip, TipSite):  # a fingertip the MJCF has no site for
                spec.body(tip.body).add_site(name=site, pos=list(tip.pos), size=[0.004] * 3, group=3)
        if floating:
            root.add_freejoint(name="base")
            for b in spec.bodies:
                if b.name != "world":
                    b.gravcomp = 1.0
        return spec

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {self.model.nu} actuators, {self.model.njnt} joints)"
