"""`gloverec calibrate --view ...`: each calibration step shown on the human hand, as the emulated wearer does it
(recorder/emulator/procedure.py ProcedureMotion follows the same step timeline), with the step's instruction and
its progress, in any live view (recorder/view). The view's "next" key starts a step where the terminal's Enter
would; "stop" ends the calibration."""

from __future__ import annotations

import threading
import time

import numpy as np

import envs
from recorder.emulator.procedure import ProcedureMotion
from recorder.hand.kinematics import HandSize
from recorder.hand.pose import HandPose
from recorder.view.process import default_view, open_view
from recorder.view.scene import frame_of, layout_of

SHOW_HZ = 30.0


class StepView:
    def __init__(self, view: str | None, glove: str, say, hand_size: HandSize = HandSize(), demo=None,
                 doing: str = "calibrating"):  # fmt: skip
        """``demo``: the moves shown, a motion with ``phases`` (step name -> (start, end) s) and ``at(t)`` (default:
        the calibration procedure); ``doing``: what the status says is done to the glove."""
        if view is None:
            view, hint = default_view()
            if hint:
                say(hint)
        self.env = envs.make("pose", "glovehand").unwrapped  # the stage: its table, the robot hidden
        self.env.reset(seed=0)
        self.glove = glove
        self._lock = threading.Lock()
        self._requests: list[str] = []
        self.view = open_view(view, "pose", "glovehand", layout_of(self.env), hide_robot=True,
                              on_event=self._request, say=say, hand_size=hand_size)  # fmt: skip
        if self.view is not None:
            self.view.wait_ready()
        self.demo = demo if demo is not None else ProcedureMotion("gestures", 0, 200.0, pinch=True, size=hand_size)
        self.doing = doing
        self._last = 0.0

    def show(self, k: int, steps: int, step, seconds: float, waiting: bool = False) -> None:
        """Step ``k`` of ``steps`` at ``seconds`` into it (``waiting``: for the operator to start it)."""
        now = time.monotonic()
        if self.view is None or now - self._last < 1.0 / SHOW_HZ:
            return
        self._last = now
        start, end = self.demo.phases[step.name]
        t = start + (seconds % (end - start))
        m = self.demo.at(np.array([t]))
        pose = HandPose(m.angles[0], m.palm_quat[0], np.ones(len(m.angles[0]), bool))
        doing = "waiting for Enter, the glove's button or F9" if waiting else f"{seconds:.1f} of {step.seconds:g} s"
        status = {"phase": f"{self.doing} {self.glove}", "step": f"{k + 1} of {steps}: {step.text} ({doing})",
                  "keys": ["next", "stop"]}  # fmt: skip
        self.view.publish(frame_of(self.env, status, pose))

    def take(self) -> str | None:
        with self._lock:
            return self._requests.pop(0) if self._requests else None

    def _request(self, name: str) -> None:
        with self._lock:
            self._requests.append(name)

    def close(self) -> None:
        if self.view is not None:
            self.view.close()
        self.env.close()
