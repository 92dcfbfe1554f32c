"""Santaera et al. Algorithm 2: the passive complementary filter run on IMU pairs, estimating each IMU's
orientation relative to its parent IMU directly (the palm's IMU, the root, runs Algorithm 1 against the world).

One step for a child IMU c with parent p and relative orientation r (c's axes -> p's axes):
1. a_p, a_c normalised (step 2); accelerometer trust from Kortier et al. eq. 27: both pair members must agree in
   magnitude, e_m = | |a_c| - |a_p| |, through the ramp of thesis eq. 3.19 (thresholds t1, t2).
2. d = R(r)^T a_p, the parent's measured specific force seen in c's axes (step 3).
3. e = a_c x d (step 5), times the trust.
4. I = I + ki e dt (step 8, with dt and the anti-windup limit as in recorder/fusion/mahony.py).
5. Omega = gyro_c - R(r)^T gyro_p, the rate of c relative to p in c's axes (step 10; eq. 18 writes
   gyro_c - gyro_p, exact only when the two frames are aligned: ``rotate_parent_rate=False`` keeps that form).
6. w = Omega + kp e + I; r = r (x) exp(w dt / 2) (steps 11-13).
Both IMUs feel the same linear acceleration when the hand translates, so unlike gravity alone the pair also
observes the relative heading whenever the hand accelerates (Kortier et al., §Sensor fusion).
``q`` is composed down the tree: q_c = q_p (x) r. ``bias`` holds -I, the bias of the relative rate (a root's:
its Algorithm 1 bias). The maths: ``relative_step`` below (the roots by mahony.py's ``_mahony_step``, the
composition by ``relative_compose``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from recorder import quat
from recorder.fusion.base import Filter, as_mask
from recorder.fusion.gravity import attitude_from_gravity
from recorder.fusion.kernels import _exp, _gain_factor, _mul, _normalize, _rotate
from recorder.fusion.mahony import _mahony_step
from recorder.fusion.registry import register_filter
from recorder.hand.skeleton import JOINT_MAP, PARENTS


def imu_parents(joint_map=JOINT_MAP) -> tuple[int, ...]:
    """Parent IMU of every IMU (-1 for a root): the IMU on its segment's parent segment."""
    where = {s: i for i, s in enumerate(joint_map)}
    return tuple(where.get(PARENTS[s], -1) if s >= 0 else -1 for s in joint_map)


@dataclass
class RelativeSettings:
    kp: float = 0.5
    ki: float = 0.0  # the relative rate's bias changes as the joint moves (gyro_c - R^T gyro_p)
    threshold1: float = 0.1  # Kortier eq. 27 on the pair's magnitude difference, in g
    threshold2: float = 0.2
    root_kp: float = 0.5  # the root's Algorithm 1
    root_ki: float = 0.002
    integral_limit: float = 0.1
    rotate_parent_rate: bool = True


@njit(cache=True)
def relative_step(
    q,
    rel,
    root_q,
    root_bias,
    bias,
    parents,
    order,
    gyro,
    accel,
    dt,
    mask,
    kp,
    ki,
    root_kp,
    root_ki,
    t1,
    t2,
    il,
    rotate_parent,
):
    """recorder/fusion/relative.py (Algorithm 2, roots by Algorithm 1), one sample of every IMU."""
    n = gyro.shape[0]
    for i in range(n):
        p = parents[i]
        if p < 0:
            if mask[i]:
                root_q[i, 0], root_q[i, 1], root_q[i, 2], root_q[i, 3] = _mahony_step(
                    root_q[i, 0],
                    root_q[i, 1],
                    root_q[i, 2],
                    root_q[i, 3],
                    root_bias[i],
                    gyro[i, 0],
                    gyro[i, 1],
                    gyro[i, 2],
                    accel[i, 0],
                    accel[i, 1],
                    accel[i, 2],
                    dt[i],
                    root_kp,
                    root_ki,
                    t1,
                    t2,
                    il,
                )
            continue
        if not (mask[i] and mask[p]):
            continue
        w, x, y, z = rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3]
        cx, cy, cz = accel[i, 0], accel[i, 1], accel[i, 2]
        px, py, pz = accel[p, 0], accel[p, 1], accel[p, 2]
        nc = math.sqrt(cx * cx + cy * cy + cz * cz)
        np_ = math.sqrt(px * px + py * py + pz * pz)
        trust = _gain_factor(1.0 + abs(nc - np_), t1, t2)
        ex = ey = ez = 0.0
        if trust > 0.0 and nc > 0.0 and np_ > 0.0:
            cx, cy, cz = cx / nc, cy / nc, cz / nc
            dx, dy, dz = _rotate(w, -x, -y, -z, px / np_, py / np_, pz / np_)
            ex = trust * (cy * dz - cz * dy)
            ey = trust * (cz * dx - cx * dz)
            ez = trust * (cx * dy - cy * dx)
        h = dt[i]
        if math.sqrt(ex * ex + ey * ey + ez * ez) < il:
            bias[i, 0] -= ki * ex * h
            bias[i, 1] -= ki * ey * h
            bias[i, 2] -= ki * ez * h
        if rotate_parent:
            ox, oy, oz = _rotate(w, -x, -y, -z, gyro[p, 0], gyro[p, 1], gyro[p, 2])
        else:
            ox, oy, oz = gyro[p, 0], gyro[p, 1], gyro[p, 2]
        rw, rx, ry, rz = _exp(
            (gyro[i, 0] - ox + kp * ex - bias[i, 0]) * h,
            (gyro[i, 1] - oy + kp * ey - bias[i, 1]) * h,
            (gyro[i, 2] - oz + kp * ez - bias[i, 2]) * h,
        )
        rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3] = _normalize(*_mul(w, x, y, z, rw, rx, ry, rz))
    relative_compose(q, rel, root_q, root_bias, bias, parents, order)


@njit(cache=True)
def relative_compose(q, rel, root_q, root_bias, bias, parents, order):
    """q down the IMU tree in ``order`` (parents first): a root's own (and its bias), q_c = q_p (x) r_c."""
    for k in range(order.shape[0]):
        i = order[k]
        p = parents[i]
        if p < 0:
            for c in range(4):
                q[i, c] = root_q[i, c]
            for c in range(3):
                bias[i, c] = root_bias[i, c]
        else:
            q[i, 0], q[i, 1], q[i, 2], q[i, 3] = _mul(
                q[p, 0], q[p, 1], q[p, 2], q[p, 3], rel[i, 0], rel[i, 1], rel[i, 2], rel[i, 3]
            )


@njit(cache=True, inline="always")
def step(q, bias, state, gyro, accel, dt, mask, params):
    """The registry's step (recorder/fusion/registry.py): state (rel, root_q, root_bias, parents, order), params
    (kp, ki, root_kp, root_ki, t1, t2, integral_limit, rotate_parent_rate as 1 or 0)."""
    rel, root_q, root_bias, parents, order = state
    p = params
    relative_step(q, rel, root_q, root_bias, bias, parents, order, gyro, accel, dt, mask, p[0], p[1], p[2], p[3],
                  p[4], p[5], p[6], p[7] != 0.0)  # fmt: skip


@register_filter("relative", settings=RelativeSettings, step=step, parent_share=0.0, own_bias=True)
class RelativeFilter(Filter):
    STATE = Filter.STATE + ("rel", "root_q", "root_bias")

    def __init__(self, n: int = 12, settings: RelativeSettings | None = None, parents=None):
        super().__init__(n)
        self.settings = settings or RelativeSettings()
        self.parents = np.array(
            imu_parents()
            if parents is None and n == len(JOINT_MAP)
            else (parents if parents is not None else (-1,) * n),
            np.int64,
        )
        self.order = np.array(_topological(self.parents), np.int64)
        self.child = np.flatnonzero(self.parents >= 0)
        self.rel = np.tile(quat.IDENTITY, (n, 1))  # r of every child (c's axes -> p's axes)
        self.root_q = self.q.copy()  # the roots' Algorithm 1 state
        self.root_bias = np.zeros((n, 3))

    def params(self) -> tuple:
        s = self.settings
        values = (s.kp, s.ki, s.root_kp, s.root_ki, s.threshold1, s.threshold2, s.integral_limit, s.rotate_parent_rate)
        return tuple(float(v) for v in values)

    def kernel_state(self) -> tuple:
        return self.rel, self.root_q, self.root_bias, self.parents, self.order

    def reset(self, accel, mask=None) -> None:
        """Attitude from gravity for the masked IMUs; each pair with a masked member restarts its r from the two."""
        m = as_mask(mask, self.n)
        g = np.where(m[:, None], attitude_from_gravity(np.asarray(accel, float).reshape(self.n, 3)), self.q)
        self.root_q[m] = g[m]
        self.root_bias[m] = 0.0
        self.bias[m] = 0.0
        c = self.child[m[self.child] | m[self.parents[self.child]]]
        self.rel[c] = quat.mul(quat.conj(g[self.parents[c]]), g[c])
        relative_compose(self.q, self.rel, self.root_q, self.root_bias, self.bias, self.parents, self.order)


def _topological(parents) -> list[int]:
    order, done = [], set()
    while len(order) < len(parents):
        before = len(order)
        for i, p in enumerate(parents):
            if i not in done and (p < 0 or p in done):
                order.append(i)
                done.add(i)
        if len(order) == before:
            raise ValueError(f"IMU parents {list(parents)} do not form a tree")
    return order
