"""`gloverec calibrate`: walk the user through the calibration procedure (docs/fusion.md, "Calibration") on a
glove in raw mode and save its GloveCalibration (recorder/hand/calibration.py) under its glove id.

Steps, each recorded for a fixed time (recorder/hand/calibration.py STEPS, the emulated wearer's timeline too):
1. rest flat and still, 3 s (gyro bias, gravity axes; refused and repeated when the hand moved), 2. flex every
finger and the thumb twice, 3 s (flexion axes), 3. tilt forward, back, left and right, 8 s (accelerometer
offsets), 4. rest flat again, 2 s (checks: still, back in the same pose), and with ``pinch`` 5. flat for 1 s,
then the thumb tip on the index, middle, ring and little fingertips, 2 s each (fused with the new calibration:
the wearer's finger proportions, recorder/hand/pinch.py, for their hand profile).
Interactive (stdin a terminal, a real glove): each step starts at Enter or the glove's button. Otherwise (a
script, CI, ``--yes``, the emulator) the steps follow each other by the glove's clock.
"""

from __future__ import annotations

import os
import select
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from recorder import GloverecError
from recorder.calibrate.view import StepView
from recorder.fusion.host import HostFusion, _arrays
from recorder.fusion.session import load_config
from recorder.glove.config import GloveConfig
from recorder.glove.glove import open_glove
from recorder.hand import calibration as cal
from recorder.hand.kinematics import HandSize
from recorder.hand.pinch import estimate_proportions
from recorder.hand.skeleton import JOINT_MAP, N_IMUS, SEGMENTS
from recorder.paths import calibration_dir
from recorder.protocol.frames import (
    CommandCode,
    EventCode,
    EventFrame,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)

FIRST_FRAME_S = 5.0  # no frame at all within this: not a glove
RAW_WAIT_S = 3.0  # after the set-mode command: only pose frames for this long means the glove refused
STATUS_WAIT_S = 2.5  # raw frames but no status frame (the glove id) for this long: ask for --glove-id
STALL_S = 2.0  # a glove that stops sending mid-step
MARGIN_S = 0.2  # left out at both ends of a step (the hand settling), as recorder.emulator.procedure.phase

STDERR = object()  # ``out``'s default: sys.stderr as it is when the object is made


@dataclass(frozen=True)
class Step:
    name: str
    seconds: float
    text: str


STEPS = (
    Step(
        "still",
        cal.STEPS["still"],
        "Rest the hand flat on the table, palm down, fingers straight and together, "
        "thumb beside the index. Do not move.",
    ),
    Step(
        "flex",
        cal.STEPS["flex"],
        "Flex all fingers and the thumb twice, slowly and as far as comfortable "
        "(knuckles and finger joints, no spreading), back to flat.",
    ),
    Step(
        "tilt",
        cal.STEPS["tilt"],
        "Tilt the hand forward, back, left and right by about 45 degrees, holding each tilt for a second.",
    ),
    Step("rest", cal.STEPS["rest"], "Rest the hand flat again, as in step 1 (the reference pose)."),
)
PINCH = Step(
    "pinch",
    cal.STEPS["pinch"],
    "Hold the hand flat for a second, then touch the thumb tip to the tip of the index, middle, ring and little "
    "finger in turn, about 2 s each (there, hold, back).",
)


@dataclass
class Result:
    calibration: cal.GloveCalibration  # its quality says how it went (attempts, frames per step, checks)
    path: Path
    proportions: np.ndarray | None = None  # from the pinch step: length factors of the thumb and fingers


class Calibrator:
    """One run of the procedure on ``glove`` (emulator, serial:PORT, a device path, udp:PORT or mcap:FILE)."""

    def __init__(
        self,
        glove: GloveConfig | str,
        *,
        glove_id: int | None = None,
        folder=None,
        config=None,
        interactive: bool | None = None,
        attempts: int = 3,
        realtime: bool = False,
        seed: int = 0,
        out=STDERR,
        view: str | None = "none",
        pinch: bool = False,
        hand_size: HandSize = HandSize(),
    ):
        """``view``: a live view showing each step on the human hand (recorder/calibrate/view.py; None: the
        default, native with a display and a terminal). ``pinch``: add the pinch step, which estimates the
        finger proportions of a hand of ``hand_size`` (the wearer's measured length and breadth)."""
        self.glove_config = GloveConfig.parse(glove)
        self.emulated = self.glove_config.kind == "emulator"
        self.steps = STEPS + ((PINCH,) if pinch else ())
        self.hand_size = hand_size
        self.motion = "calibration_pinch" if pinch else "calibration"
        if self.emulated:  # the emulated wearer performs the steps; its glove starts in raw mode
            self.glove_config = GloveConfig.parse(self.glove_config, mode="raw", motion=self.motion, seed=seed)
        self.spec = str(self.glove_config)
        self.glove_id = glove_id
        self.folder = calibration_dir(folder)
        self.config = load_config(config)
        self.interactive = (
            (not self.emulated and sys.stdin is not None and sys.stdin.isatty())
            if interactive is None
            else bool(interactive and not self.emulated)
        )
        self.attempts = 1 if self.emulated else max(1, int(attempts))  # the emulated wearer does not repeat
        self.realtime = realtime
        self.seed = seed
        self.out = sys.stderr if out is STDERR else out  # None: silent; stderr resolved now (it may be redirected)
        self.glove = None
        self.view_spec = view
        self.view = None
        self.view_moves = None  # what the view shows on the human hand (None: the calibration procedure's steps)
        self.view_doing = "calibrating"  # what its status says is done to the glove
        self._pending: list = []  # frames read ahead and not used yet
        self.channels = None  # the glove's channel map (`gloverec doctor --fix`), applied to its raw frames
        self.announced_hz: float | None = None  # the output rate its status frames state
        self.mode_before: Mode | None = None  # the glove's output mode before calibrating: restored at the end

    # ------------------------------------------------------------ the run
    def run(self) -> Result:
        self.source = self._open()
        try:
            self._open_view()
            first = self._raw_mode()
            self._pending = first + self._pending
            recs, attempts = {}, 0
            for k, step in enumerate(self.steps):
                while True:
                    recs[step.name] = self._step(k, step)
                    if step.name != "still":
                        break
                    attempts += 1
                    try:
                        g, a, _, _ = _arrays(_inside(recs["still"]))
                        cal.check_still(g, a)
                        break
                    except cal.CalibrationRefused as exc:
                        if attempts >= self.attempts:
                            raise GloverecError(
                                f"calibration refused: {exc.reason}; hold the hand flat and "
                                f"still for the whole step ({attempts} attempt(s))"
                            ) from None
                        self._say(f"refused: {exc.reason}. Again:")
                if step.name == "flex":
                    self._check_build(recs["still"], recs["flex"])
        finally:
            self.close()
        calibration = self._compute(recs, attempts)
        proportions = self._proportions(calibration, recs["pinch"]) if "pinch" in recs else None
        try:
            path = calibration.save(self.folder)
        except OSError as exc:
            raise GloverecError(f"cannot save the calibration in {self.folder}: {exc.strerror or exc}") from None
        return Result(calibration, path, proportions)

    def _check_build(self, still: list, flex: list) -> None:
        """The doctor's checks on the first two steps (recorder/glove/checks.py): a glove built wrong is refused in
        one line, before anything is fitted, pointing at `gloverec doctor`. A sensor mounted turned is refused too:
        the flexion axis is fitted only up to its sign (forced towards +y), so a turned sensor would be calibrated
        with its finger bending backwards; the doctor's channel map turns it back."""
        from recorder.glove.checks import calibration_problems

        problems = calibration_problems(still, flex, self.announced_hz)  # each move trimmed at its ends there
        if problems:
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            raise GloverecError(
                f"calibration refused: {problems[0].found}{more}; run `gloverec doctor --glove {self.spec}`"
            )

    def _mapped(self, f: RawFrame) -> RawFrame:
        """A raw frame in slot order, by the glove's channel map (loaded once its id is known)."""
        if self.channels is None and self.glove_id is not None:
            from recorder.fusion.session import read_channel_map

            self.channels = read_channel_map(self.folder, self.glove_id) or False
        return self.channels.apply(f) if self.channels else f

    def _proportions(self, calibration: cal.GloveCalibration, frames: list) -> np.ndarray:
        """The finger length factors from the pinch step: fused with the new calibration from its flat first
        second, the middle of each finger's hold."""
        fusion = HostFusion(self.config, calibration)
        t = np.array([(f.t_us - frames[0].t_us) & 0xFFFFFFFF for f in frames]) * 1e-6
        flat = [f for f, s in zip(frames, t) if MARGIN_S <= s <= cal.PINCH_FLAT_S - MARGIN_S]
        try:
            fusion.start(flat)
        except (ValueError, IndexError):
            raise GloverecError("the pinch step's first second was too short to start from: repeat it") from None
        angles = np.array([fusion.process(f).angles for f in frames])
        pinches = {}
        for k, finger in enumerate(cal.PINCH_FINGERS):
            mid = cal.PINCH_FLAT_S + (k + 0.5) * cal.PINCH_EACH_S
            pinches[finger] = angles[np.abs(t - mid) <= 0.25 * cal.PINCH_EACH_S]
        return estimate_proportions(pinches, self.hand_size)

    def _compute(self, recs: dict, attempts: int) -> cal.GloveCalibration:
        still, flex, tilt, rest = (_inside(recs[s.name]) for s in STEPS)  # the glove's steps (not the pinch)
        fusion = HostFusion(self.config)  # the frames are in slot order already (the channel map applied)
        try:
            calibration = fusion.calibrate(still, flex, tilt, glove_id=self.glove_id)
        except cal.CalibrationRefused as exc:  # checked already; kept for a glove whose frames changed meanwhile
            raise GloverecError(f"calibration refused: {exc.reason}") from None
        g1, a1, _, _ = _arrays(still)
        g4, a4, _, _ = _arrays(rest)
        try:
            cal.check_still(g4, a4)
            rest_still = True
        except cal.CalibrationRefused:
            rest_still = False
        up1, up4 = (m / np.linalg.norm(m, axis=1, keepdims=True) for m in (a1.mean(0), a4.mean(0)))
        calibration.quality.update(
            {
                "still_attempts": attempts,
                "rest_still": rest_still,
                # how far the gyro bias moved between steps 1 and 4 (warming up), and how far each IMU's gravity
                # direction is from step 1's in step 4 (the hand back in the reference pose: a few degrees at most)
                "rest_bias_change_dps": float(np.degrees(np.max(np.linalg.norm(g4.mean(0) - g1.mean(0), axis=1)))),
                "rest_pose_change_deg": float(np.degrees(np.max(np.arccos(np.clip(np.sum(up1 * up4, 1), -1, 1))))),
                "frames": {s.name: len(recs[s.name]) for s in self.steps},
            }
        )
        return calibration

    # ------------------------------------------------------------ the glove
    def _open(self):
        # a device runs in real time whatever we do; a log plays back as fast as it is read
        fast = not self.realtime if self.emulated else True
        # the steps read raw frames as they come; host fusion runs only at the end (the pinch step)
        self.glove = open_glove(self.glove_config, fast=fast, motion=self.motion, warm_fusion=False)
        return self.glove.source

    def close(self) -> None:
        if self.view is not None:
            self.view.close()
            self.view = None
        if self.glove is not None:
            self._restore_mode()
            self.glove.close()
            self.glove = None

    def _restore_mode(self) -> None:
        """Put the glove back in the mode it was in (a pose glove stays a pose glove after calibrating, whether
        the calibration worked or not), and say so."""
        if self.mode_before is None or self.mode_before == Mode.RAW or self.emulated:
            return
        if self._command(CommandCode.SET_MODE, self.mode_before):
            self._say(f"glove back in {self.mode_before.name.lower()} mode")

    def _first_mode(self) -> list:
        """The glove's output mode before anything is asked of it, from its first frames (a status frame says
        it; a pose, compact or raw frame shows it); returns the frames read."""
        kinds = {PoseFrame: Mode.POSE, PoseCompactFrame: Mode.COMPACT, RawFrame: Mode.RAW}
        end = time.monotonic() + FIRST_FRAME_S
        seen = []
        while time.monotonic() < end and not self.source.finished:
            f = self.source.read(0.05)
            if f is None:
                continue
            seen.append(f)
            mode = f.mode if isinstance(f, StatusFrame) else kinds.get(type(f))
            if mode is not None:
                self.mode_before = Mode(mode)
                break
        return seen

    def _raw_mode(self) -> list:
        """Ask for raw frames and wait for them and for the glove id; returns the raw frames read meanwhile."""
        self._pending = self._first_mode() + self._pending
        self._command(CommandCode.SET_MODE, Mode.RAW)
        name = "the emulator" if self.emulated else self.spec
        t0 = time.monotonic()
        raw, poses, status_asked = [], 0, False
        got_frame = got_raw = None
        while True:
            f = self._next(0.05)
            now = time.monotonic()
            if f is not None:
                got_frame = got_frame or now
                if isinstance(f, StatusFrame):
                    self.glove_id = self.glove_id if self.glove_id is not None else int(f.glove_id)
                elif isinstance(f, RawFrame):
                    raw.append(f)
                    got_raw = got_raw or now
                elif isinstance(f, (PoseFrame, PoseCompactFrame)):
                    poses += 1
            if got_raw is not None and self.glove_id is not None:
                return raw
            if self.source.finished and f is None:
                break
            if got_frame is None and now - t0 > FIRST_FRAME_S:
                raise GloverecError(
                    f"no glove frames from {name} in {FIRST_FRAME_S:.0f} s: is it connected and sending?"
                )
            if got_raw is None and got_frame is not None and now - got_frame > RAW_WAIT_S:
                break
            if got_raw is not None and now - got_raw > STATUS_WAIT_S / 2 and not status_asked:
                status_asked = self._command(CommandCode.GET_STATUS)
            if got_raw is not None and now - got_raw > STATUS_WAIT_S:
                break
        if not raw:
            what = f"{poses} fused pose frames" if poses else "no raw frames"
            raise GloverecError(
                f"{name} sends {what} and did not switch to raw mode: calibration needs the raw "
                "IMU frames of a glove that takes the set-mode command"
            )
        raise GloverecError(f"{name} sent no status frame, so its glove id is unknown: pass --glove-id HEX")

    def _command(self, code: CommandCode, arg: int = 0) -> bool:
        try:
            self.source.command(code, int(arg))
            return True
        except GloverecError:  # a log cannot take commands: its frames are what they are
            return False

    def _next(self, timeout: float):
        if self._pending:
            return self._pending.pop(0)
        f = self.source.read(timeout)
        if isinstance(f, StatusFrame) and f.output_rate_hz:
            self.announced_hz = float(f.output_rate_hz)
        return f

    # ------------------------------------------------------------ one step
    def _step(self, k: int, step: Step) -> list:
        self._k, self._current = k, step
        self._say(f"step {k + 1}/{len(self.steps)}, {step.seconds:g} s: {step.text}")
        if self.interactive:
            self._wait_for_go()
        frames = []
        progress = _Progress(self.out, f"step {k + 1}", step.seconds)
        last = time.monotonic()
        try:
            while True:
                f = self._next(0.1)
                if f is None:
                    if self.source.finished:
                        raise GloverecError(f"{self.spec} ended during step {k + 1} ({step.name})")
                    if time.monotonic() - last > STALL_S:
                        raise GloverecError(f"the glove stopped sending during step {k + 1} ({step.name})")
                    continue
                last = time.monotonic()
                if not isinstance(f, RawFrame):
                    continue
                span = ((f.t_us - frames[0].t_us) & 0xFFFFFFFF) * 1e-6 if frames else 0.0
                if span >= step.seconds:
                    self._pending.insert(0, f)  # the first frame of the next step
                    break
                frames.append(self._mapped(f))
                progress.update(span)
                self._show(k, step, span)
        finally:
            progress.close()
        return frames

    def _wait_for_go(self) -> None:
        """Enter on the terminal or the glove's button; then what came while waiting is thrown away."""

        self._say("press Enter (or the glove's button) to start")
        fd = sys.stdin.fileno()
        while True:
            if self._show(self._k, self._current, 0.0, waiting=True) == "next":
                break
            ready, _, _ = select.select([fd], [], [], 0.05)
            if ready:
                os.read(fd, 1024)
                break
            f = self._next(0.0)
            if isinstance(f, EventFrame) and f.code == EventCode.BUTTON:
                break
            if f is None and self.source.finished:
                break
        self._pending = []
        self.source.drain()

    def _say(self, text: str) -> None:
        print(text, file=self.out, flush=True)

    def _open_view(self) -> None:
        """The live view of the steps, unless it is ``none``."""
        if self.view_spec != "none":
            self.view = StepView(self.view_spec, self.spec, self._say, self.hand_size, demo=self.view_moves,
                                 doing=self.view_doing)  # fmt: skip

    def _show(self, k: int, step: Step, seconds: float, waiting: bool = False) -> str | None:
        """Show the step in the live view, if any; its requests: "next" (returned), "stop" (ends the run)."""
        if self.view is None:
            return None
        self.view.show(k, len(self.steps), step, seconds, waiting)
        what = self.view.take()
        if what == "stop":
            raise GloverecError("calibration stopped from the view; nothing saved")
        return what


def _inside(frames: list, margin_s: float = MARGIN_S) -> list:
    """The frames more than ``margin_s`` from both ends of a step (all of them for a step too short for that)."""
    if len(frames) < 3:
        return frames
    t = np.array([(f.t_us - frames[0].t_us) & 0xFFFFFFFF for f in frames]) * 1e-6
    keep = [f for f, s in zip(frames, t) if margin_s <= s <= t[-1] - margin_s]
    return keep if len(keep) >= 3 else frames


class _Progress:
    """A rich progress bar on a terminal; a line at the end otherwise."""

    def __init__(self, out, label: str, seconds: float):
        self.out, self.label, self.seconds, self.done = out, label, seconds, 0.0
        self.bar = None
        if hasattr(out, "isatty") and out.isatty():
            self.bar = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.completed:4.1f} / {task.total:g} s"),
                console=Console(file=out),
                transient=False,
            )
            self.task = self.bar.add_task(label, total=seconds)
            self.bar.start()

    def update(self, seconds: float) -> None:
        self.done = seconds
        if self.bar is not None:
            self.bar.update(self.task, completed=min(seconds, self.seconds))

    def close(self) -> None:
        if self.bar is not None:
            self.bar.update(self.task, completed=self.seconds)
            self.bar.stop()
        else:
            print(f"{self.label}: recorded {self.done:.1f} s", file=self.out, flush=True)


# ---------------------------------------------------------------- the report


def summary(result: Result) -> dict:
    """What `gloverec calibrate --json` prints."""
    c = result.calibration
    return {
        "glove_id": c.glove_id,
        "glove_id_hex": f"{c.glove_id:08x}",
        "path": str(result.path),
        "created": c.created,
        "version": c.version,
        "imus": [SEGMENTS[s] for s in JOINT_MAP],
        "gyro_bias_dps": np.round(np.degrees(c.gyro_bias), 4).tolist(),
        "accel_offset_mg": np.round(c.accel_offset * 1e3, 2).tolist(),
        "flexion_axis_ok": list(c.quality.get("flexion_axis_ok", [False] * N_IMUS)),
        "accel_offset_ok": list(c.quality.get("accel_offset_ok", [False] * N_IMUS)),
        "quality": {k: v for k, v in c.quality.items() if k not in ("flexion_axis_ok", "accel_offset_ok")},
    }


def report(result: Result) -> str:
    """One screen: gyro bias per IMU, which IMUs got a flexion axis and an accelerometer offset, quality."""
    s = summary(result)
    q = s["quality"]
    lines = [
        f"glove {s['glove_id_hex']} calibrated, saved to {s['path']}",
        f"{'IMU':>3}  {'segment':<18} {'gyro bias deg/s (x y z)':>26}  {'flexion axis':<12} "
        f"{'accel offset mg (x y z)':>24}",
    ]
    for i, name in enumerate(s["imus"]):
        b = " ".join(f"{v:+7.2f}" for v in s["gyro_bias_dps"][i])
        off = " ".join(f"{v:+6.1f}" for v in s["accel_offset_mg"][i]) if s["accel_offset_ok"][i] else "-"
        flex = "yes" if s["flexion_axis_ok"][i] else "-"
        lines.append(f"{i:>3}  {name:<18} {b:>26}  {flex:<12} {off:>24}")
    lines.append(
        f"flexion axes {sum(s['flexion_axis_ok'])}/{N_IMUS - 1} (not the palm), accelerometer offsets "
        f"{sum(s['accel_offset_ok'])}/{N_IMUS}; step 1 took {q['still_attempts']} attempt(s); "
        f"step 4 {'still' if q['rest_still'] else 'NOT still'}, gyro bias moved "
        f"{q['rest_bias_change_dps']:.2f} deg/s, pose {q['rest_pose_change_deg']:.1f} deg from step 1"
    )
    return "\n".join(lines)
