"""`gloverec calibrate --wrist SOURCE --glove GLOVE`: where the tracked marker sits on the glove (docs/wrist.md,
"Where the marker sits on the glove").

For ``--duration`` seconds the wearer holds the hand in the camera's view and tilts it forward and back, left and
right, and turns it. Each tracked marker pose (WristTrack's ``on_pose``: the source's poses on the loop's clock) is
paired with the glove's palm orientation at the pose's capture time (its stamp less the tracker's latency; the
glove's pose track, slerped between samples), with IPPE's other pose beside it. A status line shows how far the
palm has turned about each axis and what to do next. The pairs are solved by recorder/wrist/mounting.py
(``solve_mount``) and the mounting is saved as ``marker_mount.json`` in the calibrations' folder, where `gloverec
record --wrist` finds it.

With no hardware, ``--glove emulator --wrist marker:emulated[:RX,RY,RZ]``: the emulated wearer performs the moves
(``mount_motion``, a scripted demonstration through ``Performer.demonstrate``) and the emulated webcam films its
palm as the emulator performs it (``Performer.performed``), with the marker glued off by RX, RY, RZ (degrees, a
rotation vector in the palm's axes). The emulator then runs faster than real time, the loop stepping at the
camera's rate.
"""

from __future__ import annotations

import sys
import time
from collections import deque
from pathlib import Path

import numpy as np

from recorder import GloverecError, quat
from recorder.demonstrator.motion import DemoMotion
from recorder.demonstrator.performer import Performer
from recorder.glove.config import EMULATOR, GloveConfig
from recorder.glove.glove import make_glove
from recorder.hand.gestures import GESTURES
from recorder.paths import calibration_dir
from recorder.wrist import open_wrist
from recorder.wrist.config import SCRIPTED, WristConfig
from recorder.wrist.fusion import FusionConfig
from recorder.wrist.mounting import (
    AXES,
    MIN_SAMPLES,
    MIN_TURN_DEG,
    MarkerMount,
    mount_file,
    progress,
    solve_mount,
    turns,
)
from recorder.wrist.track import WristTrack

DURATION_S = 15.0
FRAME_S = 1.0 / 30.0  # the loop's step faster than real time (the emulated camera's frame period)
NO_POSE_S = 5.0  # the glove's first hand pose, and the emulated wearer's start, are waited for this long (wall)
CENTRE = (0.0, 0.0, 0.15)  # where the emulated wearer holds the palm: where the emulated camera looks
# The emulated wearer's moves, rotation vectors in the palm's axes (degrees): forward and back (about y), left and
# right (about x), a turn (about z), then some of each together, spread evenly over the step
TURNS_DEG = [(0, 0, 0), (0, 25, 0), (0, -25, 0), (0, 0, 0), (25, 0, 0), (-25, 0, 0), (0, 0, 0), (0, 0, 35),
             (0, 0, -35), (15, 15, 15), (-15, -15, -15), (0, 0, 0)]  # fmt: skip


def mount_motion(duration_s: float, seed: int = 0, rate_hz: float = 200.0, centre=CENTRE) -> DemoMotion:
    """The emulated wearer's part: the open hand held at ``centre``, tilted and turned through TURNS_DEG."""
    times = np.linspace(0.0, duration_s, len(TURNS_DEG))
    poses = np.tile(GESTURES["open"], (len(TURNS_DEG), 1))
    return DemoMotion(times, poses, np.random.default_rng([seed, 0x6D6E74]), rate_hz, palm_pos=centre,
                      palm_turns=np.radians(TURNS_DEG))  # fmt: skip


class _Pairs:
    """Tracked marker poses waiting for the glove's palm at their capture time, and the pairs made."""

    def __init__(self, glove, latency_s: float):
        self.glove, self.latency_s = glove, latency_s
        self.waiting: deque = deque()  # (capture time, pose)
        self.marker, self.alternative, self.palm = [], [], []
        self.poses = self.tracked = 0

    def on_pose(self, pose, t: float) -> None:
        self.poses += 1
        if pose.tracked:
            self.tracked += 1
            self.waiting.append((float(pose.t) - self.latency_s, pose))

    def pair(self, final: bool = False) -> None:
        """Pair the poses whose capture time the glove's track has passed (``final``: all of them it has)."""
        track = self.glove.track
        newest = track.newest_s
        while self.waiting and newest is not None and (self.waiting[0][0] <= newest or final):
            t, pose = self.waiting.popleft()
            at = track.at(t)
            if at is None or at.age_s > 0.05:  # before the track began, or long after its last sample
                continue
            self.marker.append(quat.normalize(np.asarray(pose.quat, float)))
            alt = getattr(pose, "alternative", None)
            self.alternative.append(np.full(4, np.nan) if alt is None else np.asarray(alt[1], float))
            self.palm.append(np.asarray(at.pose.palm, float))

    def status(self, left_s: float) -> str:
        done, hint = progress(np.array(self.palm)) if len(self.palm) > 1 else (0.0, "tilt it forward/back")
        _, per_axis = turns(np.array(self.palm)) if len(self.palm) > 1 else (None, np.zeros(3))
        bar = "#" * int(round(20 * done))
        axes = "  ".join(f"{name} {v:3.0f}°" for name, v in zip(AXES, per_axis))
        share = self.tracked / self.poses if self.poses else 0.0
        return (f"marker mounting [{bar:<20}] {100 * done:3.0f} %  {axes}  ({len(self.palm)} poses, tracked "
                f"{100 * share:.0f} %): {hint}, {left_s:.0f} s left")  # fmt: skip


def calibrate_mount(glove: str, wrist: str, duration_s: float = DURATION_S, camera_file: str | None = None,
                    marker_mm: float = 40.0, folder=None, realtime: bool = False, out=None) -> dict:  # fmt: skip
    """Run the step and save the mounting; returns what it found (MarkerMount.as_dict() with the file's ``path``,
    the tracked share, and for the emulated marker its true mounting's error). ``out``: where the instructions and
    the status line go (stderr; the status line only on a terminal). One-line GloverecError when it cannot."""
    out = sys.stderr if out is None else out
    wrist_config, glove_config = WristConfig.parse(wrist), GloveConfig.parse(glove)
    emulated_wearer = glove_config.kind == EMULATOR
    if wrist_config.kind == SCRIPTED:
        raise GloverecError("--wrist scripted has no marker to calibrate: pass udp:PORT, marker:CAMERA or mcap:FILE")
    if wrist_config.follows_wearer and not emulated_wearer:
        raise GloverecError(f"--wrist {wrist_config.kind} films the emulated wearer: calibrate with --glove emulator")
    if wrist_config.follows_wearer and realtime:
        raise GloverecError(f"--wrist {wrist_config.kind} films the emulated wearer faster than real time: drop "
                            "--realtime")  # fmt: skip
    fast = (emulated_wearer and not realtime) or glove_config.kind == "mcap"
    options = {"fast": fast, "calibration_dir": folder, "say": lambda text: print(text, file=out, flush=True)}
    performer = Performer(glove_config, **options) if emulated_wearer else None  # it wears the emulated glove
    g = performer.glove if performer is not None else make_glove(glove_config, **options)
    try:
        source = open_wrist(wrist_config, camera_file, marker_mm, paced=not fast, glove=glove_config,
                            wearer=performer.performed if performer is not None else None)  # fmt: skip
        latency = float(getattr(source, "latency_s", 0.0))  # a log's: its recording's; the emulated webcam's
        track = WristTrack(source, FusionConfig(latency_s=latency))
    except BaseException:
        g.close()
        raise
    pairs = _Pairs(g, latency)
    track.on_pose = pairs.on_pose
    live = bool(getattr(out, "isatty", lambda: False)())
    try:
        g.open()
        track.open()
        if performer is not None:
            performer.demonstrate(mount_motion(duration_s, glove_config.seed, glove_config.rate_hz))
        who = "the emulated wearer does" if emulated_wearer else "do"
        print(f"hold the hand in the tracker's view and, for {duration_s:g} s, tilt it forward and back, left and "
              f"right, and turn it ({who}: {MIN_TURN_DEG:.0f}° about two axes is needed)", file=out,
              flush=True)  # fmt: skip
        (_fast_loop if fast else _realtime_loop)(g, track, pairs, duration_s, emulated_wearer, out if live else None)
        pairs.pair(final=True)
    finally:
        if live:
            print(file=out)
        track.close()
        g.close()
    share = pairs.tracked / pairs.poses if pairs.poses else 0.0
    if len(pairs.palm) < MIN_SAMPLES:
        raise GloverecError(f"only {len(pairs.palm)} of {pairs.poses} poses from {source.name} in {duration_s:g} s "
                            f"tracked the marker ({MIN_SAMPLES} needed): is it in view?")  # fmt: skip
    mount = solve_mount(np.array(pairs.marker), np.array(pairs.palm), np.array(pairs.alternative),
                        source=str(wrist_config), glove=str(glove_config), glove_id=g.fusion.glove_id)  # fmt: skip
    path = mount.save(mount_file(calibration_dir(folder)))
    result = {**mount.as_dict(), "path": str(path), "tracked_fraction": round(share, 4)}
    true = getattr(source, "true_mount", None)  # the emulated marker's, glued off as --wrist says
    if true is not None:
        result["emulated_mount_deg"] = round(float(np.degrees(quat.angle_between(quat.IDENTITY, true))), 4)
        result["emulated_error_deg"] = round(float(np.degrees(quat.angle_between(true, mount.q))), 4)
    return result


def _fast_loop(g, track, pairs, duration_s: float, emulated_wearer: bool, live) -> None:
    """Faster than real time: the loop steps the glove's clock one camera frame at a time from the start (the
    emulated wearer's: its button as it starts the moves)."""
    if not g.wait_past(float("-inf"), NO_POSE_S):
        raise GloverecError(f"no hand pose from {g.name} in {NO_POSE_S:g} s: is it a glove?")
    t = g.now()
    deadline = time.monotonic() + NO_POSE_S
    while emulated_wearer and g.take_button() is None:  # the demonstration starts with a press
        t += FRAME_S
        if not g.wait_past(t) or time.monotonic() > deadline:
            raise GloverecError("the emulated wearer did not start its moves")
    start, last_line = t, 0.0
    while t < start + duration_s:
        t += FRAME_S
        if not g.wait_past(t):
            break  # a log ended
        track.update(t, g.track.at(t).pose.palm)
        pairs.pair()
        if live is not None and time.monotonic() - last_line > 0.25:
            last_line = time.monotonic()
            live.write("\r" + pairs.status(start + duration_s - t) + "\x1b[K")
            live.flush()


def _realtime_loop(g, track, pairs, duration_s: float, emulated_wearer: bool, live) -> None:
    """In real time: the loop takes what has arrived every 10 ms, for ``duration_s`` from the glove's first pose."""
    if g.latest(wait_s=NO_POSE_S) is None:
        raise GloverecError(f"no hand pose from {g.name} in {NO_POSE_S:g} s: waiting for {g.waiting_for()}")
    end, last_line = time.monotonic() + duration_s, 0.0
    while time.monotonic() < end and not g.finished:
        g.poll(timeout=0.01)
        track.update(g.now(), g.track.newest.palm)  # now: the poses' ages put them on the loop's clock
        pairs.pair()
        if live is not None and time.monotonic() - last_line > 0.25:
            last_line = time.monotonic()
            live.write("\r" + pairs.status(end - time.monotonic()) + "\x1b[K")
            live.flush()


def report(result: dict) -> str:
    """The lines `gloverec calibrate --wrist` prints."""
    mount = MarkerMount.load(result["path"])
    turned = " and ".join(f"{v:.0f}°" for v in result["turned_deg"])
    lines = [
        f"marker mounting of {mount.glove} on {mount.source}: {mount.describe()}",
        f"  {mount.flipped} frames took IPPE's other pose, {mount.dropped} were left out; the palm turned {turned} "
        f"about its two main axes; tracked {100 * result['tracked_fraction']:.0f} % of the frames",
    ]
    if "emulated_error_deg" in result:
        lines.append(f"  the emulated marker is glued {result['emulated_mount_deg']:.1f}° off: found to within "
                     f"{result['emulated_error_deg']:.2f}°")  # fmt: skip
    lines.append(f"saved to {Path(result['path'])}: gloverec record --wrist uses it")
    return "\n".join(lines)
