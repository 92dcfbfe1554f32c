"""The built-in emulator as a glove source (``--glove emulator``; recorder/glove/sources.py registers ``emulated``
by name): an Emulator on a pseudo-terminal in this process, read through the real serial path. The link starts
the emulator streaming when it opens and stops it, and removes its port, when it closes."""

from __future__ import annotations

from recorder import GloverecError
from recorder.emulator.checkup import CheckupMotion
from recorder.emulator.emulator import Emulator
from recorder.emulator.procedure import ProcedureMotion
from recorder.link.serial_source import SerialSource

CALIBRATION = ("calibration", "calibration_pinch")  # the calibration steps: raw frames read as they come


class EmulatedLink(SerialSource):
    """A serial link to ``emulator``'s pty, plugged now. ``realtime``: the emulator paces itself by the host clock,
    else it synthesises as fast as this link takes its frames (none lost, however slow the reader)."""

    def __init__(self, emulator: Emulator, realtime: bool = True, **options):
        emulator.realtime = realtime  # before plug(): its first status frame states the clock
        try:
            port = emulator.plug()
        except OSError as exc:
            raise GloverecError(f"cannot create the emulator's port: {exc}") from None
        super().__init__(port, **options)
        self.emulator = emulator
        self.realtime = realtime
        self.lossless = not realtime

    def open(self) -> EmulatedLink:
        if self._thread is None:  # not open yet (opening an open link does nothing, as for every link)
            super().open()
            self.emulator.start(realtime=self.realtime)
        return self

    def close(self) -> None:
        self.emulator.close()
        super().close()


def emulated(config, realtime: bool = True, wearer=None, rest_angles=None, **options) -> EmulatedLink:
    """The emulator ``config`` names (its rate, output mode, motion and seed) behind an unopened link. Its wearer
    moves as ``config.motion`` says (gestures when unset); ``demonstrations`` are a ``wearer``'s, the Motion-like
    object a performer drives (recorder/demonstrator/performer.py), resting at ``rest_angles`` before it starts.
    Host fusion is told the glove before it sends, except while the wearer calibrates (nothing is fused then)."""
    kind = config.motion or "gestures"
    if kind == "demonstrations":
        if wearer is None:
            raise GloverecError("the emulated wearer performs demonstrations only for a demonstrator (gloverec record, "
                                "gloverec calibrate --wrist): give the emulator another motion")  # fmt: skip
        motion = wearer
    elif kind in CALIBRATION:
        motion = ProcedureMotion("gestures", config.seed, config.rate_hz, pinch=kind == "calibration_pinch")
    elif kind == "doctor":
        motion = CheckupMotion(config.seed, config.rate_hz)
    else:
        motion = kind
    link = EmulatedLink(Emulator(config.rate_hz, config.mode, motion, seed=config.seed), realtime, **options)
    known = {"glove_id": link.emulator.glove_id, "raw": config.mode == "raw", "rest_angles": rest_angles}
    link.expects = {} if kind in (*CALIBRATION, "doctor") else known
    return link
