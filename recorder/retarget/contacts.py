"""Finger-finger geometry of a robot hand, from its MuJoCo model: which collision geoms belong to which finger,
the finger-finger pairs the model itself collides, each fingertip's pad geom, and signed distances between geoms
with their gradients in joint space. The pinch-preserving retargeting (pinch.py) keeps these pairs apart and
closes the pads of a pinch; the retargeting benchmark measures penetration and pinch gaps with the same pairs.

A finger's geoms are those of the bodies on the chain from its fingertip site's body up to the first body shared
with another finger (the palm). Pairs: the model's explicit ``<pair>``s and the geoms whose contype/conaffinity
match, less its ``<exclude>``s, between geoms of different fingers; a pair that already overlaps in the model's
reference pose (two finger bases built into each other) is a mechanical neighbour, not a contact, and is left
out. A hand whose fingers do not collide (glovehand: the hand model has no volumes) has no pairs.
Distances are MuJoCo's (mj_geomDistance: exact for primitives, GJK/EPA for meshes; negative: penetration).
"""

from __future__ import annotations

import mujoco
import numpy as np

DETECT_M = 0.05  # pairs whose bounding spheres are farther apart than this are not measured


class FingerGeoms:
    """``FingerGeoms(model, tip_site_ids)``: finger index per geom (``finger``, -1: not a finger's), the
    finger-finger contact ``pairs`` (k, 2), the ``pads`` (a geom per fingertip, thumb first)."""

    def __init__(self, model: mujoco.MjModel, tip_site_ids):
        self.model = m = model
        self._fromto = np.zeros(6)
        tip_bodies = [int(m.site_bodyid[s]) for s in tip_site_ids]
        chains = []
        for b in tip_bodies:
            chain = []
            while b > 0:
                chain.append(b)
                b = int(m.body_parentid[b])
            chains.append(chain)
        shared = {b for i, c in enumerate(chains) for b in c if any(b in o for j, o in enumerate(chains) if j != i)}
        body_finger = np.full(m.nbody, -1)
        for k, chain in enumerate(chains):
            for b in chain:
                if b not in shared:
                    body_finger[b] = k
        collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.finger = np.where(collides, body_finger[m.geom_bodyid], -1)
        self.pads = np.array([self._pad(s, b) for s, b in zip(tip_site_ids, tip_bodies)])
        self.pairs = self._pairs()
        self._g1, self._g2 = self.pairs[:, 0].copy(), self.pairs[:, 1].copy()
        self._reach = m.geom_rbound[self.pairs].sum(axis=1)  # per pair: the sum of its bounding spheres' radii

    def _pad(self, site: int, body: int) -> int:
        """The collision geom of the fingertip's body nearest its site (-1: none)."""
        m = self.model
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body and self.finger[g] >= 0]
        if not geoms:
            return -1
        return min(geoms, key=lambda g: np.linalg.norm(d.geom_xpos[g] - d.site_xpos[site]))

    def _pairs(self) -> np.ndarray:
        m = self.model
        f = self.finger
        found = set()
        for p in range(m.npair):
            g1, g2 = int(m.pair_geom1[p]), int(m.pair_geom2[p])
            if f[g1] >= 0 and f[g2] >= 0 and f[g1] != f[g2]:
                found.add((min(g1, g2), max(g1, g2)))
        excluded = set(m.exclude_signature.tolist())
        geoms = np.flatnonzero(f >= 0)
        for i, g1 in enumerate(geoms):
            for g2 in geoms[i + 1 :]:
                if f[g1] == f[g2]:
                    continue
                if not (m.geom_contype[g1] & m.geom_conaffinity[g2] or m.geom_contype[g2] & m.geom_conaffinity[g1]):
                    continue
                b1, b2 = sorted((int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])))
                if (b1 << 16) + b2 in excluded:
                    continue
                found.add((int(g1), int(g2)))
        pairs = np.array(sorted(found), int).reshape(-1, 2)
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        rest = np.array([self._distance(d, g1, g2, DETECT_M) for g1, g2 in pairs]).reshape(-1)
        return pairs[rest > 0.0]

    def _distance(self, data, g1: int, g2: int, distmax: float) -> float:
        self._last = mujoco.mj_geomDistance(self.model, data, int(g1), int(g2), distmax, self._fromto)
        return self._last

    def distance(self, data, g1: int, g2: int, distmax: float) -> float:
        """Signed distance between two geoms (``distmax`` where farther); ``gradient`` reuses its witnesses."""
        return self._distance(data, g1, g2, distmax)

    # ------------------------------------------------------------ measuring (after mj_kinematics)
    def near(self, data, within: float) -> np.ndarray:
        """Rows of ``pairs`` whose bounding spheres are within ``within`` of each other (a cheap broad phase)."""
        x = data.geom_xpos
        apart = x[self._g1] - x[self._g2]
        reach = self._reach + within
        return (np.einsum("ij,ij->i", apart, apart) < reach * reach).nonzero()[0]

    def measure(self, data, pairs: np.ndarray, distmax: float) -> tuple[np.ndarray, np.ndarray]:
        """Signed distances (k,) of geom pairs (k, 2) (``distmax`` where farther) and their witness points (k, 6):
        the nearest points of the first geom, then of the second."""
        dist, fromto = np.empty(len(pairs)), np.zeros((len(pairs), 6))
        for i, (g1, g2) in enumerate(pairs.tolist()):
            dist[i] = mujoco.mj_geomDistance(self.model, data, g1, g2, distmax, fromto[i])
        return dist, fromto

    def gradients(self, data, pairs: np.ndarray, dist: np.ndarray, fromto: np.ndarray) -> np.ndarray:
        """Gradients (k, nv) in joint space of the distances ``measure`` returned for ``pairs`` (needs
        mj_comPos): the witness points' Jacobians along the line between them."""
        m = self.model
        n = fromto[:, 3:] - fromto[:, :3]
        norm = np.sqrt(np.einsum("ij,ij->i", n, n))
        touching = norm < 1e-9
        if touching.any():  # touching exactly: the line between the geoms' centres
            n[touching] = data.geom_xpos[pairs[touching, 1]] - data.geom_xpos[pairs[touching, 0]]
            norm[touching] = np.linalg.norm(n[touching], axis=1)
        # penetrating: the witness segment points from the second geom's surface into the first
        n *= (np.where(dist < 0.0, -1.0, 1.0) / np.maximum(norm, 1e-12))[:, None]
        jac = np.empty((len(pairs), 2, 3, m.nv))
        bodies = m.geom_bodyid[pairs].tolist()
        for i, (b1, b2) in enumerate(bodies):
            mujoco.mj_jac(m, data, jac[i, 0], None, fromto[i, :3], b1)
            mujoco.mj_jac(m, data, jac[i, 1], None, fromto[i, 3:], b2)
        return np.einsum("ij,ijk->ik", n, jac[:, 1] - jac[:, 0])

    def distances(self, data, within: float = DETECT_M) -> np.ndarray:
        """Signed distance (m) of every pair (``within`` where farther)."""
        out = np.full(len(self.pairs), within)
        near = self.near(data, within)
        out[near] = np.minimum(within, self.measure(data, self.pairs[near], within)[0])
        return out

    def deepest(self, data) -> float:
        """The deepest finger-finger penetration (m, >= 0) in this configuration."""
        d = self.distances(data, 0.01)
        return float(max(0.0, -d.min())) if len(d) else 0.0

    def pad_distance(self, data, k: int) -> float:
        """Signed distance between the thumb's pad and finger k's (m)."""
        return self._distance(data, self.pads[0], self.pads[k], 1.0)

    def gradient(self, data, g1: int, g2: int) -> tuple[float, np.ndarray]:
        """Signed distance between two geoms and its gradient (nv,) in joint space, right after ``distance`` of
        the same pair (its witness points; needs mj_comPos)."""
        grad = self.gradients(data, np.array([[g1, g2]]), np.array([self._last]), self._fromto[None].copy())
        return self._last, grad[0]
