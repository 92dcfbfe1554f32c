"""WristTrack: the recording loop's wrist. It brings a wrist source's poses onto the loop's clock, fuses them with
the glove's palm orientation (recorder/wrist/fusion.py) and answers, at each frame, where the palm is in the
robot's world and whether the tracker saw it.

Clocks. A live tracker stamps its poses in Unix time (a camera source: when the frame was read); a pose's time
on the loop's clock is the frame's time less the pose's age, so latency is kept. A video file read faster than
real time (`gloverec record --fast`) stamps frames by their place in the video, and video time 0 is the glove
time of the first frame the loop asks for. ``EmulatedMarker`` renders an emulated wearer's marker (a scripted
demonstration's palm pose) on the loop's own clock: the whole camera path with no webcam.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import replace

from recorder import GloverecError
from recorder.wrist.fusion import MARKER_ON_BACK, FusedWrist, FusionConfig, WristFusion

FIRST_POSE_S = 5.0  # an episode waits this long for a tracked pose to zero on


class EmulatedMarker:
    """A source that renders what a webcam would film of ``truth(t)`` (the palm's (position, quat) in W at the
    loop's time t) at the camera's rate, each frame usable ``latency_s`` after its capture; the default camera's
    marker is mounted on the palm as ``mount`` (recorder/wrist/sources.py emulated_mount). A source on the loop's
    clock: ``until(t)`` makes its poses (recorder/wrist/config.py WristKind)."""

    name = "marker:emulated"
    finished = False

    def __init__(self, truth, camera=None, mount=MARKER_ON_BACK):
        from recorder.wrist.emulated import EmulatedCamera  # OpenCV: loaded only where the wearer is filmed

        self.truth = truth
        self.camera = camera or EmulatedCamera(marker_in_palm=mount)
        self.next_t = None

    @property
    def latency_s(self) -> float:
        """The emulated camera's, capture to stamp (the fusion takes it)."""
        return self.camera.latency_s

    @property
    def true_mount(self):
        """The marker's true mounting on the palm (wxyz): what `gloverec calibrate --wrist` should find."""
        return self.camera.marker_in_palm

    def open(self):
        return self

    def until(self, t: float) -> list:
        """The frames captured up to ``t - latency``, as (pose on the loop's clock) in order."""
        c = self.camera
        self.next_t = t if self.next_t is None else self.next_t
        out = []
        while self.next_t + c.latency_s <= t + 1e-9:
            pose, _ = c.capture(self.next_t, *self.truth(self.next_t))
            out.append(pose)
            self.next_t += 1.0 / c.fps
        return out

    def close(self) -> None:
        self.camera.close()


class WristTrack:
    def __init__(self, source, config: FusionConfig | None = None, marker_in_palm=MARKER_ON_BACK):
        self.source = source
        self.fusion = WristFusion(config, marker_in_palm)  # the marker's mounting: recorder/wrist/mounting.py
        self._pending: deque = deque()
        self._t0 = getattr(source, "video_t0", None)  # video time 0 on the loop's clock (None: the first t asked)
        self.latency_s: list = []  # tracker stamp -> arrival, per live pose
        self._fed: list = []  # (tracker stamp, arrival), Unix s, of the live poses taken since ``applied()``
        self.on_pose = None  # on_pose(pose, t): each pose the fusion takes, at loop time t (the session log)

    @property
    def video_clock(self) -> bool:
        """The source stamps poses with video time (a file read faster than real time; known once open)."""
        return bool(getattr(self.source, "video_clock", False))

    @property
    def name(self) -> str:
        return self.source.name

    def open(self) -> WristTrack:
        self.source.open()
        return self

    def close(self) -> None:
        self.source.close()

    def update(self, t: float, palm_quat) -> None:
        """The glove's palm orientation at loop time ``t``, and the tracker's poses up to ``t``."""
        self.fusion.imu(t, palm_quat)
        if hasattr(self.source, "until"):  # a source on the loop's clock (EmulatedMarker): poses up to t
            self._pending.extend((pose, None) for pose in self.source.until(t))
        else:
            self._t0 = t if self._t0 is None else self._t0
            if self.video_clock:  # a file read faster than real time: wait for its frames to come up to t
                deadline = time.monotonic() + 1.0
                while not self.source.finished and self._behind(t) and time.monotonic() < deadline:
                    self._take(t)
                    time.sleep(0.001)
            self._take(t)
        while self._pending and self._pending[0][0].t <= t + 1e-9:
            pose, stamps = self._pending.popleft()
            self.fusion.tracker(pose)
            if stamps is not None:
                self._fed.append(stamps)
            if self.on_pose is not None:
                self.on_pose(pose, t)

    def _behind(self, t: float) -> bool:
        return not self._pending or self._pending[-1][0].t < t

    def _take(self, t: float) -> None:
        now = time.time()
        for pose, arrival in self.source.take():
            if self.video_clock:
                self._pending.append((replace(pose, t=self._t0 + pose.t), None))
            else:
                self.latency_s.append(arrival - pose.t)
                self._pending.append((replace(pose, t=t - (now - pose.t)), (pose.t, arrival)))

    def applied(self) -> list:
        """For each live pose the fusion took since the last call, now that the target it went into is applied
        (the recording loop calls this after stepping the robot): (the tracker's own delay, its stamp to its
        arrival: a camera source's detection; the whole delay, its stamp to now), s."""
        now = time.time()
        out = [(arrival - stamp, now - stamp) for stamp, arrival in self._fed]
        self._fed.clear()
        return out

    def zero(self, t: float, start, palm_quat, wait=None) -> None:
        """Zero the mapping at loop time ``t`` (the palm in the nominal pose at the robot's ``start``); without a
        tracked pose yet, call ``wait()`` (which moves the loop's time on and returns it) for up to FIRST_POSE_S,
        then one-line GloverecError."""
        deadline = time.monotonic() + FIRST_POSE_S
        self.update(t, palm_quat)
        while not self.fusion.zero(t, start):
            ended = getattr(self.source, "finished", False) and not self._pending  # nothing more will come
            if wait is None or time.monotonic() > deadline or ended:
                raise GloverecError(
                    f"no tracked wrist pose from {self.name} to start the episode on: is the marker in view?"
                )
            t = wait()
            self.update(t, palm_quat)
        self._fed.clear()  # what came while the episode waited for the zero went into no target

    def pose(self, t: float) -> FusedWrist:
        return self.fusion.pose(t)
