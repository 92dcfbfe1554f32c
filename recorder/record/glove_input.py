"""The glove side of the recording loop: a source (or the emulator driven by the scripted demonstrator),
host fusion of raw frames (recorder/fusion/session.py SessionFusion: every frame goes through it), the pose
track on the loop's clock, and the glove's button events.

The loop's clock ("glove time") is the host's monotonic clock when recording in real time (device times are
mapped onto it), and the glove's own device clock when recording faster than real time (the loop then advances
as fast as the frames arrive).
"""

from __future__ import annotations

import threading
import time
from typing import NamedTuple

from recorder import GloverecError
from recorder.link.sources import make_source
from recorder.protocol import EventCode, EventFrame, PoseCompactFrame, PoseFrame, RawFrame
from recorder.record.pose_track import PoseTrack

TRANSITION_S = 0.8  # the emulated hand's move back to a demonstration's start pose
LEAD_S = 0.5  # faster than real time, the emulator runs at most this far ahead of the loop's needs


class Sample(NamedTuple):
    """What the pose track keeps beside each pose."""

    t_us: int  # device time stamp (-1: legacy JSON)
    rx_ns: int  # host receive time
    quality: float | None  # host fusion's disturbance estimate, None without host fusion


class _TakenMotion:
    """The session motion as the emulator takes it, block by block, under a lock that ``demonstrate`` holds too:
    a demonstration then starts after the last block taken, never inside a block being synthesised (which would
    make the hand jump: harmless for poses, a saturated gyro for raw frames)."""

    def __init__(self, motion):
        self.motion = motion
        self.rate_hz = motion.rate_hz
        self.lock = threading.Lock()
        self.taken = 0  # samples the emulator took

    @property
    def taken_s(self) -> float:
        """Session time of the first sample not taken yet."""
        return self.taken / self.rate_hz

    def next_block(self, n: int):
        with self.lock:
            self.taken += n
            return self.motion.next_block(n)


class GloveInput:
    def __init__(
        self, spec: str, fast: bool, *, rate_hz: float = 200.0, mode: str = "pose", seed: int = 0, fusion=None
    ):
        """``fusion``: a SessionFusion (None: raw frames are refused)."""
        self.fast = fast
        self.fusion = fusion
        self.emulator = None
        self.session = None
        self._motion = None
        if spec == "emulator":
            from recorder.demonstrator.session import SessionMotion
            from recorder.emulator.emulator import Emulator
            from recorder.hand.kinematics import interpolate_dip

            self.session = SessionMotion(seed=seed, rate_hz=rate_hz)
            self._motion = _TakenMotion(self.session)
            self.emulator = Emulator(rate_hz, mode, self._motion, seed=seed)
            if fusion is not None:  # the emulated wearer rests in the session's first pose, not the flat hand
                rest = interpolate_dip(self.session.keyframe_angles([0.0]))[0]
                fusion.expect(self.emulator.glove_id, raw=mode == "raw", rest_angles=rest)
            self.emulator.realtime = not fast  # before plug(): its first status frame states the clock
            spec = self.emulator.plug()
        self.source = make_source(spec, realtime=not fast)
        self.spec = spec if self.emulator is None else "emulator"
        self.track = PoseTrack()
        self.buttons: list[float] = []  # glove times of button presses not yet taken
        self.frames = 0

    # ------------------------------------------------------------ lifecycle
    def open(self) -> GloveInput:
        self.source.open()
        if self.emulator is not None:
            if self.fast:
                self.emulator.lead_s = LEAD_S
            self.emulator.start(realtime=not self.fast)
        return self

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.close()
        self.source.close()

    # ------------------------------------------------------------ the demonstrator (emulator only)
    def demonstrate(self, demo, lead_s: float = 0.0) -> None:
        """Have the emulated hand perform ``demo`` next; its glove presses the button as the demo starts."""
        hold = self.fusion.hold_until_s if self.fusion is not None else 0.0  # host fusion starts on a resting hand
        with self._motion.lock:
            start = max(self._motion.taken_s, hold) + TRANSITION_S + lead_s
            self.session.append(demo, start, TRANSITION_S)
        self.emulator.schedule_button(start)

    # ------------------------------------------------------------ frames in
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

    def reset_pose(self) -> None:
        """Re-take host fusion's reference pose (the reset key); the glove's button does it through the frames."""
        if self.fusion is not None:
            self.fusion.request_reset()

    def _take(self, f) -> None:
        fused = self.fusion.process(f) if self.fusion is not None else None  # every frame: ids, button, raw
        if isinstance(f, PoseFrame):
            self.frames += 1
            self.track.push(self.time_of(f), f.quats, Sample(f.t_us, f.rx_ns, None))
        elif isinstance(f, PoseCompactFrame):
            self.frames += 1
            self.track.push(self.time_of(f), f.relative_quats(), Sample(f.t_us, f.rx_ns, None))
        elif isinstance(f, RawFrame):
            if self.fusion is None:
                raise GloverecError("the glove sends raw IMU frames but no host fusion is configured")
            if fused is not None:
                self.frames += 1
                self.track.push(self.time_of(f), fused.quats, Sample(f.t_us, f.rx_ns, fused.quality))
        elif isinstance(f, EventFrame) and f.code == EventCode.BUTTON:
            self.buttons.append(self.time_of(f))

    def take_button(self) -> float | None:
        return self.buttons.pop(0) if self.buttons else None

    def now(self) -> float:
        """The loop's clock: host monotonic time, or (fast) the newest glove sample's time."""
        if not self.fast:
            return time.monotonic()
        return self.track.newest_s if self.track.newest_s is not None else float("-inf")

    def wait_past(self, t: float, timeout_s: float = 5.0) -> bool:
        """Fast mode: take frames until the track has a sample at or after ``t``; False if none comes."""
        end = time.monotonic() + timeout_s
        if self.emulator is not None:  # host fusion shows its first pose after the hand's rest
            hold = self.fusion.hold_until_s if self.fusion is not None and not self.fusion.started else 0.0
            self.emulator.allow(max(self._session_time(t), hold) + LEAD_S)
        while self.track.newest_s is None or self.track.newest_s < t:
            if self.poll(timeout=0.05, until=t) == 0 and (self.source.finished or time.monotonic() > end):
                return False
        return True

    def _session_time(self, t: float) -> float:
        """The emulator's session time of glove time ``t`` (fast: its device clock, unwrapped from t0)."""
        t0 = self.emulator.t0_us
        return t - t0 * 1e-6 if t0 is not None else 0.0

    @property
    def connected(self) -> bool:
        return self.source.connected

    @property
    def finished(self) -> bool:
        return self.source.finished
