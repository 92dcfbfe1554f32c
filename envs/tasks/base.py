"""HandEnv: what every gloverec task shares. A robot hand (any robot of envs.robots) on a mocap-driven base,
stepped at a fixed control rate, observed the way LeRobot datasets store it.

Scene: a floor (the table top, z = 0), lights, cameras, and the hand: its root body has a free joint welded
(soft, stiff) to a mocap body, the "base target", with gravity compensation on every hand body. The base
target carries the glove palm frame; the task scripts its position and nominal orientation, and the action
rotates it (the glove's palm orientation), about the palm frame's origin or a task's ``pivot``. A weld rather
than a kinematic parent gives the hand real velocities, so friction carries a held object along.

Action (float32): the actuators' position targets (ctrl ranges), then, with ``base_rotation``, the palm
rotation as a rotation vector (rad, palm axes, relative to the task's nominal orientation, norm clipped to
``max_base_angle_deg``), then, with ``base_position`` (a free wrist: the wearer's from a tracker), the palm
frame's position target (m, world, clipped to ``base_bounds``). With a free wrist the task no longer scripts the
base: the episode starts at the script's first pose and the action moves it from there, and the palm rotation
is relative to palm down (the world's axes), the orientation every task starts in. Out-of-range actions are
clipped; ``info["applied_action"]`` is what was applied.

Observation (dict):
- ``observation.state``: hand joint positions, then velocities (``state_velocities``), then the palm
  frame's position (3, m) and orientation (4, wxyz) in the world: names in ``state_names``.
- ``observation.environment_state``: the task's (goal or object), names in ``environment_state_names``. With
  ``state_includes_task`` (LeRobot's layout) it is appended to ``observation.state`` instead.
- ``observation.images.<camera>``: uint8 (H, W, 3) for each of ``cameras`` (offscreen, MUJOCO_GL=egl).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import gymnasium as gym
import mujoco
import numpy as np

from envs.robots import load_robot
from envs.tasks.perturb import perturb
from recorder import config, quat
from recorder.config import STRICT, Positive

UNSTABLE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)

CAMERAS = ("front", "top", "side")


@dataclass
class TaskConfig:
    """What every task shares; each task's dataclass adds its own. Built by ``load`` from these defaults and
    keyword overrides (gym.make kwargs, the recorder's flags), validated by recorder.config."""

    __pydantic_config__ = STRICT

    control_hz: Annotated[float, Positive] = 30.0
    max_physics_dt: Annotated[float, Positive] = 0.002  # the physics step: the control period split into equal
    # steps of at most this
    episode_s: Annotated[float, Positive] = 6.0
    cameras: tuple[Literal["front", "top", "side"], ...] = ()  # empty: state only (fastest)
    image_size: tuple[Annotated[int, Positive], Annotated[int, Positive]] = (128, 128)  # (height, width)
    # the cameras' multisampling (MuJoCo's offsamples): none by default. MuJoCo's 4 took 2.6x the rendering time on
    # a CPU renderer (EGL on llvmpipe) for edges that differ by half a grey level on average at 128 px; the
    # videos people watch at another size keep it
    camera_samples: Literal[0, 2, 4, 8] = 0
    base_rotation: bool = True  # the action carries the palm rotation (3)
    base_position: bool = False  # the action carries the palm position (3): the wrist from a tracker, not the script
    max_base_angle_deg: Annotated[float, Positive] = 75.0
    state_velocities: bool = True
    # LeRobot's layout: the task's state (goal or object) appended to observation.state and no
    # observation.environment_state, as a LeRobot robot reports every float it has (lerobot_robot_gloverec)
    state_includes_task: bool = False
    weld_timeconst: Annotated[float, Positive] = 0.01  # s; how stiffly the hand base follows its target
    terminate_on_success: bool = True  # end the episode once the task is done (a live view, a benchmark: False)
    # scene changes the demonstrations never showed (envs/tasks/perturb.py), for evaluation
    perturb: tuple[Literal["light", "colour", "camera"], ...] = ()

    @classmethod
    def load(cls, name: str, **overrides):
        """The defaults with ``overrides``; an unknown option or a bad value: one-line ConfigError."""
        return config.build(cls, overrides, f"{name} task")

    def min_episode_s(self) -> float:
        """The shortest episode the task can run (its script's length, for tasks that script the base)."""
        return 0.0


BASE_ROTATION = ("base.rx", "base.ry", "base.rz")
BASE_POSITION = ("base.x", "base.y", "base.z")


def action_names(robot, base_rotation: bool = True, base_position: bool = False) -> tuple[str, ...]:
    """The names of a task's action elements for ``robot``: its actuators, then the palm rotation, then the palm
    position (a free wrist)."""
    return (
        tuple(robot.actuator_names)
        + (BASE_ROTATION if base_rotation else ())
        + (BASE_POSITION if base_position else ())
    )


def _look_at(pos, target):
    """xyaxes of a camera at ``pos`` looking at ``target`` with the world z up."""
    f = np.asarray(target, float) - np.asarray(pos, float)
    f /= np.linalg.norm(f)
    x = np.cross(f, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.concatenate((x, np.cross(x, f)))


class HandEnv(gym.Env):
    """Base of the tasks; subclasses define ``config_class``, ``_build_task(spec)``, ``_reset_task()``,
    ``_base_target(t)``, ``_environment_state()`` (+ names), ``_evaluate()`` and ``instruction()``, and register
    with ``@register_task(name, ...)`` (envs/tasks/registry.py), which sets ``task_name``. Optional view hooks:
    ``goal_qpos(qpos, goal)`` (a target the live view draws as a ghost), ``schedule`` ({move: start time}: the
    view's "lift in 1.2 s") and ``guidance()`` (a line for the operator now: "press with your ring", "turn 40°
    left")."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}
    config_class = TaskConfig
    task_name = "base"
    workspace = (0.0, 0.0, 0.25)  # where the cameras look
    pivot = None  # the point (palm frame, m) the action's palm rotation turns the hand about; None: the palm origin
    view_distance_m = 0.75  # how far the live views' camera stands back (a small scene wants it closer)
    reach_m = (0.25, 0.25, 0.25)  # a free wrist's bounds: the workspace ± this (x, y, z), the palm above the table

    def __init__(self, robot: str = "glovehand", render_mode: str | None = None, config=None, **overrides):
        self.config = config if config is not None else self.config_class.load(self.task_name, **overrides)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"unknown render_mode {render_mode!r}; valid: rgb_array")
        if self.config.episode_s <= self.config.min_episode_s():
            raise config.ConfigError(
                f"{self.task_name} task: episode_s {self.config.episode_s:g} s is too short for its script, "
                f"which takes {self.config.min_episode_s():g} s"
            )
        self.render_mode = render_mode
        self.robot = load_robot(robot)
        cfg = self.config
        period = 1.0 / cfg.control_hz
        self.n_substeps = int(np.ceil(period / cfg.max_physics_dt - 1e-9))
        self.metadata = {**self.metadata, "render_fps": cfg.control_hz}

        spec = self.robot.spec(floating=True)
        spec.option.timestep = period / self.n_substeps
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = 10.0
        h, w = cfg.image_size
        spec.visual.global_.offwidth = max(w, 640)
        spec.visual.global_.offheight = max(h, 480)
        spec.stat.extent = 0.5
        self._build_scene(spec)
        self._build_task(spec)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        if cfg.perturb:
            perturb(self.model, cfg.perturb, self.model.body(self.robot.config.root_body).id, self.workspace)
        self._init_indices()

        nu = self.model.nu
        lo, hi = self.model.actuator_ctrlrange.T
        amax = np.radians(cfg.max_base_angle_deg)
        if cfg.base_rotation:
            lo, hi = np.concatenate((lo, [-amax] * 3)), np.concatenate((hi, [amax] * 3))
        ws, reach = np.array(self.workspace, float), np.array(self.reach_m, float)
        self.base_bounds = (np.maximum(ws - reach, [-np.inf, -np.inf, 0.02]), ws + reach)
        if cfg.base_position:
            lo, hi = np.concatenate((lo, self.base_bounds[0])), np.concatenate((hi, self.base_bounds[1]))
        self.action_space = gym.spaces.Box(lo.astype(np.float32), hi.astype(np.float32), dtype=np.float32)
        self.action_names = action_names(self.robot, cfg.base_rotation, cfg.base_position)
        self.state_names = (
            tuple(f"{n}.pos" for n in self.joint_names)
            + (tuple(f"{n}.vel" for n in self.joint_names) if cfg.state_velocities else ())
            + ("palm.x", "palm.y", "palm.z", "palm.qw", "palm.qx", "palm.qy", "palm.qz")
            + (tuple(self.environment_state_names) if cfg.state_includes_task else ())
        )
        spaces = {"observation.state": gym.spaces.Box(-np.inf, np.inf, (len(self.state_names),), np.float32)}
        if not cfg.state_includes_task:
            spaces["observation.environment_state"] = gym.spaces.Box(
                -np.inf, np.inf, (len(self.environment_state_names),), np.float32
            )
        for cam in cfg.cameras:
            spaces[f"observation.images.{cam}"] = gym.spaces.Box(0, 255, (h, w, 3), np.uint8)
        self.observation_space = gym.spaces.Dict(spaces)
        self._renderer = None
        self.video_size = None  # (H, W) of render()'s frames when not the cameras' image_size (an eval's videos)
        self._video_renderer = None
        self._nu = nu
        self._ctrl = np.zeros(nu)
        self._base_rot = quat.IDENTITY.copy()
        self.t = 0.0
        self.steps = 0

    # ------------------------------------------------------------ scene
    def _build_scene(self, spec: mujoco.MjSpec) -> None:
        spec.add_texture(
            name="grid",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
            rgb1=[0.32, 0.36, 0.40],
            rgb2=[0.26, 0.30, 0.34],
            width=256,
            height=256,
        )
        spec.add_material(name="grid", textures=["", "grid"], texrepeat=[8, 8], reflectance=0.0)
        wb = spec.worldbody
        wb.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[1.0, 1.0, 0.05],
            material="grid",
            friction=[0.8, 0.005, 0.0001],
            contype=1,
            conaffinity=1,
        )
        wb.add_light(
            name="key", pos=[0.3, -0.4, 1.2], dir=[-0.25, 0.35, -1.0], diffuse=[0.7, 0.7, 0.7], castshadow=False
        )
        wb.add_light(
            name="fill", pos=[-0.4, 0.4, 1.0], dir=[0.4, -0.4, -1.0], diffuse=[0.35, 0.35, 0.35], castshadow=False
        )
        spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
        wb.add_body(name="base_target", mocap=True)
        spec.add_equality(
            type=mujoco.mjtEq.mjEQ_WELD,
            name1="base_target",
            name2=self.robot.config.root_body,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            solref=[self.config.weld_timeconst, 1.0],
            data=[0, 0, 0, *self.robot.root_in_palm[0], *self.robot.root_in_palm[1], 1.0, 0.0],
        )
        ws = np.array(self.workspace)
        for name, offset in (("front", (0.42, -0.30, 0.22)), ("top", (0.02, 0.0, 0.55)), ("side", (0.05, -0.50, 0.10))):
            pos = ws + offset
            wb.add_camera(name=name, pos=pos, xyaxes=_look_at(pos, ws), fovy=45.0)

    def _init_indices(self) -> None:
        m = self.model
        robot_root = m.body(self.robot.config.root_body).id
        self._base_qpos = m.jnt_qposadr[m.joint("base").id]
        self._base_dof = m.jnt_dofadr[m.joint("base").id]
        joints = [
            j
            for j in range(m.njnt)
            if m.body_rootid[m.jnt_bodyid[j]] == robot_root and m.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
        ]
        self.joint_names = tuple(m.joint(j).name for j in joints)
        self._jq = m.jnt_qposadr[joints]
        self._jv = m.jnt_dofadr[joints]
        self._mocap = m.body_mocapid[m.body("base_target").id]
        self._palm_in_root = (
            -quat.rotate(quat.conj(self.robot.root_in_palm[1]), self.robot.root_in_palm[0]),
            quat.conj(self.robot.root_in_palm[1]),
        )
        self._act_qpos = m.jnt_qposadr[m.actuator_trnid[:, 0]]
        self._robot_geoms = np.flatnonzero(m.body_rootid[m.geom_bodyid] == robot_root)
        # each finger's distal body (the one its fingertip site is on) and its geoms: what a task lights, what a
        # pinch must touch with, and what a watching wearer sees close on an object (``distal_gaps``)
        tips = [m.site(n).id for n in self.robot.tip_sites]
        self._distal = {f: int(m.site_bodyid[t]) for f, t in zip(self.robot.fingers, tips)}
        self._distal_geoms = {f: np.flatnonzero(m.geom_bodyid == b) for f, b in self._distal.items()}

    # ------------------------------------------------------------ the base
    def palm_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The glove palm frame's world pose (pos, quat) as the hand base is now."""
        p, q = (
            self.data.qpos[self._base_qpos : self._base_qpos + 3],
            self.data.qpos[self._base_qpos + 3 : self._base_qpos + 7],
        )
        pr, qr = self._palm_in_root
        return p + quat.rotate(q, pr), quat.mul(q, qr)

    def _set_base_target(self, pos, q) -> None:
        self.data.mocap_pos[self._mocap] = pos
        self.data.mocap_quat[self._mocap] = q

    def _place_base(self, pos, q) -> None:
        """Put the hand (and its target) at palm pose (pos, q), at rest."""
        self._set_base_target(pos, q)
        rp, rq = self.robot.root_in_palm
        self.data.qpos[self._base_qpos : self._base_qpos + 3] = pos + quat.rotate(q, rp)
        self.data.qpos[self._base_qpos + 3 : self._base_qpos + 7] = quat.mul(q, rq)
        self.data.qvel[self._base_dof : self._base_dof + 6] = 0.0

    # ------------------------------------------------------------ gym API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        mujoco.mj_resetData(self.model, self.data)
        self.t = 0.0
        self.steps = 0
        self.unstable_s = None  # when the physics blew up this episode (MuJoCo reset the state), if it did
        self._base_rot = quat.IDENTITY.copy()
        self._reset_task()
        pos, q = self._base_target(0.0)
        self._place_base(pos, q)
        self._ctrl = self.data.qpos[self._act_qpos].copy()
        self.data.ctrl[:] = np.clip(self._ctrl, *self.model.actuator_ctrlrange.T)
        mujoco.mj_forward(self.model, self.data)
        return self._observation(), self._info(False)

    def clip_action(self, action) -> np.ndarray:
        """``action`` as ``step`` applies it (float64): within the action space, the palm rotation's angle at most
        ``max_base_angle_deg``."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != self.action_space.shape:
            raise ValueError(f"expected an action of shape {self.action_space.shape}, got {a.shape}")
        a = np.clip(np.nan_to_num(a), self.action_space.low, self.action_space.high)
        if self.config.base_rotation:
            r = slice(self._nu, self._nu + 3)
            angle = np.linalg.norm(a[r])
            amax = np.radians(self.config.max_base_angle_deg)
            if angle > amax:
                a[r] = a[r] * (amax / angle)
        return a

    def step(self, action):
        a = self.clip_action(action)
        self.data.ctrl[:] = a[: self._nu]
        cfg = self.config
        if cfg.base_rotation:
            self._base_rot = quat.from_rotvec(a[self._nu : self._nu + 3])
        self.t = (self.steps + 1) / cfg.control_hz
        if cfg.base_position:  # the wearer's wrist: where the action puts it, palm down before the rotation
            pos, q = a[len(a) - 3 :].copy(), quat.IDENTITY.copy()
        else:
            pos, q = self._base_target(self.t)
        turned = quat.mul(q, self._base_rot)
        if self.pivot is not None:  # the palm turns about the task's pivot, not about the palm frame's origin
            pos = pos + quat.rotate(q, self.pivot) - quat.rotate(turned, self.pivot)
        self._set_base_target(pos, turned)
        blowups = self._blowups()
        mujoco.mj_step(self.model, self.data, nstep=self.n_substeps)
        if self._blowups() > blowups and self.unstable_s is None:
            self.unstable_s = round(self.t, 3)
        self.steps += 1
        success, terminated, reward = self._evaluate()
        truncated = not terminated and self.t >= self.config.episode_s - 1e-9
        info = self._info(success)
        info["applied_action"] = a.astype(np.float32)
        return self._observation(), float(reward), bool(terminated), bool(truncated), info

    def _blowups(self) -> int:
        """MuJoCo's count of unstable steps ("Nan, Inf or huge value in QACC ..."), after each of which it resets the
        simulation's state: the episode goes on from another state, which a saved episode must say."""
        return sum(int(self.data.warning[w].number) for w in UNSTABLE)

    def _info(self, success: bool) -> dict:
        info = {"is_success": bool(success), "t": self.t}
        if self.unstable_s is not None:
            info["physics_unstable_s"] = self.unstable_s
        return info

    def _observation(self) -> dict:
        d = self.data
        parts = [d.qpos[self._jq]]
        if self.config.state_velocities:
            parts.append(d.qvel[self._jv])
        parts.extend(self.palm_pose())
        task = self._environment_state().astype(np.float32)
        if self.config.state_includes_task:
            obs = {"observation.state": np.concatenate([*parts, task]).astype(np.float32)}
        else:
            obs = {"observation.state": np.concatenate(parts).astype(np.float32), "observation.environment_state": task}
        for cam in self.config.cameras:
            obs[f"observation.images.{cam}"] = self._render(cam)
        return obs

    def _render(self, camera: str) -> np.ndarray:
        if self._renderer is None:
            h, w = self.config.image_size
            kept, self.model.vis.quality.offsamples = self.model.vis.quality.offsamples, self.config.camera_samples
            try:  # read when the renderer's GL context is made
                self._renderer = mujoco.Renderer(self.model, h, w)
            finally:
                self.model.vis.quality.offsamples = kept
        self._renderer.update_scene(self.data, camera=camera)
        return self._renderer.render()

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        camera = self.config.cameras[0] if self.config.cameras else "front"
        if self.video_size is None or tuple(self.video_size) == tuple(self.config.image_size):
            return self._render(camera)
        if self._video_renderer is None:  # people watch at another size than a policy's 84 px input
            self._video_renderer = mujoco.Renderer(self.model, *self.video_size)
        self._video_renderer.update_scene(self.data, camera=camera)
        return self._video_renderer.render()

    def close(self):
        for renderer in (self._renderer, self._video_renderer):
            if renderer is not None:
                renderer.close()
        self._renderer = self._video_renderer = None

    # ------------------------------------------------------------ helpers for tasks
    def actuated_positions(self) -> np.ndarray:
        """Positions (nu,) of the actuators' joints, comparable with ctrl targets."""
        return self.data.actuator_length.copy()

    def hand_bodies_touching(self, geom: int) -> set[int]:
        """The hand bodies (ids) that touch ``geom`` now."""
        d, m = self.data, self.model
        bodies = set()
        for c in d.contact[: d.ncon]:
            for a, b in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
                if a == geom and b in self._robot_geoms:
                    bodies.add(int(m.geom_bodyid[b]))
        return bodies

    def distal_gaps(self, geom: int, reach_m: float = 0.05) -> dict[str, tuple[float, np.ndarray]]:
        """Per finger (thumb first): the gap (m) between its distal segment's surface and ``geom``'s (negative where
        they press into each other, at most ``reach_m``) and the vector (3, m, world) from the segment's nearest
        point to the object's. What an operator watching the robot hand sees when they close it on an object
        (recorder/demonstrator/watching.py)."""
        m, d = self.model, self.data
        colliding = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        out, fromto = {}, np.zeros(6)
        for f, geoms in self._distal_geoms.items():
            best = (reach_m, np.zeros(3))
            for g in geoms:
                if colliding[g]:
                    gap = mujoco.mj_geomDistance(m, d, int(g), geom, reach_m, fromto)
                    if gap < best[0]:
                        best = (float(gap), fromto[3:] - fromto[:3])
            out[f] = best
        return out

    def hand_contacts(self, geom: int) -> int:
        """How many distinct hand bodies touch ``geom``."""
        return len(self.hand_bodies_touching(geom))

    # ------------------------------------------------------------ for subclasses
    environment_state_names: tuple = ()

    def guidance(self) -> str | None:
        """What the operator should do now, in a few words, for the live view (None: its schedule's next move)."""
        return None

    def failure(self) -> str | None:
        """Why the take has not succeeded, as it stands now, in a few words ("dropped in the carry"), for a failed
        episode's record; None where the task does not say."""
        return None

    def show_state(self, environment_state: np.ndarray) -> None:
        """Show in this scene's looks what ``environment_state`` (another copy's) says that they change with: the
        live views keep a copy of the task that follows the recording's frames (default: nothing to show)."""

    def instruction(self) -> str:
        """The episode's instruction, as a person reads it and a dataset's ``task`` stores it (after ``reset``)."""
        return self.task_name

    def instructions(self) -> tuple[str, ...]:
        """Every instruction this task's config can draw (a fixed, finite set)."""
        return (self.task_name,)

    def _build_task(self, spec: mujoco.MjSpec) -> None:
        pass

    def _reset_task(self) -> None:
        pass

    def _base_target(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.workspace, float), quat.IDENTITY.copy()

    def _environment_state(self) -> np.ndarray:
        return np.zeros(0)

    def _evaluate(self) -> tuple[bool, bool, float]:
        """(success, terminated, reward) after a step."""
        return False, False, 0.0
