"""Human hand -> robot action: 20 joint angles and the palm orientation in, actuator targets (and the base
rotation) out, with the fingertip retargeting error of every frame.

Modes: ``joint`` maps joint angles linearly (configs/robots/<name>.yaml, retarget.joints); ``ik`` places the
robot's fingertips on the scaled human fingertips by inverse kinematics, seeded and regularised by the joint
map; ``pinch`` (pinch.py) adds thumb-finger vectors, closes the robot's pinch when the human's fingertips touch
and keeps the robot's fingers out of each other.

The human fingertips are the wearer's (``hand_size``: their hand profile, recorder/hand/profile.py), scaled to
the 190 mm reference hand along the palm's axes (length, breadth) and then to the robot by its ``retarget.tips``:
a small and a large wearer making the same gesture ask the robot for the same fingertips. A robot with fewer
fingers (no pinky) takes the thumb and the fingers it has.

The palm orientation becomes a rotation vector (3, rad): the palm's rotation since the first frame after
``reset()`` in the palm's own axes (``palm_reference="first"``; any glove heading works), or its absolute
orientation in the glove's world (``"absolute"``). Environments apply it to their hand base. With
``base_position`` (a free wrist) the palm's position target (3, m, the robot's world: recorder/wrist/fusion.py
maps a tracker's, ``WristFusion.zero`` and ``pose``) follows it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from envs.robots import Robot, load_robot
from envs.robots.config import TipsConfig
from recorder import quat
from recorder.config import ConfigError
from recorder.hand.kinematics import N_JOINTS, HandSize
from recorder.hand.skeleton import FINGERS
from recorder.retarget.human import HumanHandFK
from recorder.retarget.ik import FingertipIK
from recorder.retarget.pinch import PinchSolver

MODES = ("joint", "ik", "pinch")
PALM_REFERENCES = ("first", "absolute")


class Retargeter:
    """``action, info = retargeter(angles, palm_quat, palm_pos)``. action: float32 (nu,) actuator targets, followed
    by the palm rotation vector (3,) when ``base_rotation`` and the palm position (3,) when ``base_position``.
    info: tip_error (n,) m per robot finger, thumb first (robot fingertip vs scaled human fingertip, palm frame),
    tip_error_mean, ik_iterations, joint_targets (nu,), qpos (the robot's joint positions at the targets)."""

    @classmethod
    def for_env(cls, env, mode: str = "joint", **kw) -> Retargeter:
        """The retargeter whose actions ``env`` (a gloverec task) takes: its robot, with the palm rotation where
        the task turns its base (HandKeys' does not)."""
        u = env.unwrapped
        return cls(u.robot, mode, base_rotation=u.config.base_rotation, base_position=u.config.base_position, **kw)

    def __init__(
        self,
        robot="glovehand",
        mode: str = "joint",
        *,
        base_rotation: bool = True,
        base_position: bool = False,
        palm_reference: str = "first",
        hand_size: HandSize = HandSize(),
    ):
        if mode not in MODES:
            raise ConfigError(f"unknown retarget mode {mode!r}; valid modes: {', '.join(MODES)}")
        if palm_reference not in PALM_REFERENCES:
            raise ConfigError(f"unknown palm reference {palm_reference!r}; valid: {', '.join(PALM_REFERENCES)}")
        self.robot = robot if isinstance(robot, Robot) else load_robot(robot)
        self.mode = mode
        self.base_rotation = base_rotation
        self.base_position = base_position
        self.palm_reference = palm_reference
        self.hand_size = hand_size
        self.human = HumanHandFK(hand_size)
        self.fingers = self.robot.fingers
        self._human_fingers = [FINGERS.index(f) for f in self.fingers]
        self._to_reference = 1.0 / hand_size.axes()  # the wearer's fingertips on the reference hand
        self.map = self.robot.joint_map
        section = self.robot.config.retarget
        self.tips = section.tips
        spec = self.robot.spec()
        for c in self.map.couplings:  # couplings as joint equalities: exact in FK, hard constraints in IK
            spec.add_equality(
                type=mujoco.mjtEq.mjEQ_JOINT, name1=c.joint, name2=c.leader, data=[0.0, c.ratio] + [0.0] * 10
            )
        self.model = m = spec.compile()
        self.data = mujoco.MjData(m)
        self.nu = m.nu
        self.action_dim = m.nu + (3 if base_rotation else 0) + (3 if base_position else 0)
        self._act_qpos = m.jnt_qposadr[m.actuator_trnid[:, 0]]
        act_dof = m.jnt_dofadr[m.actuator_trnid[:, 0]]
        self._tip_ids = self.robot.tip_site_ids
        self._palm_ref = None
        self.ik = self.pinch = None
        if mode == "pinch":
            tip_ids = [m.site(n).id for n in self.robot.tip_sites]
            self.pinch = PinchSolver(m, tip_ids, self.map, section.pinch, self.tips.scale)
        if mode == "ik":
            cost = np.full(m.nv, section.ik.posture_cost)
            cost[act_dof[self.map.constant]] = 100.0  # constant targets (e.g. a wrist): hold them
            if self.map.couplings:  # coupled joints are set by their constraint, not pulled by the posture
                cost[m.jnt_dofadr[[m.joint(c.joint).id for c in self.map.couplings]]] = 0.0
            self.ik = FingertipIK(m, list(self.robot.tip_sites), section.ik, cost)

    def reset(self) -> None:
        """Start a new episode: the next palm orientation becomes the reference; IK restarts."""
        self._palm_ref = None
        for solver in (self.ik, self.pinch):
            if solver is not None:
                solver.reset()

    # ------------------------------------------------------------ pieces
    def joint_map(self, angles) -> np.ndarray:
        """Actuator targets (nu,) from human joint angles (20,) by the robot's joint map, clipped."""
        return self.map(angles)

    def qpos(self, ctrl) -> np.ndarray:
        """Robot joint positions (nq,) with the actuated joints at ``ctrl`` and coupled joints following."""
        return self.map.qpos(ctrl)

    @property
    def tips(self) -> TipsConfig:
        return self._tips

    @tips.setter
    def tips(self, tips: TipsConfig) -> None:
        """The fingertip map (the robot's ``retarget.tips``; fit.py tries others)."""
        self._tips = tips
        maps = [tips.of(f) for f in self.fingers]
        self._tip_map = (np.array([s for s, _ in maps])[:, None], np.array([o for _, o in maps], float))

    def reference_tips(self, angles) -> np.ndarray:
        """The wearer's fingertips (n, 3) of the robot's fingers, on the reference hand (palm frame, m)."""
        return self.human.tips(angles)[self._human_fingers] * self._to_reference

    def human_tips(self, angles) -> np.ndarray:
        """Scaled human fingertips (n, 3), palm frame, m: the robot's fingertip targets."""
        scale, offset = self._tip_map
        return scale * self.reference_tips(angles) + offset

    def human_gaps(self, angles) -> np.ndarray:
        """Distances (n - 1,) from the wearer's thumb tip to each of the robot's fingers' tips, reference hand."""
        p = self.reference_tips(angles)
        return np.linalg.norm(p[1:] - p[0], axis=1)

    def robot_tips(self, q) -> np.ndarray:
        """Robot fingertips (n, 3), palm frame, m, at joint positions q (nq,)."""
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.site_xpos[self._tip_ids].copy()

    def palm_rotvec(self, palm_quat) -> np.ndarray:
        q = quat.normalize(np.asarray(palm_quat, float))
        if self.palm_reference == "absolute":
            return quat.to_rotvec(q)
        if self._palm_ref is None:
            self._palm_ref = q
        return quat.to_rotvec(quat.mul(quat.conj(self._palm_ref), q))

    # ------------------------------------------------------------ the call
    def __call__(self, angles, palm_quat=None, palm_pos=None) -> tuple[np.ndarray, dict]:
        angles = np.asarray(angles, float)
        if angles.shape != (N_JOINTS,):
            raise ValueError(f"expected {N_JOINTS} joint angles, got shape {angles.shape}")
        ctrl = self.joint_map(angles)
        targets = self.human_tips(angles)
        iterations = 0
        if self.ik is not None:
            q, iterations = self.ik.solve(targets, self.qpos(ctrl))
            ctrl = np.clip(q[self._act_qpos], self.map.lo, self.map.hi)
        elif self.pinch is not None:
            q, iterations = self.pinch.solve(targets, self.human_gaps(angles), ctrl)
            ctrl = q[self._act_qpos]
        q = self.qpos(ctrl)
        err = np.linalg.norm(self.robot_tips(q) - targets, axis=1)
        action = ctrl
        if self.base_rotation:
            rv = np.zeros(3) if palm_quat is None else self.palm_rotvec(palm_quat)
            action = np.concatenate((ctrl, rv))
        if self.base_position:
            if palm_pos is None:
                raise ValueError("a free-wrist retargeter needs the palm position (a wrist source's)")
            action = np.concatenate((action, np.asarray(palm_pos, float).reshape(3)))
        info = {
            "tip_error": err,
            "tip_error_mean": float(err.mean()),
            "ik_iterations": iterations,
            "joint_targets": ctrl,
            "qpos": q,
        }
        return action.astype(np.float32), info
