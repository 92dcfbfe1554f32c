"""Noise injection while recording (`gloverec record --dart SCALE`): DART, Laskey et al. 2017, "DART: Noise
Injection for Robust Imitation Learning". The action the environment executes is the wearer's (the glove
retargeted) plus noise, so the hand is pushed off the demonstrated path and the wearer's next actions bring it back:
the demonstrations then show the states a learned policy's small errors lead to, labelled with what the wearer meant
there.

The noise is a first-order low-pass filtered Gaussian (an AR(1) process) per action element, started at 0 with
each episode: n[k] = c n[k-1] + sqrt(1 - c^2) s e[k], e[k] ~ N(0, 1), c = exp(-1 / (time_s fps)). Its standard
deviation s is ``scale`` times the element's range in the action space (an actuator's ctrl range, the palm
rotation's +-max angle, a free wrist's workspace bounds in metres: 0.05 of the 0.5 m bounds is 2.5 cm), and it holds
for about ``time_s`` (white noise, as DART's paper draws it, would mostly be filtered out by the position-controlled
hand before it moved it). It is drawn from a generator seeded with the episode's seed (its own stream of it), so an
episode re-recorded from the same seed (`gloverec rerecord`) gets the same noise.
"""

from __future__ import annotations

import math

import numpy as np

# The features a DART recording adds, and a takeover recording too (recorder/record/features.py): the wearer's action
# and the executed one less it. Named outside "observation." and "action", which LeRobot's dataset_to_policy_features
# (lerobot/utils/feature_utils.py) takes for policy inputs and for the action.
EXPERT_ACTION = "expert.action"
EXPERT_OFFSET = "expert.offset"
STREAM = 0xDA27  # the noise's stream of an episode seed (numpy SeedSequence entropy [STREAM, seed])


class Dart:
    """``scale``: the noise's standard deviation as a share of each action element's range (``low``, ``high``);
    ``time_s``: its correlation time (0: white); ``fps``: the frame rate it is drawn at."""

    def __init__(self, scale: float, time_s: float, low, high, fps: float):
        self.scale, self.time_s = scale, time_s
        span = np.asarray(high, float) - np.asarray(low, float)
        self.sigma = scale * np.where(np.isfinite(span), span, 0.0)
        self.keep = math.exp(-1.0 / (time_s * fps)) if time_s > 0 else 0.0
        self.reset(0)

    def reset(self, seed: int) -> None:
        """A new episode: the noise starts at 0, drawn from the episode seed's stream."""
        self.rng = np.random.default_rng([STREAM, seed])
        self.noise = np.zeros_like(self.sigma)

    def perturb(self, intended: np.ndarray) -> np.ndarray:
        """This frame's action to execute: ``intended`` plus the noise, in float32 as the dataset stores actions (so
        that the stored action replays exactly), the environment clipping it to its range."""
        fresh = self.rng.standard_normal(len(self.sigma))
        self.noise = self.keep * self.noise + math.sqrt(1.0 - self.keep**2) * self.sigma * fresh
        return (np.asarray(intended, float) + self.noise).astype(np.float32)

    def summary(self) -> dict:
        return {"scale": self.scale, "time_s": self.time_s}
