"""`gloverec doctor`: a new glove's check-up (docs/recording.md, "Bringing up a new glove"). The wearer rests the
hand flat, then curls each finger in turn, thumb to little (recorder/hand/checkup.py, 9.5 s of moves); from the raw
frames recorder/glove/checks.py finds what was built wrong, and ``fix`` saves the channel map that undoes swapped
cables and sensors glued turned (recorder/fusion/channels.py), beside the calibration. The steps are recorded as
`gloverec calibrate` records its own (recorder/calibrate/procedure.py): on the glove's clock, each started by Enter
or the glove's button on a terminal, one after the other with ``--yes``, a script or the emulator.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

from recorder import GloverecError
from recorder.calibrate.procedure import STDERR, Calibrator, Step
from recorder.emulator.checkup import CheckupMotion
from recorder.fusion.channels import ChannelMap
from recorder.glove.checks import Checkup, examine
from recorder.glove.config import GloveConfig
from recorder.hand import checkup
from recorder.hand.calibration import created_now
from recorder.hand.skeleton import FINGERS

FINGER_NAMES = {"thumb": "thumb", "index": "index finger", "middle": "middle finger", "ring": "ring finger",
                "pinky": "little finger"}  # fmt: skip
STEPS = (
    Step(
        "still",
        checkup.STILL_S,
        "Rest the hand flat on the table, palm down, fingers straight and together. Do not move.",
    ),  # fmt: skip
    *(
        Step(
            f,
            checkup.FLEX_S,
            f"Curl the {FINGER_NAMES[f]} fully, all its joints, and straighten it again (the other fingers flat).",
        )  # fmt: skip
        for f in FINGERS
    ),
)


@dataclass
class Verdict:
    checkup: Checkup
    glove_id: int
    spec: str
    wearer_s: float  # wall time from the first instruction to the last move's end
    moves_s: float  # glove time the moves were recorded for
    applied: ChannelMap | None = None  # the channel map in place while the doctor looked (already fixed)
    saved: Path | None = None  # the channel map ``fix`` saved


class Doctor(Calibrator):
    """One check-up of ``glove`` (emulator, serial:PORT, a device path, udp:PORT or mcap:FILE)."""

    def __init__(self, glove: GloveConfig | str, *, folder=None, glove_id: int | None = None,
                 interactive: bool | None = None, realtime: bool = False, seed: int = 0, out=STDERR,
                 view: str | None = "none"):  # fmt: skip
        """``view``: a live view showing each move on the human hand (None: native with a display and a
        terminal)."""
        super().__init__(glove, glove_id=glove_id, folder=folder, interactive=interactive, realtime=realtime,
                         seed=seed, out=out, view=view)  # fmt: skip
        self.steps = STEPS
        self.motion = "doctor"
        self.view_moves, self.view_doing = CheckupMotion(vary=False), "checking"  # the emulated wearer's clean moves
        if self.emulated:  # the emulated wearer performs the moves; its glove starts in raw mode
            self.glove_config = GloveConfig.parse(self.glove_config, mode="raw", motion="doctor", seed=seed)
            self.spec = str(self.glove_config)

    def run(self, fix: bool = False) -> Verdict:
        self._open_view()  # first: its start-up (seconds) is over before the glove streams the moves it shows
        try:
            self.source = self._open()
            try:
                first = self._raw_mode()
            except GloverecError as exc:
                if "did not switch to raw mode" not in str(exc):
                    raise
                raise GloverecError(
                    f"{self.spec} fuses on board and did not switch to raw mode: the doctor reads each IMU's raw "
                    "frames; put the glove in raw mode (its firmware's set_mode raw) and run it again"
                ) from None
            self._pending = first + self._pending
            started = time.monotonic()
            moves = {step.name: self._step(k, step) for k, step in enumerate(self.steps)}
            wearer_s = time.monotonic() - started
        finally:
            self.close()
        found = examine(moves, self.announced_hz)
        applied = self.channels or None
        verdict = Verdict(found, int(self.glove_id), self.spec, wearer_s, sum(s.seconds for s in self.steps), applied)
        if fix and found.channel_map is not None:
            verdict.saved = self._save(found.channel_map, applied)
        return verdict

    def _save(self, new: ChannelMap, old: ChannelMap | None) -> Path:
        """The new map on top of the one in place (the doctor looked through it)."""
        order, turns = new.order, new.turns
        if old is not None:
            order = tuple(old.order[k] for k in new.order)
            turns = tuple((old.turns[k] + t) % 4 for k, t in zip(new.order, new.turns))
        fixed = replace(new, glove_id=int(self.glove_id), order=order, turns=turns, created=created_now())
        try:
            return fixed.save(self.folder)
        except OSError as exc:
            raise GloverecError(f"cannot save the channel map in {self.folder}: {exc.strerror or exc}") from None


def summary(v: Verdict) -> dict:
    """What `gloverec doctor --json` prints."""
    c = v.checkup
    fixable = c.channel_map is not None
    return {
        "glove": v.spec,
        "glove_id": v.glove_id,
        "glove_id_hex": f"{v.glove_id:08x}",
        "ok": c.ok,
        "problems": [p.as_dict() for p in c.problems],
        "rate_hz": round(c.rate_hz, 1),
        "announced_hz": c.announced_hz,
        "raw_frames": c.frames,
        "wearer_s": round(v.wearer_s, 2),
        "moves_s": v.moves_s,
        "channel_map_applied": v.applied is not None,
        "fix": {
            "software": fixable,
            "saved": None if v.saved is None else str(v.saved),
            "order": list(c.channel_map.order) if fixable else None,
            "turns": list(c.channel_map.turns) if fixable else None,
        },
        "activity_dps": c.activity_dps,
    }


def report(v: Verdict, fix_hint: str = "") -> str:
    """One screen: the verdict, each problem with what to do, the fix."""
    c = v.checkup
    head = f"glove {v.glove_id:08x} ({v.spec}): "
    rate = f"{c.rate_hz:.0f} Hz measured, {c.announced_hz:g} Hz announced" if c.announced_hz else f"{c.rate_hz:.0f} Hz"
    if v.applied is not None:
        rate += "; its saved channel map applied"
    if c.ok:
        return (head + f"no problems found: every IMU answers and turns with its finger, about its flexion axis "
                f"({rate}; {c.frames} raw frames, {v.moves_s:g} s of moves)")  # fmt: skip
    lines = [head + f"{len(c.problems)} problem(s) ({rate}; {c.frames} raw frames, {v.moves_s:g} s of moves)"]
    for p in c.problems:
        lines.append(f"- {p.kind}: {p.found}")
        lines.append(f"    what to do: {p.action}")
    if v.saved is not None:
        lines.append(f"fixed in software: channel map saved to {v.saved}; the host applies it to every raw frame "
                     "(run the doctor again to check, then `gloverec calibrate`)")  # fmt: skip
    elif c.channel_map is not None:
        lines.append(f"all of it can be fixed in software: {fix_hint or 'add --fix'} to save a channel map")
    else:
        lines.append("some of it needs the soldering iron: fix those, then run the doctor again")
    return "\n".join(lines)
