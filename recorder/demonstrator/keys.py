"""HandKeys demonstrator: the hand settles over the keys, fingers curved; then for each key of the sequence, a human
reaction time after it lights, its finger presses it (minimum jerk, a little past the key's travel: the key's stop
holds the finger), holds it a moment and lets go, before the next finger moves. The press postures are the robot's
(envs.tasks.hand_keys.press_angles): the operator watches the robot's fingertip. The next key lights when the
pressed key passes its threshold, which the plan predicts from its own press (a person reacts to the light they
see; a plan made at reset does the same on the predicted time). Varies timing, speed and depth between demos."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.tasks.hand_keys import press_angles, rest_angles
from recorder.demonstrator.motion import DemoMotion
from recorder.hand.gestures import GESTURES
from recorder.hand.motion import min_jerk

_S = np.linspace(0.0, 1.0, 201)


@dataclass(frozen=True)
class KeysDemoConfig:
    settle_s: tuple = (0.4, 0.6)  # from the open hand to the curved fingers over the keys
    reaction_s: tuple = (0.2, 0.3)  # visual reaction to a key lighting
    press_s: tuple = (0.15, 0.25)  # down
    hold_s: tuple = (0.05, 0.12)
    release_s: tuple = (0.15, 0.25)
    depth: tuple = (2.0, 2.6)  # how far the fingertip aims below the key top, in key travels
    pose_noise_deg: float = 1.0
    palm_deg: float = 1.0
    rate_hz: float = 200.0


class KeysDemonstrator:
    task = "keys"

    def __init__(self, config: KeysDemoConfig = KeysDemoConfig()):
        self.config = config

    def plan(self, env, seed: int | None = None, mistake: tuple[str, int] | None = None) -> DemoMotion:
        """``mistake``: (kind, k) a wearer's mistake at the k-th press: "too light" (the key stops short of its
        threshold; the wearer goes on to the next, unlit), "wrong finger" (the neighbouring finger presses its own key
        instead)."""
        env = env.unwrapped
        c = self.config
        rng = np.random.default_rng(seed)
        robot, cfg = env.robot.config.name, env.config
        noise = np.clip(rng.normal(0, 1, len(GESTURES["open"])), -2, 2) * np.radians(c.pose_noise_deg)
        rest = rest_angles() + noise
        times, poses = [0.0, rng.uniform(0.05, 0.2)], [GESTURES["open"], GESTURES["open"]]
        times.append(times[-1] + rng.uniform(*c.settle_s))
        poses.append(rest)
        lit_at = cfg.first_key_s
        free_at = times[-1]
        for k, finger in enumerate(env.sequence):
            wrong = mistake is not None and mistake[1] == k
            if wrong and mistake[0] == "wrong finger":
                fingers = list(env.layout)
                finger = fingers[(fingers.index(finger) + 1) % len(fingers)]
            key = env.layout[finger]
            depth = key.contact_drop + rng.uniform(*c.depth) * cfg.travel_m
            if wrong and mistake[0] == "too light":
                depth = key.contact_drop + 0.3 * cfg.threshold * cfg.travel_m
            down = press_angles(robot, finger, round(depth, 4)) + noise
            go = max(lit_at + rng.uniform(*c.reaction_s), free_at + 0.02)
            t_down = go + rng.uniform(*c.press_s)
            # the key passes its threshold part way down (the fingertip's path is minimum jerk): the next lights then
            part = (key.contact_drop + cfg.threshold * cfg.travel_m) / depth
            lit_at = go + (t_down - go) * float(np.interp(part, min_jerk(_S), _S))
            t_up = t_down + rng.uniform(*c.hold_s)
            free_at = t_up + rng.uniform(*c.release_s)
            times += [go, t_down, t_up, free_at]
            poses += [rest, down, down, rest]
        times.append(max(free_at, cfg.episode_s) + 1.0)
        poses.append(rest)
        return DemoMotion(times, poses, rng, c.rate_hz, palm_deg=c.palm_deg)
