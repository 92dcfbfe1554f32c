"""Pinch-preserving retargeting: one small nonlinear least-squares problem per frame over the robot's actuated
joints, DexPilot's idea (Handa et al. 2020) on MuJoCo's kinematics and collision geometry.

Terms (weights in the robot's ``retarget.pinch`` section, envs/robots/config.py PinchConfig):
- fingertips: each robot fingertip on its target (the wearer's fingertip scaled to the robot);
- thumb-finger vectors: the vector from the robot's thumb tip to each fingertip equals the human's, scaled: the
  shape of a grasp, which matters more than where the hand sits;
- pinch: when the human's thumb and a finger come within ``release_m``, the robot's fingertip pads (their
  collision geoms) are pulled to the human's gap, zero once the human's fingertips touch (``touch_m``); a pair's
  vector term fades out as its pinch term comes in, as in DexPilot;
- non-penetration: every finger-finger pair the model collides (contacts.py) is pushed apart when it overlaps;
- temporal smoothness: the change from the last frame; posture: a weak pull toward the joint map.
Joint limits are the box bounds of the variables; coupled joints follow their leaders exactly (the variables are
the actuator targets). Each frame starts from the last solution (warm start) and takes at most ``iterations``
Gauss-Newton steps with a projected active set for the bounds, stopping once a step gains less than
``improvement`` of the cost (about 2.5 evaluations a frame on Shadow).

Written here rather than with a general solver: dex-retargeting's DexPilot (NLopt SLSQP on Pinocchio) takes
14-22 ms a frame on a Shadow hand on a 2-core machine and mink's QP per iteration about 1 ms; a frame of this
problem is a few Jacobians from MuJoCo and a 20x20 solve, well under 2 ms (bench/retarget.py).
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.linalg.lapack import dposv

from envs.robots import JointMap
from envs.robots.config import PinchConfig
from recorder.retarget.contacts import FingerGeoms

SAFE_M = 0.0005  # contact pairs are pushed apart to this separation
DAMPING = 1e-6  # Levenberg-Marquardt damping (the problem is well posed with the posture term)
LINEAR_RAD = 0.01  # a step this small moves a finger by about half a millimetre: distances change linearly


class PinchSolver:
    """``q, iterations = solver.solve(targets, human_gaps, ctrl_map)``: robot joint positions (nq,) for fingertip
    targets (n, 3) (thumb first, the robot's fingers), the human's thumb-to-finger fingertip distances (n - 1,)
    (reference hand, m) and the joint map's actuator targets (nu,) (the posture and the first frame's start)."""

    def __init__(self, model: mujoco.MjModel, tip_site_ids, joint_map: JointMap, config: PinchConfig, scale: float):
        self.model = m = model
        self.data = mujoco.MjData(m)
        self.config = config
        self.scale = float(scale)
        self.map = jm = joint_map
        self.geoms = FingerGeoms(m, tip_site_ids)
        pairs = {tuple(p) for p in self.geoms.pairs.tolist()}
        pads = self.geoms.pads
        self._pad_collides = np.array([tuple(sorted((pads[0], p))) in pairs for p in pads[1:]], bool)
        self._pads = np.array([(pads[0], p) for p in pads[1:]], int).reshape(-1, 2)  # thumb pad, finger pad
        self._pad_ok = (self._pads >= 0).all(axis=1)  # both fingertips have a collision geom
        self.tips = np.asarray(tip_site_ids, int)
        self.var = np.flatnonzero(~jm.constant)  # the actuators optimised (constant ones, a wrist, stay)
        act_q = m.jnt_qposadr[m.actuator_trnid[:, 0]]
        # dq/dx: each variable moves its joint, and the joints coupled to that one by their ratio
        self.S = np.zeros((m.nv, len(self.var)))
        for k, a in enumerate(self.var):
            self.S[act_q[a], k] = 1.0
        for f, lead, ratio in zip(jm._follow, jm._lead, jm._ratio):
            self.S[f] += ratio * self.S[lead]
        self.lo, self.hi = jm.lo[self.var], jm.hi[self.var]
        self._jacs = np.zeros((len(self.tips), 3, m.nv))  # mj_jacSite writes each fingertip's rows in place
        self._diag = np.diag_indices(len(self.var))
        self.x = None

    def reset(self) -> None:
        self.x = None

    def _qpos(self, ctrl_map: np.ndarray, x: np.ndarray) -> np.ndarray:
        ctrl = ctrl_map.copy()
        ctrl[self.var] = x
        return self.map.qpos(ctrl)

    def solve(self, targets: np.ndarray, human_gaps: np.ndarray, ctrl_map: np.ndarray) -> tuple[np.ndarray, int]:
        c = self.config
        x_map = ctrl_map[self.var]
        if self.x is None:
            self.x = x_map.copy()
        x_prev = self.x.copy()
        x = self.x
        # per thumb-finger pair: how much it pinches (1 when the human's fingertips touch) and the pads' gap
        active = np.clip((c.release_m - human_gaps) / (c.release_m - c.touch_m), 0.0, 1.0)
        pad_target = self.scale * np.maximum(human_gaps - c.touch_m, 0.0)
        human_vec = targets[1:] - targets[0]
        n, best, step, x_best = 0, np.inf, np.zeros(len(x)), x
        for n in range(1, c.iterations + 1):  # noqa: B007  (n is the iteration count returned)
            H, g, G, dist, cost = self._normal_equations(
                ctrl_map, x, targets, human_vec, active, pad_target, x_prev, x_map
            )
            if cost > best:  # the last step overshot (the problem is not linear over it): go half as far
                step *= 0.5
                x = x_best + step
                continue
            settled = best - cost < c.improvement * cost  # the last step gained next to nothing: done
            best, x_best = cost, x
            if n == c.iterations or settled:
                break
            step = self._step(H, g, G, dist, x)
            x = x + step
            if np.abs(step).max() < c.tolerance:
                break
            # a small step that should gain next to nothing is taken without another evaluation
            gain = -(2.0 * g @ step + step @ H @ step)  # Gauss-Newton's prediction of the cost's decrease
            if gain < c.improvement * cost and np.abs(step).max() < LINEAR_RAD:
                break
        else:
            x = x_best  # ended on a step that made things worse
        self.x = x
        return self._qpos(ctrl_map, x), n

    def _normal_equations(self, ctrl_map, x, targets, human_vec, active, pad_target, x_prev, x_map):
        """J^T J and J^T r of the weighted residuals at x, the cost there, and the contact pairs within the
        margin: their distances and gradients (rows, variables)."""
        m, d, c, S = self.model, self.data, self.config, self.S
        d.qpos[:] = self._qpos(ctrl_map, x)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        tips = d.site_xpos[self.tips]
        nx, jacs = len(x), self._jacs
        for k, s in enumerate(self.tips):
            mujoco.mj_jacSite(m, d, jacs[k], None, int(s))
        jt = (jacs.reshape(-1, m.nv) @ S).reshape(len(self.tips), 3, nx)  # per variable, coupled joints included
        rows = [jt.reshape(-1, nx) * np.sqrt(c.tip_weight)]
        res = [(tips - targets).reshape(-1) * np.sqrt(c.tip_weight)]
        wv = np.sqrt(c.vector_weight * (1.0 - active))[:, None]
        rows.append(((jt[1:] - jt[0]) * wv[:, :, None]).reshape(-1, nx))
        res.append((((tips[1:] - tips[0]) - human_vec) * wv).reshape(-1))
        geoms, pads = self.geoms, self._pads
        pinching = ((active > 0.0) & self._pad_ok).nonzero()[0]
        if len(pinching):  # pinching pairs: the pads to the human's gap
            gap, fromto = geoms.measure(d, pads[pinching], 1.0)
            pull = (gap > pad_target[pinching]) | self._pad_collides[pinching]  # pads that pass through: not pushed
            if pull.any():
                k = pinching[pull]
                wp = np.sqrt(c.pinch_weight * active[k])
                rows.append(wp[:, None] * (geoms.gradients(d, pads[k], gap[pull], fromto[pull]) @ S))
                res.append(wp * (gap[pull] - pad_target[k]))
        # finger-finger pairs within the margin: their distances and gradients (the step keeps them apart)
        pairs = geoms.pairs[geoms.near(d, c.margin_m)]
        dist, fromto = geoms.measure(d, pairs, c.margin_m)
        close = dist < c.margin_m
        dist = dist[close]
        G = geoms.gradients(d, pairs[close], dist, fromto[close]) @ S
        J = np.concatenate(rows)
        r = np.concatenate(res)
        H = J.T @ J
        H[self._diag] += c.smooth_weight + c.posture_weight + DAMPING
        g = J.T @ r + c.smooth_weight * (x - x_prev) + c.posture_weight * (x - x_map)
        dx, dm = x - x_prev, x - x_map
        over = np.minimum(dist - SAFE_M, 0.0)
        cost = r @ r + c.smooth_weight * (dx @ dx) + c.posture_weight * (dm @ dm) + c.contact_weight * (over @ over)
        return H, g, G, dist, cost

    def _step(self, H, g, G, dist, x) -> np.ndarray:
        """A Gauss-Newton step within the joint limits (variables at a bound the step would push out stay) and
        clear of the contact pairs: pairs that overlap, or that the step would bring within SAFE_M, join the
        problem as stiff springs and the step is solved again (an active set that only grows; a few rounds)."""
        wc = self.config.contact_weight
        on = dist < SAFE_M
        for _ in range(4):
            Hc = H + wc * G[on].T @ G[on]
            gc = g + wc * G[on].T @ (dist[on] - SAFE_M)
            step = self._bounded(Hc, gc, x)
            more = ~on & (dist + G @ step < SAFE_M)
            if not more.any():
                return step
            on |= more
        return step

    def _bounded(self, H, g, x) -> np.ndarray:
        step = -_solve(H, g)
        blocked = ((x <= self.lo + 1e-9) & (step < 0)) | ((x >= self.hi - 1e-9) & (step > 0))
        if blocked.any():
            free = ~blocked
            step[:] = 0.0
            step[free] = -_solve(H[np.ix_(free, free)], g[free])
        return np.clip(x + step, self.lo, self.hi) - x


def _solve(H: np.ndarray, g: np.ndarray) -> np.ndarray:
    """H^-1 g for a symmetric positive definite H (LAPACK's Cholesky solver: a quarter of numpy.linalg.solve's
    call overhead at this size, which is most of its cost)."""
    _, out, info = dposv(H, g)
    return out if info == 0 else np.linalg.solve(H, g)
