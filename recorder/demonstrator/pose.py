"""HandPose demonstrator: from the starting open hand, react, then move to the goal gesture in one
minimum-jerk reach and hold it. Varies reaction time, movement time and the exact pose between demos."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from recorder.demonstrator.motion import DemoMotion
from recorder.hand.gestures import GESTURES


@dataclass(frozen=True)
class PoseDemoConfig:
    reaction_s: tuple = (0.15, 0.45)
    move_s: tuple = (0.6, 1.1)
    pose_noise_deg: float = 1.5  # per joint, clipped at 2 sigma
    rate_hz: float = 200.0


class PoseDemonstrator:
    task = "pose"

    def __init__(self, config: PoseDemoConfig = PoseDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None) -> DemoMotion:
        """A demonstration for the episode ``env`` (a HandPoseEnv, reset) is in now."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        noise = np.clip(rng.normal(0, 1, len(env.goal_angles)), -2, 2) * np.radians(c.pose_noise_deg)
        goal = env.goal_angles + noise
        t0 = rng.uniform(*c.reaction_s)
        t1 = t0 + rng.uniform(*c.move_s)
        start = GESTURES["open"]
        end = max(t1, env.config.episode_s) + 1.0
        return DemoMotion([0.0, t0, t1, end], [start, start, goal, goal], rng, c.rate_hz)
