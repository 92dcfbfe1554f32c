"""Who drives the robot hand in a takeover recording (`gloverec record --policy DIR --takeover`): a trained policy
runs it while the wearer's glove is read as usual, and the wearer takes over when the policy goes wrong (HG-DAgger,
Kelly et al. 2019: the expert watches and intervenes; LeRobot's DAgger rollout records the same ``intervention``
flag).

Each frame both actions exist: the policy's (from the observation) and the wearer's (the glove retargeted). Their
*departure* is the largest over the action's elements of |wearer - policy| as a share of that element's range (0:
the same, 1: opposite ends): the largest, not the mean, because a correction is often one or two fingers (a pinch
with the wrong finger) among twenty joints. Control passes to the wearer

- when the departure has stayed above ``threshold`` for ``hold_s`` (with ``auto``: `--takeover`), or
- at once on the takeover key (t, the line "takeover", the web view's button) or the glove's button,

and back to the policy on the key or the button. After a hand-back the automatic takeover waits until the wearer
has come back within the threshold (a wearer still away from the policy's hand would otherwise take it back at once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

POLICY, WEARER = "policy", "wearer"


@dataclass(frozen=True)
class TakeoverConfig:
    threshold: float = 0.15  # departure: the largest share of an action element's range between the two
    hold_s: float = 0.3  # above the threshold this long before the wearer takes over
    auto: bool = True  # take over on departure (else: the key or the button only)


@dataclass(frozen=True)
class Decision:
    action: np.ndarray  # the action to apply
    intervention: bool  # the wearer's
    departure: float
    policy_action: np.ndarray  # what the policy proposed


class Takeover:
    def __init__(self, config: TakeoverConfig, low, high, fps: float):
        self.config = config
        span = np.asarray(high, float) - np.asarray(low, float)
        self._scale = np.where(np.isfinite(span) & (span > 0), 1.0 / np.where(span > 0, span, 1.0), 0.0)
        self._need = max(1, math.ceil(config.hold_s * fps - 1e-9))  # frames in a row above the threshold
        self.reset()

    def reset(self) -> None:
        """A new episode: the policy drives."""
        self.who = POLICY
        self._above = 0
        self._armed = True
        self.switches: list[tuple[int, str]] = []  # (frame, who took control)
        self._k = 0
        self.by_wearer = 0  # frames the wearer drove

    def toggle(self) -> None:
        """The takeover key or the glove's button: control to the other one, from the next frame decided."""
        self._switch(WEARER if self.who == POLICY else POLICY)
        if self.who == POLICY:
            self._armed = False

    def departure(self, policy_action, wearer_action) -> float:
        d = np.abs(np.asarray(wearer_action, float) - np.asarray(policy_action, float)) * self._scale
        return float(np.max(np.minimum(d, 1.0)))

    def decide(self, policy_action, wearer_action) -> Decision:
        """This frame's action and who gave it."""
        d = self.departure(policy_action, wearer_action)
        above = d > self.config.threshold
        self._above = self._above + 1 if above else 0
        if not above:
            self._armed = True
        if self.who == POLICY and self.config.auto and self._armed and self._above >= self._need:
            self._switch(WEARER)
        self._k += 1
        wearer = self.who == WEARER
        self.by_wearer += wearer
        return Decision(np.asarray(wearer_action if wearer else policy_action, float), wearer, d, policy_action)

    def summary(self) -> dict:
        """The episode's control, for its record: the frames the wearer drove, when each one took it (frame indices)."""
        return {"frames_by_wearer": self.by_wearer, "switches": [{"frame": k, "to": who} for k, who in self.switches],
                "interventions": sum(who == WEARER for _, who in self.switches)}  # fmt: skip

    def _switch(self, who: str) -> None:
        if who != self.who:
            self.who = who
            self.switches.append((self._k, who))
