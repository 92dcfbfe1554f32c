"""The ``retarget`` section of ``configs/robots/<name>.yaml``, validated against the robot's MuJoCo model.

    retarget:
      tips: {scale: 1.0, offset: [0, 0, 0]}   # human fingertip p (palm frame, m) -> robot target scale * p + offset
      joints:                                  # one entry per actuator, none left out
        <actuator>: {source: <human joint> | {<human joint>: weight, ...}, scale: 1.0, offset: 0.0,
                     limits: [lo, hi]}         # target = clip(offset + scale * sum(weight * angle), limits)
      couplings:                               # passive joints that follow an actuated one (besides the
        - {joint: <name>, leader: <name>, ratio: r}   # model's own tendon couplings, found automatically)
      ik: {posture_cost: 0.05, iterations: 8, tolerance_m: 0.001, damping: 1.0e-3}

``source`` left out makes a constant target (``offset``). ``limits`` default to the actuator's ctrl range and
must lie inside it. Every error is one line naming the file, the key and what would be valid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from recorder.hand.kinematics import JOINTS, N_JOINTS

_TOP_KEYS = ("tips", "joints", "couplings", "ik")
_JOINT_KEYS = ("source", "scale", "offset", "limits")


class RetargetConfigError(ValueError):
    """A retarget config that does not fit its robot; the message is one line."""


@dataclass(frozen=True)
class Coupling:
    """Joint ``joint`` follows ``leader``: q[joint] = ratio * q[leader] (a tendon or linkage in the robot)."""

    joint: str
    leader: str
    ratio: float


@dataclass(frozen=True)
class IKConfig:
    posture_cost: float = 0.05  # pull toward the joint-mapped pose (keeps the solution human-like)
    tip_cost: float = 1.0
    iterations: int = 8  # per frame at most; the solver is warm-started from the last frame
    tolerance_m: float = 0.001  # stop when every fingertip is this close to its target
    damping: float = 1e-3  # Levenberg-Marquardt damping
    solver: str = "daqp"


@dataclass(frozen=True)
class RetargetConfig:
    """Compiled joint map ``clip(A @ angles + b, lo, hi)`` over the robot's actuators, plus tips, couplings
    and IK settings."""

    source: str
    actuators: tuple
    A: np.ndarray  # (nu, 20)
    b: np.ndarray  # (nu,)
    lo: np.ndarray  # (nu,)
    hi: np.ndarray  # (nu,)
    constant: np.ndarray  # (nu,) bool: actuators with no human source
    tip_scale: float = 1.0
    tip_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    couplings: tuple = ()
    ik: IKConfig = IKConfig()


def _number(value, where: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RetargetConfigError(f"{source}: {where} must be a number, got {value!r}")
    return float(value)


def tendon_couplings(model: mujoco.MjModel) -> list[Coupling]:
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
        out.append(Coupling(model.joint(int(ja)).name, model.joint(int(jb)).name, float(-cb / ca)))
    return out


def load_retarget_config(raw: dict | None, model: mujoco.MjModel, source: str = "retarget") -> RetargetConfig:
    """Validate the ``retarget`` mapping ``raw`` against ``model`` (the robot alone) and compile it."""
    where = f"{source}: retarget"
    if not isinstance(raw, dict):
        raise RetargetConfigError(f"{where}: missing or not a mapping")
    unknown = sorted(set(raw) - set(_TOP_KEYS))
    if unknown:
        raise RetargetConfigError(f"{where}: unknown key(s) {', '.join(unknown)}; valid: {', '.join(_TOP_KEYS)}")
    actuators = tuple(model.actuator(i).name for i in range(model.nu))
    ctrl = model.actuator_ctrlrange
    joints = raw.get("joints")
    if not isinstance(joints, dict) or not joints:
        raise RetargetConfigError(f"{where}.joints: missing; map every actuator ({', '.join(actuators)})")
    bad = [k for k in joints if k not in actuators]
    if bad:
        raise RetargetConfigError(f"{where}.joints: unknown actuator {bad[0]!r}; valid: {', '.join(actuators)}")
    missing = [a for a in actuators if a not in joints]
    if missing:
        raise RetargetConfigError(f"{where}.joints: missing actuator(s) {', '.join(missing)}")

    nu = len(actuators)
    A, b = np.zeros((nu, N_JOINTS)), np.zeros(nu)
    lo, hi = ctrl[:, 0].copy(), ctrl[:, 1].copy()
    constant = np.zeros(nu, bool)
    for i, name in enumerate(actuators):
        entry = joints[name]
        at = f"{where}.joints.{name}"
        if entry is None:
            entry = {}
        if not isinstance(entry, dict):
            raise RetargetConfigError(f"{at}: expected a mapping with {', '.join(_JOINT_KEYS)}")
        extra = sorted(set(entry) - set(_JOINT_KEYS))
        if extra:
            raise RetargetConfigError(f"{at}: unknown key(s) {', '.join(extra)}; valid: {', '.join(_JOINT_KEYS)}")
        src = entry.get("source")
        weights = {src: 1.0} if isinstance(src, str) else src if isinstance(src, dict) else {}
        if src is not None and not isinstance(src, (str, dict)):
            raise RetargetConfigError(f"{at}.source: expected a human joint or {{joint: weight}}, got {src!r}")
        for human, w in weights.items():
            if human not in JOINTS:
                raise RetargetConfigError(f"{at}.source: unknown human joint {human!r}; valid: {', '.join(JOINTS)}")
            A[i, JOINTS.index(human)] = _number(w, f"{at}.source.{human}", source)
        constant[i] = not weights
        A[i] *= _number(entry.get("scale", 1.0), f"{at}.scale", source)
        b[i] = _number(entry.get("offset", 0.0), f"{at}.offset", source)
        if "limits" in entry:
            lim = entry["limits"]
            if not isinstance(lim, (list, tuple)) or len(lim) != 2:
                raise RetargetConfigError(f"{at}.limits: expected [lo, hi] in radians, got {lim!r}")
            low, high = (_number(v, f"{at}.limits", source) for v in lim)
            if not low < high:
                raise RetargetConfigError(f"{at}.limits: lo {low:g} must be below hi {high:g}")
            if low < ctrl[i, 0] - 1e-6 or high > ctrl[i, 1] + 1e-6:
                raise RetargetConfigError(
                    f"{at}.limits: [{low:g}, {high:g}] out of the actuator's ctrl range "
                    f"[{ctrl[i, 0]:g}, {ctrl[i, 1]:g}]"
                )
            lo[i], hi[i] = low, high

    tips = raw.get("tips", {}) or {}
    if not isinstance(tips, dict) or set(tips) - {"scale", "offset"}:
        raise RetargetConfigError(f"{where}.tips: expected {{scale: s, offset: [x, y, z]}}")
    scale = _number(tips.get("scale", 1.0), f"{where}.tips.scale", source)
    if scale <= 0:
        raise RetargetConfigError(f"{where}.tips.scale: must be positive, got {scale:g}")
    offset = tips.get("offset", [0.0, 0.0, 0.0])
    if not isinstance(offset, (list, tuple)) or len(offset) != 3:
        raise RetargetConfigError(f"{where}.tips.offset: expected [x, y, z] in metres")
    offset = np.array([_number(v, f"{where}.tips.offset", source) for v in offset])

    couplings = tendon_couplings(model)
    joint_names = {model.joint(j).name for j in range(model.njnt)}
    for k, c in enumerate(raw.get("couplings", []) or []):
        at = f"{where}.couplings[{k}]"
        if not isinstance(c, dict) or set(c) != {"joint", "leader", "ratio"}:
            raise RetargetConfigError(f"{at}: expected {{joint: name, leader: name, ratio: r}}")
        for key in ("joint", "leader"):
            if c[key] not in joint_names:
                raise RetargetConfigError(
                    f"{at}.{key}: unknown joint {c[key]!r}; valid: {', '.join(sorted(joint_names))}"
                )
        couplings.append(Coupling(c["joint"], c["leader"], _number(c["ratio"], f"{at}.ratio", source)))

    ik_raw = raw.get("ik", {}) or {}
    fields = IKConfig.__dataclass_fields__
    extra = sorted(set(ik_raw) - set(fields))
    if extra:
        raise RetargetConfigError(f"{where}.ik: unknown key(s) {', '.join(extra)}; valid: {', '.join(fields)}")
    ik = IKConfig(
        **{
            k: (v if k == "solver" else int(v) if k == "iterations" else _number(v, f"{where}.ik.{k}", source))
            for k, v in ik_raw.items()
        }
    )
    return RetargetConfig(source, actuators, A, b, lo, hi, constant, scale, offset, tuple(couplings), ik)
