"""Scene perturbations a policy's demonstrations never showed, for `gloverec eval --perturb`: the light, the task
objects' colour, the cameras moved a few degrees. Applied to the compiled model before the task reads it (its
objects' colours are the perturbed ones from the first reset on); the physics is untouched, so a perturbed
episode is the plain one seen differently.

    light   every light dimmer and warmer (diffuse x LIGHT_TINT), the headlight's ambient x 0.6
    colour  every task object (a geom neither the robot's nor the floor) with its red, green and blue rotated
    camera  every camera orbited CAMERA_DEG about the vertical through the point it looks at (the workspace)
"""

from __future__ import annotations

import mujoco
import numpy as np

PERTURBATIONS = ("light", "colour", "camera")
LIGHT_TINT = np.array([0.55, 0.45, 0.35])
CAMERA_DEG = 5.0


def perturb(model: mujoco.MjModel, names, robot_root: int, workspace) -> None:
    """Apply the perturbations ``names`` (a subset of PERTURBATIONS) to ``model`` in place."""
    if "light" in names:
        model.light_diffuse[:] *= LIGHT_TINT
        model.vis.headlight.ambient[:] = np.asarray(model.vis.headlight.ambient) * 0.6
    if "colour" in names:
        floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        for g in range(model.ngeom):
            if g != floor and model.body_rootid[model.geom_bodyid[g]] != robot_root:
                model.geom_rgba[g, :3] = np.roll(model.geom_rgba[g, :3], 1)
    if "camera" in names:
        a = np.radians(CAMERA_DEG)
        turn = np.array([np.cos(a / 2), 0.0, 0.0, np.sin(a / 2)])
        rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
        ws = np.asarray(workspace, float)
        for c in range(model.ncam):
            model.cam_pos[c] = ws + rot @ (model.cam_pos[c] - ws)
            q = np.empty(4)
            mujoco.mju_mulQuat(q, turn, model.cam_quat[c])
            model.cam_quat[c] = q
