"""A robot's joint map: human joint angles (20, recorder.hand.kinematics.JOINTS) -> actuator targets, the linear
map of its yaml's ``retarget.joints`` compiled against its MuJoCo model, and its couplings (passive joints that
follow an actuated one). Every robot has one: tasks use it for their goals (HandPose), retargeting for its
``joint`` mode and to seed and regularise fingertip IK."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from envs.robots.config import CouplingConfig, RetargetSection
from recorder.config import ConfigError
from recorder.hand.kinematics import JOINTS, N_JOINTS


def tendon_couplings(model: mujoco.MjModel) -> list[CouplingConfig]:
    """Couplings the model defines as fixed tendons that tie two joints (range within ±0.01 of zero), as the
    Shadow hand's J1/J0: c_a q_a + c_b q_b ≈ 0, so the unactuated joint follows the actuated one."""
    actuated = {
        int(model.actuator_trnid[i, 0])
        for i in range(model.nu)
        if model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
    }
    out = []
    for t in range(model.ntendon):
        adr, num = model.tendon_adr[t], model.tendon_num[t]
        if num != 2 or not model.tendon_limited[t]:
            continue
        lo, hi = model.tendon_range[t]
        if not (lo <= 0.0 <= hi and hi - lo <= 0.01):
            continue
        if any(model.wrap_type[adr + k] != mujoco.mjtWrap.mjWRAP_JOINT for k in range(2)):
            continue
        (ja, jb), (ca, cb) = model.wrap_objid[adr : adr + 2], model.wrap_prm[adr : adr + 2]
        if ja in actuated and jb not in actuated:
            ja, jb, ca, cb = jb, ja, cb, ca
        elif not (jb in actuated and ja not in actuated):
            continue
        out.append(CouplingConfig(model.joint(int(ja)).name, model.joint(int(jb)).name, float(-cb / ca)))
    return out


@dataclass(frozen=True)
class JointMap:
    """``clip(A @ angles + b, lo, hi)`` over the actuators (``__call__``), the actuators with no human source
    (``constant``), and the couplings; ``qpos(ctrl)`` puts a model's joints at actuator targets."""

    actuators: tuple
    A: np.ndarray  # (nu, 20)
    b: np.ndarray  # (nu,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)
    constant: np.ndarray  # (nu,) bool
    couplings: tuple
    _qpos0: np.ndarray
    _act_qpos: np.ndarray
    _follow: np.ndarray
    _lead: np.ndarray
    _ratio: np.ndarray

    def __call__(self, angles) -> np.ndarray:
        """Actuator targets (nu,) from human joint angles (20,), clipped to the limits."""
        return np.clip(self.A @ np.asarray(angles, float) + self.b, self.lo, self.hi)

    def qpos(self, ctrl) -> np.ndarray:
        """The model's joint positions (nq,) with the actuated joints at ``ctrl`` and coupled joints following."""
        q = self._qpos0.copy()
        q[self._act_qpos] = ctrl
        if len(self._follow):
            q[self._follow] = self._ratio * q[self._lead]
        return q

    @classmethod
    def compile(cls, section: RetargetSection, model: mujoco.MjModel, source: str) -> JointMap:
        """Check ``section`` against ``model`` (the robot alone) and compile it; ConfigError naming the key."""
        where = f"{source}: retarget"
        actuators = tuple(model.actuator(i).name for i in range(model.nu))
        if any(model.actuator_trntype != mujoco.mjtTrn.mjTRN_JOINT):
            raise ConfigError(f"{source}: retargeting needs joint-transmission actuators only")
        bad = [k for k in section.joints if k not in actuators]
        if bad:
            raise ConfigError(f"{where}.joints: unknown actuator {bad[0]!r}; valid: {', '.join(actuators)}")
        missing = [a for a in actuators if a not in section.joints]
        if missing:
            raise ConfigError(f"{where}.joints: missing actuator(s) {', '.join(missing)}")
        ctrl = model.actuator_ctrlrange
        nu = len(actuators)
        A, b = np.zeros((nu, N_JOINTS)), np.zeros(nu)
        lo, hi = ctrl[:, 0].copy(), ctrl[:, 1].copy()
        constant = np.zeros(nu, bool)
        for i, name in enumerate(actuators):
            entry = section.joints[name]
            at = f"{where}.joints.{name}"
            src = None if entry is None else entry.source
            weights = {src: 1.0} if isinstance(src, str) else dict(src or {})
            for human, w in weights.items():
                if human not in JOINTS:
                    raise ConfigError(f"{at}.source: unknown human joint {human!r}; valid: {', '.join(JOINTS)}")
                A[i, JOINTS.index(human)] = w
            constant[i] = not weights
            if entry is None:
                continue
            A[i] *= entry.scale
            b[i] = entry.offset
            if entry.limits is not None:
                low, high = entry.limits
                if not low < high:
                    raise ConfigError(f"{at}.limits: lo {low:g} must be below hi {high:g}")
                if low < ctrl[i, 0] - 1e-6 or high > ctrl[i, 1] + 1e-6:
                    raise ConfigError(
                        f"{at}.limits: [{low:g}, {high:g}] out of the actuator's ctrl range "
                        f"[{ctrl[i, 0]:g}, {ctrl[i, 1]:g}]"
                    )
                lo[i], hi[i] = low, high
        couplings = tendon_couplings(model)
        joint_names = {model.joint(j).name for j in range(model.njnt)}
        for k, c in enumerate(section.couplings):
            for key in ("joint", "leader"):
                if getattr(c, key) not in joint_names:
                    raise ConfigError(
                        f"{where}.couplings.{k}.{key}: unknown joint {getattr(c, key)!r}; "
                        f"valid: {', '.join(sorted(joint_names))}"
                    )
            couplings.append(c)
        jnt = lambda name: model.jnt_qposadr[model.joint(name).id]  # noqa: E731
        return cls(
            actuators,
            A,
            b,
            lo,
            hi,
            constant,
            tuple(couplings),
            model.qpos0.copy(),
            model.jnt_qposadr[model.actuator_trnid[:, 0]],
            np.array([jnt(c.joint) for c in couplings], int),
            np.array([jnt(c.leader) for c in couplings], int),
            np.array([c.ratio for c in couplings]),
        )
