"""Wearer postures that put a robot's fingertips where a task needs them, for the tasks' scripted demonstrators and
their scene layouts (the pinch's gap, the keys under the fingertips, the knob's grip).

A posture is searched in the wearer's joint space (20 angles, within the human limits) and mapped by the robot's
joint map (configs/robots), as an operator who watches the robot hand adjusts their own: the robot's fingertips
are what count, and a human posture does not close every robot's the same way. The search is SciPy's L-BFGS-B
over a few named joints (degrees), the others held where ``base`` has them.
"""

from __future__ import annotations

from functools import lru_cache

import mujoco
import numpy as np

from recorder.hand.kinematics import JOINTS, LIMITS, interpolate_dip


@lru_cache(maxsize=8)
def retargeter(robot: str):
    """A joint-map Retargeter for ``robot`` (its MuJoCo model once more: for the tasks' layouts only)."""
    from recorder.retarget.retargeter import (
        Retargeter,  # a cycle: the retargeter loads envs, whose package imports the tasks
    )

    return Retargeter(robot, "joint", base_rotation=False)


def posture(base, joints, degrees) -> np.ndarray:
    """``base`` (20,) rad with ``joints`` (names) set to ``degrees``, clipped to the human limits, DIPs following."""
    a = np.array(base, float, copy=True)
    for name, v in zip(joints, degrees):
        a[JOINTS.index(name)] = np.radians(v)
    return interpolate_dip(np.clip(a, LIMITS[:, 0], LIMITS[:, 1]))


def bounds(joints) -> list[tuple[float, float]]:
    """The human limits of ``joints``, degrees."""
    return [tuple(np.degrees(LIMITS[JOINTS.index(n)])) for n in joints]


def robot_tips(robot: str, angles) -> np.ndarray:
    """The robot's fingertips (n, 3), palm frame, m, thumb first, when the wearer's joints are ``angles``."""
    r = retargeter(robot)
    return r.robot_tips(r.qpos(r.joint_map(angles)))


@lru_cache(maxsize=16)
def _pad_geoms(robot: str, finger: str) -> tuple[int, ...]:
    """The collision geoms of ``finger``'s distal segment (the body of its tip site)."""
    r = retargeter(robot)
    m = r.model
    body = m.site_bodyid[r.robot.tip_site_ids[r.fingers.index(finger)]]
    return tuple(g for g in range(m.ngeom) if m.geom_bodyid[g] == body and (m.geom_contype[g] or m.geom_conaffinity[g]))


def pad_gap(robot: str, a: str, b: str) -> tuple[float, np.ndarray, np.ndarray]:
    """(the distance between fingers ``a``'s and ``b``'s distal segments' surfaces (m; negative: overlapping), the
    midpoint of their nearest points (3, m, palm frame), the unit vector from ``a``'s nearest point to ``b``'s) at the
    robot's pose now (after ``robot_tips``)."""
    r = retargeter(robot)
    m, d = r.model, r.data
    best, mid, line = np.inf, None, None
    fromto = np.zeros(6)
    for ga in _pad_geoms(robot, a):
        for gb in _pad_geoms(robot, b):
            dist = mujoco.mj_geomDistance(m, d, ga, gb, 0.3, fromto)
            if dist < best:
                best, mid, line = dist, (fromto[:3] + fromto[3:]) / 2, fromto[3:] - fromto[:3]
    n = np.linalg.norm(line)
    return float(best), mid, (line / n if n > 1e-9 else line) * np.sign(best if best != 0 else 1.0)


def pad_bottom(robot: str, finger: str) -> float:
    """The lowest point of ``finger``'s distal segment (m, palm frame z: dorsal up, so palm down it is the height
    above whatever the pads must clear) at the robot's pose now (after ``robot_tips``): exact for MuJoCo's convex
    primitives and meshes (a mesh's vertices), where a bounding box would add millimetres at a slant."""
    r = retargeter(robot)
    m, d = r.model, r.data
    lowest = np.inf
    for g in _pad_geoms(robot, finger):
        kind, size, c = m.geom_type[g], m.geom_size[g], d.geom_xpos[g]
        up = d.geom_xmat[g].reshape(3, 3)[2]  # the geom's axes' palm-frame z components
        if kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            first = m.mesh_vertadr[mesh]
            reach = -np.min(m.mesh_vert[first : first + m.mesh_vertnum[mesh]] @ up)
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            reach = size[0]
        elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            reach = abs(up[2]) * size[1] + size[0]
        elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            reach = abs(up[2]) * size[1] + size[0] * np.sqrt(max(0.0, 1.0 - up[2] ** 2))
        elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
            reach = np.linalg.norm(size * up)
        else:  # a box
            reach = np.abs(up) @ size
        lowest = min(lowest, c[2] - reach)
    return float(lowest)


def search(robot: str, base, joints, start, cost, maxiter: int = 300) -> np.ndarray:
    """The values (degrees) of ``joints`` that minimise ``cost(tips)`` (tips: robot fingertips (n, 3), palm frame,
    m; the robot is left at that pose, for ``pad_gap``), from ``start``, within the human limits; a small pull
    towards ``start`` settles flat directions."""
    start = np.asarray(start, float)

    def total(p):
        return 1e4 * cost(robot_tips(robot, posture(base, joints, p))) + 1e-5 * np.sum((p - start) ** 2)

    from scipy.optimize import minimize  # 0.5 s of imports: when a posture is solved, not when tasks load

    return minimize(total, start, method="L-BFGS-B", bounds=bounds(joints), options={"maxiter": maxiter}).x
