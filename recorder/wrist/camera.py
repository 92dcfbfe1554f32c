"""MarkerWrist: the wrist from a printed marker seen by a camera. A thread reads frames with OpenCV
(``cv2.VideoCapture``: a device index, a video file or a stream URL), tracks the marker in each
(recorder/wrist/marker.py) and queues a WristPose per frame: ``t`` is when the frame was read, so the latency
reported is the tracking's; a frame without the marker repeats the last pose with ``tracked`` false. A video file
plays at its own frame rate, as a camera would deliver it, and the source is ``finished`` at its end; unpaced
(``paced=False``: a recording faster than real time) it is read as fast as it decodes and each pose's ``t`` is its
frame's time in the video."""

from __future__ import annotations

import time
from collections import deque

import cv2
import numpy as np

from recorder import GloverecError
from recorder.wrist.base import WristSource
from recorder.wrist.format import WristPose
from recorder.wrist.marker import CameraModel, MarkerSpec, MarkerTracker


class MarkerWrist(WristSource):
    def __init__(self, camera: str, model: CameraModel, marker: MarkerSpec | None = None, paced: bool = True):
        super().__init__()
        self.paced = paced
        self.address = camera
        self.name = f"marker:{camera}"
        self.model, self.marker = model, marker or MarkerSpec()
        self.frames = 0
        self._capture = None

    def _open(self) -> tuple:
        source = int(self.address) if self.address.isdigit() else self.address
        capture = cv2.VideoCapture(source)
        if not capture.isOpened():
            raise GloverecError(f"cannot open the camera or video {self.address!r} (a device index, file or URL)")
        ok, first = capture.read()
        if not ok:
            capture.release()
            raise GloverecError(f"no frames from {self.address!r}: is it a video?")
        h, w = first.shape[:2]
        if (w, h) != (self.model.width, self.model.height):
            capture.release()
            raise GloverecError(f"{self.address!r} gives {w}x{h} frames, the camera calibration is for "
                                f"{self.model.width}x{self.model.height}")  # fmt: skip
        self._capture = capture
        fps = capture.get(cv2.CAP_PROP_FPS)
        self._period = 1.0 / fps if not isinstance(source, int) and fps and fps > 0 else 0.0
        self.video_clock = bool(self._period) and not self.paced
        if self.video_clock:
            self._queue = deque()  # all of the file's poses wait for the loop (a few hundred bytes each)
        return (first,)

    def _run(self, frame) -> None:
        tracker = MarkerTracker(self.marker, self.model)
        last, start = None, time.monotonic()
        while frame is not None and not self._stop.is_set():
            read_at = self.frames * self._period if self.video_clock else time.time()
            found = tracker.track(frame[..., ::-1])  # OpenCV's BGR
            if found is not None:
                last = (found.position, found.quat, found.alternative, found.errors_px)
            if last is not None:
                self._queue.append((WristPose(self.frames, read_at, np.array(last[0]), np.array(last[1]),
                                              found is not None, *last[2:]), time.time()))  # fmt: skip
            self.frames += 1
            if self._period and not self.video_clock:  # a file plays at its frame rate
                time.sleep(max(0.0, start + self.frames * self._period - time.monotonic()))
            ok, frame = self._capture.read()
            frame = frame if ok else None
        self.finished = True

    def _release(self) -> None:
        if self._capture is not None:
            self._capture.release()
