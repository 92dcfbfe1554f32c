"""Serve a synthetic glove on a pseudo-terminal, speaking the wire protocol byte for byte.

The pty slave is what a reader opens (``port: /dev/pts/N``, or a stable symlink ``link``, as udev gives real
gloves under /dev/serial/by-id). ``unplug()`` closes the pty and removes the symlink, ``replug()`` makes a
new one at the same symlink: the reader sees the port vanish and come back, as with a USB cable.
The device clock is the host's CLOCK_MONOTONIC in µs (status frames say so), so latency is measurable.
"""

from __future__ import annotations

import errno
import os
import select
import threading
import time
import tty

import numpy as np

from recorder import GloverecError
from recorder.emulator.faults import FaultyGlove
from recorder.emulator.firmware import FirmwareCore, FirmwareError, RestThenMove, build_core
from recorder.emulator.glove import SyntheticGlove
from recorder.hand.kinematics import joint_angles_from_relative
from recorder.hand.motion import Motion
from recorder.hand.skeleton import JOINT_MAP, MUX_MAP, N_IMUS
from recorder.protocol import StreamDecoder
from recorder.protocol.codec import encode_frame
from recorder.protocol.frames import (
    CLOCK_HOST_MONOTONIC,
    CalibState,
    Command,
    CommandCode,
    EventCode,
    EventFrame,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)
from recorder.protocol.legacy_json import encode_line

FIRMWARE = (0, 1, 0)  # the emulator reports itself as firmware 0.1.0
GLOVE_ID = 0xE0E0_0001
BLOCK_S = 0.05  # synthesise motion 50 ms at a time (short: less jitter for an in-process reader)
FAST_BLOCK_S = 0.5  # bulk generation: larger blocks amortise the synthesis
MAX_PENDING = 16 * 1024  # bytes held back while the reader is slow; beyond this, frames are dropped


class Emulator:
    def __init__(
        self,
        rate_hz: float = 200.0,
        mode: str = "pose",
        motion="gestures",
        seed: int = 0,
        link: str | None = None,
        keep_truth: bool = False,
        firmware: bool = False,
        glove_id: int = GLOVE_ID,
        faults=(),
    ):
        """``motion``: a Motion kind or a Motion-like object. ``firmware``: run the compiled glove core
        (firmware/lib/glove_core) on the synthetic IMU readings instead of encoding frames here: the bytes on
        the pty are then exactly what the real glove's code sends (firmware in the loop). ``glove_id``: what
        the status frames say; it also seeds the IMUs' own errors (turn-on gyro bias, accelerometer offsets),
        so one emulated glove keeps its errors across sessions and seeds, as hardware does, and a calibration
        saved for it (`gloverec calibrate --glove emulator`) holds for every recording with it. ``faults``: build
        errors in its raw frames (recorder/emulator/faults.py: "swap:3,4", "rotate:5:180", ... or Faults)."""
        self.sense_hz = float(rate_hz)  # synthesis ("sensing") rate, fixed
        self.output_hz = float(rate_hz)  # frame rate; SET_RATE lowers it (at most the sensing rate)
        self.mode = Mode[mode.upper()]
        self.core = None
        self.faults = FaultyGlove(faults, seed)
        if firmware and self.faults:
            raise GloverecError("--fault acts on the emulator's own frames: drop --firmware")
        if firmware:
            motion = self._start_core(motion, seed, mode)
        self.glove_id = int(glove_id)
        self.glove = SyntheticGlove(motion=motion, rate_hz=self.sense_hz, seed=seed, unit_seed=self.glove_id)
        self.link = link
        self.seq = 0
        self.sent_frames = 0
        self.dropped_frames = 0  # frames a slow reader had no room for
        self.unread_frames = 0  # frames written while no reader had the port open
        self.port: str | None = None
        self._master: int | None = None
        self._pending = b""
        self._commands = StreamDecoder("binary", sequenced=False)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None  # start(): run in the background
        self.truth_rows: list | None = [] if keep_truth else None  # ground truth per frame sent
        self.realtime = True
        self.horizon_s = 0.0  # session time up to which motion has been synthesised (fixed from then on)
        self.t0_us = None
        self.lead_s = None  # faster than real time: synthesise no block that starts after this session
        self._lead = threading.Condition()  # time (None: no limit); a reader raises it with allow()
        self.fast_block_s = FAST_BLOCK_S  # faster than real time, blocks this long (a performer shortens them
        # while a wearer who watches corrects the motion: a block once synthesised is fixed)
        self._buttons: list[float] = []
        # The buttons have a lock of their own: the port's is held while a fast write waits for the reader, and the
        # reader may be waiting for the recording loop to take its frames, the loop that schedules the buttons.
        self._buttons_lock = threading.Lock()
        self._requests: list[str] = []
        self._t_us = time.monotonic_ns() // 1000

    def _start_core(self, motion, seed: int, mode: str):

        try:
            self.core = FirmwareCore(build_core(), int(self.sense_hz), int(self.output_hz), mode)
        except FirmwareError as exc:
            raise GloverecError(f"firmware in the loop: {exc}") from None
        if isinstance(motion, str):
            motion = Motion(motion, seed=seed, rate_hz=self.sense_hz)
        return RestThenMove(motion, rest_s=2.0)  # the core calibrates its gyros on a resting hand at boot

    # ------------------------------------------------------------ the pseudo-terminal
    def plug(self) -> str:
        with self._lock:
            self._master, slave = os.openpty()
            tty.setraw(slave)  # no echo, no newline translation: the line carries bytes
            self.port = os.ttyname(slave)
            # Not holding the slave open makes the pty behave like a USB CDC device: with no reader the
            # bytes are discarded, with a slow reader the buffer fills and frames are dropped (counted).
            os.close(slave)
            os.set_blocking(self._master, False)
            self._poll = select.poll()
            self._poll.register(self._master, select.POLLOUT)
            if self.link:
                tmp = f"{self.link}.tmp{os.getpid()}"
                os.symlink(self.port, tmp)
                os.replace(tmp, self.link)
            self._pending = b""
            self._commands.reset()
        if self.core is None:  # the core sends its own boot frames
            self._write(self._status() + self._event(EventCode.BOOT))
        return self.link or self.port

    def request(self, what: str) -> None:
        """Unplug or replug from a signal handler or another thread: done by the streaming loop at its next
        sample (a handler that took the lock itself could deadlock against the interrupted write)."""
        self._requests.append(what)

    def _serve_requests(self) -> None:
        while self._requests:
            what = self._requests.pop(0)
            if what == "unplug" and self.plugged:
                self.unplug()
            elif what == "replug" and not self.plugged:
                self.replug()

    def unplug(self) -> None:
        with self._lock:
            if self.link and os.path.islink(self.link):
                os.unlink(self.link)
            if self._master is not None:
                os.close(self._master)
            self._master = None

    def replug(self) -> str:
        return self.plug()

    @property
    def plugged(self) -> bool:
        return self._master is not None

    # ------------------------------------------------------------ streaming
    def stop(self) -> None:
        self._stop.set()

    def run(self, duration: float | None = None, realtime: bool = True) -> None:
        """Sense at the glove's rate and output at ``output_hz`` until ``duration`` s pass or ``stop()``.

        ``realtime=False`` (bulk generation): no pacing, a virtual device clock, and writes that wait for the
        reader instead of dropping frames, so nothing is lost however fast the reader runs."""
        if not self.plugged:
            self.plug()
        self.realtime = realtime
        period = 1.0 / self.sense_hz
        start = time.monotonic()
        t0_us = time.monotonic_ns() // 1000
        self.t0_us = t0_us & 0xFFFFFFFF  # device clock at session time 0 (faster than real time)
        next_status = next_out = 0.0
        k = 0
        block, i = None, 0
        batch: list[bytes] = []
        while not self._stop.is_set():
            self._serve_requests()
            t = k * period  # session time of this sample
            if duration is not None and t >= duration:
                break
            if realtime:
                delay = start + t - time.monotonic()
                if delay > 0:
                    self._stop.wait(delay)
                elif delay < -1.0:  # suspended or starved: resynchronise instead of bursting
                    start -= delay
                self._t_us = time.monotonic_ns() // 1000
            else:
                self._t_us = t0_us + round(t * 1e6)
            if block is None or i == len(block.t):
                if not realtime and not self._wait_for_lead(t):
                    break
                block_s = BLOCK_S if realtime else self.fast_block_s
                block, i = self.glove.next_block(max(1, int(block_s * self.sense_hz)), raw=self._reads_raw()), 0
                self.horizon_s = float(block.t[-1]) + period
            if self.core is not None:
                self._firmware_cycle(block, i)
            elif self.plugged and t >= next_out - 1e-9:
                next_out += 1.0 / self._send_hz()
                self._poll_commands()
                data = self._due_buttons(float(block.t[i])) + self._encode(block, i)
                if t >= next_status:
                    data += self._status()
                    next_status = t + 1.0
                if realtime:
                    self._write(data)
                else:  # bulk generation: one write per block, not per frame (fewer syscalls and wake-ups)
                    batch.append(data)
                    if i == len(block.t) - 1:
                        self._write(b"".join(batch))
                        batch.clear()
            i += 1
            k += 1

    def _reads_raw(self) -> bool:
        """Whether the next block needs the IMUs' readings: raw frames, or the firmware, which fuses them."""
        return self.core is not None or self.mode == Mode.RAW

    def _send_hz(self) -> float:
        """Frames per second actually sent: the output rate, or a slower one a ``rate`` fault imposes (the status
        frames still announce ``output_hz``)."""
        return min(self.output_hz, self.faults.rate_hz or self.output_hz)

    def stream(self, duration: float, status_s: float = 1.0):
        """The bytes the glove would send over ``duration`` s of its own clock, block by block, with no pty and
        no pacing (tests and benchmarks decode them as a host would): frames, a status frame every ``status_s``."""
        self.realtime = False
        period = 1.0 / self.sense_hz
        self.t0_us = t0_us = 0
        next_out = 0.0
        next_status = 0.0
        k = 0
        while k * period < duration:
            block = self.glove.next_block(max(1, int(self.fast_block_s * self.sense_hz)), raw=self._reads_raw())
            self.horizon_s = float(block.t[-1]) + period
            out = []
            for i in range(len(block.t)):
                t = k * period
                k += 1
                if t >= duration:
                    break
                self._t_us = t0_us + round(t * 1e6)
                if t >= next_status:
                    out.append(self._status())
                    next_status = t + status_s
                if t >= next_out - 1e-9:
                    next_out += 1.0 / self._send_hz()
                    out.append(self._encode(block, i))
            yield b"".join(out)

    def allow(self, t_s: float) -> None:
        """Faster than real time: let the synthesis run up to session time ``t_s`` (see ``lead_s``)."""
        with self._lead:
            if self.lead_s is not None and t_s > self.lead_s:
                self.lead_s = t_s
                self._lead.notify_all()

    def _wait_for_lead(self, t: float) -> bool:
        """Bulk generation paced by its reader: nothing is synthesised (and thrown away) far ahead of the
        frames the reader needs. False when stopped while waiting."""
        with self._lead:
            while self.lead_s is not None and t > self.lead_s and not self._stop.is_set():
                self._lead.wait(0.1)
        return not self._stop.is_set()

    def _firmware_cycle(self, block, i: int) -> None:
        """One sensing cycle of the compiled core: readings in, its frames out, host commands through."""
        if self._due_buttons(float(block.t[i])):
            self.core.press_button()
        self.core.feed(block.raw[i], block.accel_fs_g, block.gyro_fs_dps, t_us=self._now_us())
        if self.plugged:
            host = self._read_host()
            if host:
                for cmd in self._commands.feed(host):  # the core obeys; the emulated wearer may take a cue
                    if isinstance(cmd, Command) and cmd.code == CommandCode.SET_MODE and cmd.arg in iter(Mode):
                        self._mode_cue(Mode(cmd.arg))
                        self.mode = Mode(cmd.arg)
                self.core.send(host)
            self._write(self.core.read())
        else:
            self.core.read()

    def schedule_button(self, at_s: float) -> None:
        """Press the reset button when the motion reaches session time ``at_s`` (the demonstrator's cue)."""
        with self._buttons_lock:
            self._buttons.append(at_s)
            self._buttons.sort()

    def _due_buttons(self, t: float) -> bytes:
        out = b""
        with self._buttons_lock:
            while self._buttons and t >= self._buttons[0] - 1e-9:
                self._buttons.pop(0)
                out += self._event(EventCode.BUTTON)
        return out

    def _now_us(self) -> int:
        return self._t_us & 0xFFFFFFFF

    def _encode(self, block, i: int) -> bytes:
        t_us = self._now_us()
        if self.mode == Mode.JSON:
            data, seq = encode_line(block.pose[i]), -1
        elif self.mode == Mode.POSE:
            data, seq = encode_frame(PoseFrame(self._next_seq(), t_us, block.pose[i])), self.seq
        elif self.mode == Mode.COMPACT:
            angles = joint_angles_from_relative(block.pose[i].astype(np.float64))
            data = encode_frame(PoseCompactFrame(self._next_seq(), t_us, block.pose[i][0], angles))
            seq = self.seq
        elif block.raw is None:  # switched to raw mode within a block synthesised without readings: they start
            return b""  # with the next block (50 ms on; 0.5 s of glove time faster than real time)
        else:
            raw, ok_mask = block.raw[i], (1 << N_IMUS) - 1
            if self.faults:
                raw, ok_mask = self.faults.apply(float(block.t[i]), raw, ok_mask)
            data = encode_frame(RawFrame(self._next_seq(), t_us, raw, block.accel_fs_g, block.gyro_fs_dps, ok_mask))
            seq = self.seq
        if self.truth_rows is not None:
            self.truth_rows.append(
                (
                    seq,
                    t_us,
                    block.t[i],
                    block.angles[i],
                    block.truth_rel[i],
                    block.tips[i],
                    block.palm_quat[i],
                    block.palm_pos[i],
                )
            )
        return data

    def save_truth(self, path: str) -> int:
        """Write the ground truth of every frame sent, keyed by seq and t_us, to an .npz; returns the count."""
        rows = self.truth_rows or []
        cols = list(zip(*rows)) or [()] * 8
        names = ("seq", "t_us", "t", "angles", "rel_quats", "tips", "palm_quat", "palm_pos")
        np.savez_compressed(path, **{k: np.array(v) for k, v in zip(names, cols)})
        return len(rows)

    def _next_seq(self) -> int:
        self.seq = (self.seq + 1) & 0xFFFF
        return self.seq

    # Status and event frames are binary; in legacy JSON mode the glove sends nothing but JSON lines, as
    # the thesis prototype did, so a legacy reader is never confused.
    def _event(self, code: EventCode, arg: int = 0) -> bytes:
        if self.mode == Mode.JSON:
            return b""
        return encode_frame(EventFrame(self._next_seq(), self._now_us(), code, arg))

    def _status(self) -> bytes:
        if self.mode == Mode.JSON:
            return b""
        return encode_frame(
            StatusFrame(
                self._next_seq(),
                self._now_us(),
                FIRMWARE,
                self.mode,
                int(self.sense_hz),
                int(self.output_hz),
                CalibState.DONE,
                100,
                CLOCK_HOST_MONOTONIC if self.realtime else 0,
                self.glove_id,
                (1 << N_IMUS) - 1,
                MUX_MAP,
                JOINT_MAP,
            )
        )

    def _write(self, data: bytes) -> None:
        """Non-blocking write; a frame that does not fit behind a slow reader is dropped whole."""
        with self._lock:
            if self._master is None or not data:
                return
            if not self.realtime:
                self._write_all(data)
                return
            events = self._poll.poll(0)  # none: the reader's buffer is full (the write below goes to pending)
            if events and events[0][1] & select.POLLHUP:  # no reader has the port open: bytes go nowhere
                self._pending = b""
                self.unread_frames += 1
                return
            buf = self._pending + data
            try:
                n = os.write(self._master, buf)
            except BlockingIOError:
                n = 0
            except OSError as exc:
                if exc.errno != errno.EIO:  # EIO: the pty is going away
                    raise
                n = len(buf)
            self._pending = buf[n:]
            if len(self._pending) > MAX_PENDING:
                self.dropped_frames += 1
                self._pending = self._pending[: len(self._pending) - len(data)]
            else:
                self.sent_frames += 1

    def _write_all(self, data: bytes) -> None:
        """Bulk generation: wait for room rather than drop (the reader sets the pace)."""
        view = memoryview(data)
        while view and not self._stop.is_set():
            try:
                view = view[os.write(self._master, view) :]
            except BlockingIOError:
                self._poll.poll(50)
            except OSError:
                return
        self.sent_frames += 1

    # ------------------------------------------------------------ host commands
    def _read_host(self) -> bytes:
        try:
            return os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return b""

    def _poll_commands(self) -> None:
        for cmd in self._commands.feed(self._read_host()):
            if isinstance(cmd, Command):
                self._apply(cmd)

    def _apply(self, cmd: Command) -> None:
        if cmd.code == CommandCode.SET_MODE and cmd.arg in iter(Mode):
            self._mode_cue(Mode(cmd.arg))
            self.mode = Mode(cmd.arg)
        elif cmd.code == CommandCode.SET_RATE and cmd.arg > 0:
            self.output_hz = min(float(cmd.arg), self.sense_hz)
        elif cmd.code == CommandCode.RESET_POSE:
            self._write(self._event(EventCode.POSE_RESET))
        elif cmd.code == CommandCode.RECALIBRATE:
            self._write(self._event(EventCode.CALIB_START) + self._event(EventCode.CALIB_DONE))
        self._write(self._status())

    def _mode_cue(self, mode: Mode) -> None:
        """A wearer who calibrates when asked (recorder/emulator/procedure.py OnRequest) starts the procedure when
        the host switches the glove into raw mode: what `gloverec calibrate` does first."""
        restart = getattr(self.glove.motion, "restart", None)
        if restart is not None and mode == Mode.RAW and self.mode != Mode.RAW:
            restart(self.horizon_s)

    def press_button(self) -> None:
        """The reset button: an event, as the glove sends when pin 5 goes low."""
        if self.core is not None:
            self.core.press_button()
        else:
            self._write(self._event(EventCode.BUTTON))

    def start(self, duration: float | None = None, realtime: bool = True) -> None:
        """``run`` in a background thread (an in-process glove: the recorder, `gloverec calibrate`);
        ``close`` stops and joins it."""
        self._thread = threading.Thread(
            target=self.run, args=(duration,), kwargs={"realtime": realtime}, name="gloverec-emulator", daemon=True
        )
        self._thread.start()

    def close(self) -> None:
        self.stop()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self.plugged:
            self.unplug()
        if self.core is not None:
            self.core.close()
