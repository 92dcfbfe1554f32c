"""LogWrist (``mcap:FILE``): a session log's tracker poses played back, as the recording's wrist fusion took them
(the ``/wrist/pose`` channel, recorder/log/writer.py), read with the log reader that plays the glove's bytes back.

Paced (the default, and a real-time recording): each pose comes when the fusion took it, at the recorded spacing,
stamped in Unix time with its recorded age, so the latency replays too. Unpaced (``paced=False``: a recording
faster than real time, `gloverec wrist --fast`), every pose is queued at once, stamped with its time since the
log's first pose, as a video file read as fast as it decodes is (``video_clock``: WristTrack puts time 0 at the
loop's first frame). When the glove is this same log played back (`gloverec rerecord`), the poses keep their
times on the glove's clock (``video_t0`` = 0), so the fusion takes each at the loop time it took it when recorded.
"""

from __future__ import annotations

import json
import time
from collections import deque
from dataclasses import replace
from pathlib import Path

import numpy as np

from recorder import GloverecError
from recorder.log.playback import LogReader
from recorder.log.writer import WRIST_TOPIC
from recorder.wrist.base import WristSource
from recorder.wrist.format import WristPose


def _array(obj: dict, axes: str) -> np.ndarray:
    return np.array([np.nan if obj[a] is None else float(obj[a]) for a in axes])


def _pose(msg: dict) -> tuple[WristPose, float]:
    alt, errors = msg["alternative"], msg["errors_px"]
    alternative = None if alt is None else (_array(alt["position"], "xyz"), _array(alt["quat"], "wxyz"))
    errors = None if errors is None else tuple(map(float, errors))
    pose = WristPose(int(msg["seq"]), float(msg["t"]), _array(msg["position"], "xyz"), _array(msg["quat"], "wxyz"),
                     bool(msg["tracked"]), alternative, errors)  # fmt: skip
    return pose, float(msg["taken_t"])


def read_wrist(path: str) -> tuple[dict, list[tuple[WristPose, float]]]:
    """(the /wrist/pose channel's metadata, [(pose, taken_t)] in the order the fusion took them); a missing
    file, a file that is not a gloverec log, and a log without wrist poses are one-line GloverecErrors."""
    reader = LogReader(path)
    try:
        messages = [m.data for m in reader.messages(WRIST_TOPIC)]
    except OSError as exc:
        raise GloverecError(f"cannot read {path}: {exc.strerror or exc}") from None
    channel = next((c for c in reader.channels.values() if c.topic == WRIST_TOPIC), None)
    if channel is None:
        raise GloverecError(f"{path} has no {WRIST_TOPIC} channel: it was recorded without a tracker (--wrist)")
    try:
        poses = [_pose(json.loads(data)) for data in messages]
    except (ValueError, KeyError, TypeError) as exc:
        raise GloverecError(f"{path}: a {WRIST_TOPIC} message is not a wrist pose ({exc!r})") from None
    if not poses:
        raise GloverecError(f"{path} holds no wrist poses ({WRIST_TOPIC} is empty)")
    return dict(channel.metadata), poses


def same_log(path: str, glove) -> bool:
    """Whether ``glove`` (a GloveConfig, or None) is the log at ``path`` played back."""
    return glove is not None and glove.kind == "mcap" and Path(glove.address).resolve() == Path(path).resolve()


class LogWrist(WristSource):
    def __init__(self, path: str, paced: bool = True, glove_clock: bool = False):
        super().__init__()
        self.path, self.paced = str(path), paced
        self.name = f"mcap:{self.path}"
        self.video_clock = not paced
        self.video_t0 = 0.0 if glove_clock and not paced else None  # the loop's clock is the log's glove's
        meta, self._poses = read_wrist(self.path)  # read now: a bad log is one line before anything starts
        try:  # the recording's wrist fusion's (FusionConfig.latency_s): its tracker's, capture to stamp
            self.latency_s = float(meta.get("latency_s", 0.0))
        except ValueError:
            raise GloverecError(f"{self.path}: bad {WRIST_TOPIC} latency_s {meta['latency_s']!r}") from None
        try:  # the marker's mounting the recording's fusion used (flat, for a log from before it was kept)
            self.marker_in_palm = np.asarray(json.loads(meta.get("marker_in_palm", "[1, 0, 0, 0]")), float)
            if self.marker_in_palm.shape != (4,) or abs(np.linalg.norm(self.marker_in_palm) - 1.0) > 0.01:
                raise ValueError
        except (ValueError, TypeError):
            raise GloverecError(f"{self.path}: bad {WRIST_TOPIC} marker_in_palm {meta['marker_in_palm']!r}") from None

    def _open(self) -> tuple:
        if self.video_clock:
            self._queue = deque()  # all of the log's poses wait for the loop
        return (self._poses,)

    def _run(self, poses) -> None:
        start, unix = time.monotonic(), time.time()
        first = poses[0][1]  # when the fusion took the first pose
        origin = 0.0 if self.video_t0 is not None else poses[0][0].t
        for pose, taken in poses:
            if self._stop.is_set():
                break
            if self.paced:
                self._stop.wait(max(0.0, start + (taken - first) - time.monotonic()))
                pose = replace(pose, t=unix + (pose.t - first))  # its recorded age kept
            else:
                pose = replace(pose, t=pose.t - origin)
            self._queue.append((pose, time.time()))
        self.finished = True
