"""A toy task from outside the package: close the hand into a fist (docs/envs.md, "Adding a task")."""

import numpy as np

from envs.tasks import HandEnv, register_task
from recorder import quat
from recorder.demonstrator.motion import DemoMotion
from recorder.hand.gestures import GESTURES


class FistDemonstrator:
    def plan(self, env, seed=None):
        rng = np.random.default_rng(seed)
        flat, fist = GESTURES["open"], GESTURES["fist"]
        return DemoMotion([0.0, 0.3, 1.2, 4.0], [flat, flat, fist, fist], rng)


@register_task("toy_fist", demonstrator=FistDemonstrator)
class ToyFistEnv(HandEnv):
    environment_state_names = ("toy.closure",)

    def _base_target(self, t):
        return np.array(self.workspace, float), quat.IDENTITY.copy()

    def _environment_state(self):
        return np.array([self.closure()])

    def closure(self) -> float:
        lo, hi = self.model.actuator_ctrlrange.T
        return float(np.mean((self.actuated_positions() - lo) / (hi - lo)))

    def _evaluate(self):
        closed = self.closure() > 0.5
        return closed, closed and self.config.terminate_on_success, float(closed)

    def instruction(self):
        return "make a fist"
