"""Fingertip-position retargeting by differential inverse kinematics (mink, a QP per iteration).

Five position tasks put the robot's fingertip sites on the scaled human fingertips; a posture task pulls
toward the joint-mapped pose (so the fingers keep the human's style where the tips leave freedom, and the
solution is unique and smooth); couplings are hard equality constraints; joint limits are QP inequalities.
The configuration persists between frames: each frame starts from the last solution (warm start).
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np

from envs.robots.config import IKConfig


class FingertipIK:
    def __init__(self, model: mujoco.MjModel, tip_sites, config: IKConfig, posture_cost: np.ndarray):
        """model: the robot alone, with its couplings as joint equalities. posture_cost: (nv,) per DoF."""
        self.model = model
        self.config = config
        self.configuration = mink.Configuration(model)
        self.tips = [mink.FrameTask(s, "site", position_cost=config.tip_cost, orientation_cost=0.0) for s in tip_sites]
        self.posture = mink.PostureTask(model, cost=posture_cost)
        self.tasks = [*self.tips, self.posture]
        self.constraints = [mink.EqualityConstraintTask(model, cost=1.0)] if model.neq else None
        self.limits = [mink.ConfigurationLimit(model)]
        self._site_ids = np.array([model.site(s).id for s in tip_sites])
        self._started = False

    def reset(self) -> None:
        self._started = False

    def solve(self, targets: np.ndarray, q_posture: np.ndarray) -> tuple[np.ndarray, int]:
        """Joint positions (nq,) putting the tip sites on ``targets`` (5, 3); returns (q, iterations)."""
        conf = self.configuration
        if not self._started:  # first frame: start from the joint-mapped pose
            conf.update(q_posture)
            self._started = True
        self.posture.set_target(q_posture)
        for task, p in zip(self.tips, targets):
            task.set_target(mink.SE3.from_translation(p))
        n = 0
        for n in range(1, self.config.iterations + 1):  # noqa: B007  (n is the iteration count returned)
            v = mink.solve_ik(
                conf,
                self.tasks,
                1.0,
                self.config.solver,
                damping=self.config.damping,
                limits=self.limits,
                constraints=self.constraints,
            )
            conf.integrate_inplace(v, 1.0)
            err = np.linalg.norm(conf.data.site_xpos[self._site_ids] - targets, axis=1)
            if err.max() < self.config.tolerance_m or np.abs(v).max() < 1e-4:
                break
        return conf.q.copy(), n
