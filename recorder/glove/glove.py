"""Glove: an open glove as every command uses it. ``make_glove(config)`` builds it (``open_glove`` opens it too):
the link GloveConfig names (serial, UDP, an MCAP log played back) or the built-in emulator on a pseudo-terminal
read through the real serial path; host fusion (recorder/fusion/session.py SessionFusion: every frame goes
through it, so raw, pose, compact and legacy JSON gloves all yield HandPoses); the pose track on the loop's
clock; and the glove's button presses.

The loop's clock ("glove time") is the host's monotonic clock in real time (device times are mapped onto it),
and the glove's own device clock faster than real time (the loop then advances as fast as frames arrive).
"""

from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass

from recorder import GloverecError
from recorder.demonstrator.session import SessionMotion
from recorder.emulator.emulator import Emulator
from recorder.emulator.procedure import ProcedureMotion
from recorder.fusion.session import SessionFusion
from recorder.glove.config import EMULATOR, GloveConfig, glove_source
from recorder.glove.track import FrameRate, PoseTrack
from recorder.hand.kinematics import interpolate_dip
from recorder.hand.pose import HandPose
from recorder.link.base import GloveSource
from recorder.link.serial_source import SerialSource
from recorder.log.playback import log_calibration
from recorder.protocol import EventCode, EventFrame

TRANSITION_S = 0.8  # the emulated hand's move back to a demonstration's start pose
LEAD_S = 0.5  # faster than real time, the emulator runs at most this far ahead of the loop's needs
WATCHING_LEAD_S = 0.05  # ... or this far, while a demonstrator that watches performs (its corrections come a
# reaction time, 0.1-0.3 s, after what it saw: further ahead, the emulator would have synthesised past them)
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


class _TakenMotion:
    """The session motion as the emulator takes it, block by block, under a lock that ``demonstrate`` holds too:
    a demonstration then starts after the last block taken, never inside a block being synthesised (which would
    make the hand jump: harmless for poses, a saturated gyro for raw frames)."""

    def __init__(self, motion: SessionMotion):
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

    def at(self, t):
        return self.motion.at(t)


def link_for(config: GloveConfig, *, realtime: bool = True, **options) -> GloveSource:
    """The (unopened) link to a glove on a wire or in a log, from its registered source (recorder/glove/config.py);
    ``realtime`` paces log playback at recorded speed."""
    if config.kind == EMULATOR:
        raise GloverecError(f"{config} has no link of its own: open it with open_glove")
    options.setdefault("protocol", config.protocol)
    return glove_source(config.kind).opener(config, realtime, **options)


class Glove:
    """See the module docstring. ``fast``: faster than real time (log playback unpaced, the emulator on its own
    clock); ``motion``: the emulator's wearer when the config leaves it open; ``fusion``: a SessionFusion
    (default: the glove's saved calibration, or for a log the calibration it was recorded with); ``say``: where
    lines for the person go (stderr); ``warm_fusion``: compile host fusion's kernels at ``open`` when the glove
    may send raw frames (False for commands that read frames without fusing them as they come)."""

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
        self.config = config
        self.fast = fast
        self.say = say  # lines for the person (host fusion being prepared)
        self.warm_fusion = warm_fusion  # compile host fusion at open (commands that fuse frames as they come)
        self.fusion = fusion if fusion is not None else _fusion_for(config, calibration_dir)
        self.emulator: Emulator | None = None
        self.session: SessionMotion | None = None  # the scripted demonstrations the emulated wearer performs
        self._motion: _TakenMotion | None = None
        self._demo_start = 0.0  # session time of the demonstration being performed
        self._lead_s = LEAD_S  # how far ahead a fast emulator may synthesise
        self.motion = config.motion or motion
        if config.kind == EMULATOR:
            port = self._plug_emulator(config)
            self.source = SerialSource(port, protocol=config.protocol, **link_options)
            self.source.lossless = fast  # bulk generation: paced by this reader, nothing lost however slow it is
        else:
            self.source = link_for(config, realtime=not fast, **link_options)
        self.name = str(config)
        self.track = PoseTrack()
        self.buttons: list[float] = []  # glove times of button presses not yet taken
        self.frames = 0  # frames that carried a hand pose
        self.received = 0  # every frame taken
        self._rate = FrameRate(RATE_WINDOW_S)

    def _plug_emulator(self, config: GloveConfig) -> str:
        if self.motion == "demonstrations":
            self.session = SessionMotion(seed=config.seed, rate_hz=config.rate_hz)
            self._motion = _TakenMotion(self.session)
            motion = self._motion
            # the emulated wearer rests in the session's first pose (where fusion starts), not the flat hand
            rest = interpolate_dip(self.session.keyframe_angles([0.0]))[0]
        elif self.motion in ("calibration", "calibration_pinch"):
            pinch = self.motion == "calibration_pinch"
            motion, rest = ProcedureMotion("gestures", config.seed, config.rate_hz, pinch=pinch), None
        else:
            motion, rest = self.motion, None
        self.emulator = Emulator(config.rate_hz, config.mode, motion, seed=config.seed)
        if self.motion not in ("calibration", "calibration_pinch"):  # calibrating reads raw frames: nothing to fuse
            self.fusion.expect(self.emulator.glove_id, raw=config.mode == "raw", rest_angles=rest)
        self.emulator.realtime = not self.fast  # before plug(): its first status frame states the clock
        try:
            return self.emulator.plug()
        except OSError as exc:
            raise GloverecError(f"cannot create the emulator's port: {exc}") from None

    # ------------------------------------------------------------ lifecycle
    def open(self) -> Glove:
        if self.warm_fusion and self._may_fuse():  # before the link opens: no raw frame waits for a compiler
            self.fusion.warm_up(self.say)
        self.source.open()
        if self.emulator is not None:
            if self.fast and self.session is not None:  # demonstrations are scheduled as the loop goes
                self.emulator.lead_s = LEAD_S
            self.emulator.start(realtime=not self.fast)
        return self

    def close(self) -> None:
        if self.emulator is not None:
            self.emulator.close()
        self.source.close()

    def _may_fuse(self) -> bool:
        """Whether this glove may send raw frames for host fusion: an emulator in raw mode, a device (its mode is
        the glove's), a log recorded with host fusion."""
        if self.fusion.host is not None:  # known already (the emulator, a log's record)
            return bool(self.fusion.host)
        return self.config.kind != "emulator"

    def __enter__(self) -> Glove:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ the demonstrator (emulator only)
    def demonstrate(self, demo, lead_s: float = 0.0) -> None:
        """Have the emulated hand perform ``demo`` next; its glove presses the button as the demo starts."""
        if self.session is None:
            raise GloverecError("only the emulated glove with motion=demonstrations performs demonstrations")
        hold = self.fusion.hold_until_s  # host fusion starts on a resting hand
        with self._motion.lock:
            start = max(self._motion.taken_s, hold) + TRANSITION_S + lead_s
            self.session.append(demo, start, TRANSITION_S)
        self._demo_start = start
        self._lead_s = WATCHING_LEAD_S if demo.watches else LEAD_S
        self.emulator.schedule_button(start)

    def revise(self, at_s: float, duration_s: float, palm_delta=(0.0, 0.0, 0.0), move=(0.0, 0.0, 0.0)) -> float | None:
        """The demonstration being performed corrects itself (DemoMotion.revise, ``at_s`` in its own time): in the
        session's time, and never before what the emulator has synthesised already. Returns when it starts, in
        the demonstration's time (``at_s`` or later), so that the plan's copy makes the same correction; None when
        that is too late: the hold it belonged to is over (the correction is dropped, the demonstration goes on as
        planned)."""
        with self._motion.lock:
            at = max(self._demo_start + at_s, self._motion.taken_s + 1.0 / self._motion.rate_hz)
            try:
                return self.session.revise(at, duration_s, palm_delta, move) - self._demo_start
            except ValueError:
                return None

    def performed(self, t: float):
        """The emulated wearer's palm at glove time ``t`` as the emulator performs it (the session's motion, the
        palm's drift included: what its IMUs measure), as (position (3,), quat (4,)) in the world; an emulated
        glove performing demonstrations faster than real time only (``fast``: glove time is its device clock)."""
        if self.session is None or not self.fast:
            raise GloverecError("only the emulated glove, faster than real time, knows where its wearer's palm is")
        b = self.session.at([self._session_time(t)])
        return b.palm_pos[0], b.palm_quat[0]

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
        """Fast mode: take frames until the track has a sample at or after ``t``; False if none comes."""
        end = time.monotonic() + timeout_s
        if self.emulator is not None:  # host fusion shows its first pose after the hand's rest
            hold = self.fusion.hold_until_s if not self.fusion.started else 0.0
            self.emulator.allow(max(self._session_time(t), hold) + self._lead_s)
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
