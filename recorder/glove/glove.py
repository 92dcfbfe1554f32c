"""Glove: an open glove as every command uses it. ``make_glove(config)`` builds it (``open_glove`` opens it too):
the link of the glove source GloveConfig names (the built-in emulator on a pseudo-terminal read through the real
serial path, serial, UDP, an MCAP log played back, a plugin's); host fusion (recorder/fusion/session.py
SessionFusion: every frame goes through it, so raw, pose, compact and legacy JSON gloves all yield HandPoses); the
pose track on the loop's clock; and the glove's button presses.

The loop's clock ("glove time") is the host's monotonic clock in real time (device times are mapped onto it),
and the glove's own device clock faster than real time (the loop then advances as fast as frames arrive).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from recorder.fusion.session import SessionFusion
from recorder.glove.config import GloveConfig, glove_source
from recorder.glove.track import FrameRate, PoseTrack
from recorder.hand.pose import HandPose
from recorder.link.base import GloveSource
from recorder.log.playback import log_calibration
from recorder.protocol import EventCode, EventFrame

RATE_WINDOW_S = 1.0  # the glove's rate: frames over this much of its own time (robust to bursts and resets)


@dataclass(frozen=True)
class GloveHealth:
    """How the glove is doing, for views and status lines: ``rate_hz`` frames per second of glove time over the
    last RATE_WINDOW_S (every frame, poses or not: a glove resting before host fusion starts is sending),
    ``frames`` and ``poses`` taken so far, and what its first pose waits for (None once there is one)."""

    up: bool
    rate_hz: float
    frames: int
    poses: int
    waiting: str | None = None


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def link_for(config: GloveConfig, *, realtime: bool = True, **options) -> GloveSource:
    """The (unopened) link to the glove, from its registered source (recorder/glove/config.py); ``realtime`` paces
    log playback at recorded speed and the emulator by the host clock."""
    options.setdefault("protocol", config.protocol)
    return glove_source(config.kind).link(config, realtime, **options)


class Glove:
    """See the module docstring. ``fast``: faster than real time (log playback unpaced, the emulator on its own
    clock); ``motion``: the emulator's wearer when the config leaves it open; ``fusion``: a SessionFusion
    (default: the glove's saved calibration, or for a log the calibration it was recorded with); ``say``: where
    lines for the person go (stderr); ``warm_fusion``: compile host fusion's kernels at ``open`` when the glove
    may send raw frames (False for commands that read frames without fusing them as they come);
    ``link_options``: for the source's opener (the emulator's ``wearer``: recorder/emulator/source.py)."""

    def __init__(
        self,
        config: GloveConfig,
        *,
        fast: bool = False,
        motion: str = "gestures",
        fusion: SessionFusion | None = None,
        calibration_dir=None,
        say=_say,
        warm_fusion: bool = True,
        **link_options,
    ):
        self.config = config = replace(config, motion=config.motion or motion)  # the emulator's wearer, settled
        self.fast = fast
        self.say = say  # lines for the person (host fusion being prepared)
        self.warm_fusion = warm_fusion  # compile host fusion at open (commands that fuse frames as they come)
        self.fusion = fusion if fusion is not None else _fusion_for(config, calibration_dir)
        self.source = link_for(config, realtime=not fast, **link_options)
        if self.source.expects:  # the glove is known before it sends: a bad calibration file stops the session now
            try:
                self.fusion.expect(**self.source.expects)
            except BaseException:
                self.source.close()  # the emulator's port
                raise
        self.before_wait: Callable[[float], None] | None = None  # see wait_past
        self.name = str(config)
        self.track = PoseTrack()
        self.buttons: list[float] = []  # glove times of button presses not yet taken
        self.frames = 0  # frames that carried a hand pose
        self.received = 0  # every frame taken
        self._rate = FrameRate(RATE_WINDOW_S)

    # ------------------------------------------------------------ lifecycle
    def open(self) -> Glove:
        self.source.check()  # a missing port: one line at once, not after host fusion's warm-up
        if self.warm_fusion and self._may_fuse():  # before the link opens: no raw frame waits for a compiler
            self.fusion.warm_up(self.say)
        self.source.open()
        return self

    def close(self) -> None:
        self.source.close()

    def _may_fuse(self) -> bool:
        """Whether this glove may send raw frames for host fusion: an emulator in raw mode, a device (its mode is
        the glove's), a log recorded with host fusion."""
        if self.fusion.host is not None:  # known already (the emulator, a log's record)
            return bool(self.fusion.host)
        return self.source.expects is None  # {}: frames read as they come (the emulator calibrating)

    def __enter__(self) -> Glove:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ frames in
    def read(self, timeout: float | None = None):
        """The next frame as it came (no fusion, no track): what a command that needs the frames themselves
        takes (calibration, monitoring)."""
        return self.source.read(timeout)

    def time_of(self, frame) -> float:
        if frame.t_us < 0:  # legacy JSON: no device clock
            return frame.rx_ns * 1e-9
        if self.fast:
            return self.source.clock.unwrap(frame.t_us, frame.rx_ns)
        return self.source.host_time_s(frame)

    def poll(self, timeout: float = 0.0, until: float | None = None) -> int:
        """Take frames that have arrived (waiting up to ``timeout`` for the first); returns how many.

        Real time: everything queued. Fast: one frame at a time and only until the track reaches ``until``
        (default: one more frame), so the track never skips past the frame times the loop still needs."""
        n = 0
        if not self.fast:
            first = self.source.read(timeout) if timeout > 0 else None
            for f in ([first] if first is not None else []) + self.source.drain():
                self._take(f)
                n += 1
            return n
        while True:
            f = self.source.read(timeout if n == 0 else 0.0)
            if f is None:
                return n
            self._take(f)
            n += 1
            newest = self.track.newest_s
            if until is None or (newest is not None and newest >= until):
                return n

    def latest(self, wait_s: float = 0.0) -> HandPose | None:
        """The newest hand pose after taking what has arrived (waiting up to ``wait_s`` for a first one)."""
        end = time.monotonic() + wait_s
        self.poll()
        while self.track.newest is None and time.monotonic() < end and not self.finished:
            self.poll(timeout=0.05)
        return self.track.newest

    def reset_pose(self) -> None:
        """Re-take host fusion's reference pose (the reset key); the glove's button does it through the frames."""
        self.fusion.request_reset()

    def _take(self, f) -> None:
        t = self.time_of(f)
        self.received += 1
        self._rate.add(t)
        started = self.fusion.started
        pose = self.fusion.process(f)  # every frame: ids, the button, raw frames fused
        if self.fusion.started and not started and self.fusion.fusion.start_rested is False:
            self.say(
                "the hand moved while host fusion started, so its reference pose may be off: hold the hand flat "
                "and zero it (z in the terminal, the view's zero, or the glove's button)"
            )
        if pose is not None:
            self.frames += 1
            self.track.push(t, pose)
        elif isinstance(f, EventFrame) and f.code == EventCode.BUTTON:
            self.buttons.append(t)

    # ------------------------------------------------------------ health
    def rate_hz(self, default: float = 0.0) -> float:
        """Frames per second of glove time over the last RATE_WINDOW_S (``default`` before two frames)."""
        return self._rate.hz(default)

    def waiting_for(self) -> str | None:
        """What the glove's first hand pose waits for, in words for the person; None once there is one."""
        if self.track.newest_s is not None:
            return None
        if not self.connected:
            return f"{self.name} to come back (its port is gone)"
        if self.received == 0:
            return f"frames from {self.name} (is it connected and sending?)"
        if self.fusion.started:
            return "host fusion's first pose"  # the frame that started it gave none: the next one will
        return self.fusion.waiting or f"a hand pose: {self.name} sends frames without one (status, events)"

    def counters(self) -> dict:
        """What the link counted so far: sequence ``gaps``, rejected frames (``errors``), ``queue_drops`` (frames a
        slow reader lost); differences of two calls are an episode's."""
        decode = self.source.decoder.stats.as_dict()
        return {"gaps": decode["gaps"], "errors": decode["errors"], "queue_drops": self.source.stats().queue_drops}

    def device_time_s(self, pose: HandPose, sample_s: float, t: float) -> float:
        """The glove's device clock (s, unwrapped) at host time ``t``, from ``pose`` sampled at host time
        ``sample_s``; -1 for gloves without a clock (legacy JSON)."""
        if pose.t_us < 0:
            return -1.0
        return self.source.clock.unwrap(pose.t_us, pose.rx_ns) - (sample_s - t)

    def tap(self, listener) -> None:
        """Give ``listener(data, rx_ns, frames)`` every chunk of bytes the link reads (a session log)."""
        self.source.taps.append(listener)

    def health(self) -> GloveHealth:
        return GloveHealth(self.connected, self.rate_hz(), self.received, self.frames, self.waiting_for())

    def take_button(self) -> float | None:
        return self.buttons.pop(0) if self.buttons else None

    def now(self) -> float:
        """The loop's clock: host monotonic time, or (fast) the newest glove sample's time."""
        if not self.fast:
            return time.monotonic()
        return self.track.newest_s if self.track.newest_s is not None else float("-inf")

    def wait_past(self, t: float, timeout_s: float = 5.0) -> bool:
        """Fast mode: take frames until the track has a sample at or after ``t``; False if none comes. First
        ``before_wait(t)``, when set: an emulator performing demonstrations synthesises that far ahead only
        (recorder/demonstrator/performer.py)."""
        end = time.monotonic() + timeout_s
        if self.before_wait is not None:
            self.before_wait(t)
        while self.track.newest_s is None or self.track.newest_s < t:
            if self.poll(timeout=0.05, until=t) == 0 and (self.source.finished or time.monotonic() > end):
                return False
        return True

    @property
    def connected(self) -> bool:
        return self.source.connected

    @property
    def finished(self) -> bool:
        return self.source.finished


def _fusion_for(config: GloveConfig, calibration_dir=None) -> SessionFusion:
    """Host fusion for the glove: its saved calibration ($GLOVEREC_CALIBRATION_DIR or datasets/calibration), or
    for a log (`rerecord`) the calibration it was recorded with."""
    if config.kind == "mcap":
        record = log_calibration(config.address)
        if record is not None:
            return SessionFusion.from_record(record, str(config))
    return SessionFusion(calibration_dir)


def make_glove(config: GloveConfig | str, **options) -> Glove:
    """The glove ``config`` names, not open yet (the emulator's port exists already); options as Glove's."""
    return Glove(GloveConfig.parse(config), **options)


def open_glove(config: GloveConfig | str, **options) -> Glove:
    """The glove ``config`` names, open: its link connected, the emulator streaming."""
    return make_glove(config, **options).open()
