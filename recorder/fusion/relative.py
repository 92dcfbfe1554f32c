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
its Algorithm 1 bias). The maths: recorder/fusion/kernels.py ``relative_step`` (the roots by ``_mahony_step``, the
composition by ``relative_compose``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder import quat
from recorder.fusion import kernels
from recorder.fusion.base import Filter, as_mask
from recorder.fusion.gravity import attitude_from_gravity
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


class RelativeFilter(Filter):
    name = "relative"
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
        return tuple(float(v) for v in (s.kp, s.ki, s.root_kp, s.root_ki, s.threshold1, s.threshold2, s.integral_limit))

    def reset(self, accel, mask=None) -> None:
        """Attitude from gravity for the masked IMUs; each pair with a masked member restarts its r from the two."""
        m = as_mask(mask, self.n)
        g = np.where(m[:, None], attitude_from_gravity(np.asarray(accel, float).reshape(self.n, 3)), self.q)
        self.root_q[m] = g[m]
        self.root_bias[m] = 0.0
        self.bias[m] = 0.0
        c = self.child[m[self.child] | m[self.parents[self.child]]]
        self.rel[c] = quat.mul(quat.conj(g[self.parents[c]]), g[c])
        kernels.relative_compose(self.q, self.rel, self.root_q, self.root_bias, self.bias, self.parents, self.order)

    def update(self, gyro, accel, dt, mask=None) -> np.ndarray:
        kernels.relative_step(
            self.q,
            self.rel,
            self.root_q,
            self.root_bias,
            self.bias,
            self.parents,
            self.order,
            *self._sample(gyro, accel, dt, mask),
            *self.params(),
            bool(self.settings.rotate_parent_rate),
        )
        return self.q

    def block(self, gyro, accel, dt, mask, out) -> None:
        kernels.relative(
            self.q,
            self.rel,
            self.root_q,
            self.root_bias,
            self.bias,
            self.parents,
            self.order,
            gyro,
            accel,
            dt,
            mask,
            *self.params(),
            bool(self.settings.rotate_parent_rate),
            out,
        )


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
