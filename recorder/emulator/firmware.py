"""Firmware in the loop: the glove's compiled C++ core as the emulator's firmware.

``FirmwareCore`` runs ``glove_core_cli run --live`` (firmware/tools/glove_core_cli.cpp, the very code of
firmware/lib/glove_core) as a child process: register counts of the 12 IMUs go in once per sensing cycle, the
bytes the glove would send come out, host commands go back in through a FIFO. ``build_core()`` builds it with
the machine's cmake and g++ (into build/firmware, as tests/test_firmware.py does).

The core stamps its frames with the ``t_us`` given to ``feed`` (by default the host's CLOCK_MONOTONIC in µs, as
the Python emulator does; status frames then say so), so the link's latency figures stay meaningful. With
``sync`` (the default) ``feed`` returns once the core has finished that cycle: ``read()`` right after it holds
every frame of the cycle, and nothing lags behind by a cycle.

``RestThenMove`` wraps a Motion: the hand first rests flat (the model's zero pose: the reference pose the core
calibrates in) for ``rest_s``, then blends into the motion. The core's boot calibration refuses a moving hand,
so without such a start it never sends a pose.
"""

from __future__ import annotations

import os
import select
import shutil
import struct
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

from recorder import quat
from recorder.hand.kinematics import N_JOINTS
from recorder.hand.motion import MotionBlock, SampledMotion, min_jerk
from recorder.paths import checkout_dir

REPO = checkout_dir() or Path.cwd()  # installed from a wheel: there are no firmware sources to build
FIRMWARE_DIR = REPO / "firmware"
BUILD_DIR = REPO / "build" / "firmware"
MODES = ("raw", "pose", "json", "compact")  # recorder.protocol.Mode values 0..3
_DEG = np.pi / 180.0


class FirmwareError(RuntimeError):
    """The core cannot be built or started, or it stopped."""


def build_core(
    build_dir: Path | str = BUILD_DIR, target: str | None = "glove_core_cli", source_dir: Path | str = FIRMWARE_DIR
) -> Path:
    """Configure (once) and build firmware/ with cmake + g++; returns the path of glove_core_cli. ``target``
    None builds everything (unit tests, benchmark). Incremental: cheap when nothing changed."""
    missing = [tool for tool in ("cmake", "g++") if shutil.which(tool) is None]
    if missing:
        raise FirmwareError(
            f"building the glove core needs {' and '.join(missing)} on PATH (e.g. apt-get install cmake g++)"
        )
    source_dir, build_dir = Path(source_dir), Path(build_dir)
    if not (source_dir / "CMakeLists.txt").exists():
        raise FirmwareError(f"no firmware sources at {source_dir} (firmware in the loop needs a repository checkout)")
    steps = [
        ["cmake", "--build", str(build_dir), "-j", str(os.cpu_count() or 2)] + (["--target", target] if target else [])
    ]
    if not (build_dir / "CMakeCache.txt").exists():
        steps.insert(0, ["cmake", "-S", str(source_dir), "-B", str(build_dir)])
    for cmd in steps:
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode:
            raise FirmwareError(f"{' '.join(cmd)} failed:\n{done.stdout[-4000:]}\n{done.stderr[-4000:]}")
    return build_dir / "glove_core_cli"


def counts_to_sample(raw, accel_fs_g: int = 16, gyro_fs_dps: int = 2000, ok_mask: int | None = None) -> np.ndarray:
    """Register counts (n_imu, 7) -> the CLI's float32 input (n_imu, 6): gx gy gz in rad/s, ax ay az in g; NaN
    rows for IMUs whose ok_mask bit is clear. The core quantises them back to exactly these counts (at its own
    ±16 g / ±2000 dps, the real glove's settings)."""
    raw = np.asarray(raw)
    out = np.empty((raw.shape[0], 6), np.float32)
    out[:, :3] = raw[:, 3:6] * (gyro_fs_dps * _DEG / 32768.0)
    out[:, 3:] = raw[:, 0:3] * (accel_fs_g / 32768.0)
    if ok_mask is not None:
        out[(int(ok_mask) >> np.arange(len(out))) & 1 == 0] = np.nan
    return out


def monotonic_us() -> int:
    """The emulator's device clock: host CLOCK_MONOTONIC in µs, wrapping at 2^32 as micros() does."""
    return time.monotonic_ns() // 1000 & 0xFFFFFFFF


class FirmwareCore:
    """The compiled glove core as a child process. Use as a context manager or call ``close()``."""

    def __init__(
        self,
        cli: Path | str | None = None,
        sense_hz: int = 200,
        output_hz: int = 100,
        mode: str = "pose",
        clock_host: bool = True,
        calib_samples: int = 256,
        n_imu: int = 12,
        glove_id: int = 0xF1F1_0001,
        sync: bool = True,
        timeout_s: float = 5.0,
    ):
        """cli: glove_core_cli (None: ``build_core()``). calib_samples: boot gyro calibration length, 0 = none
        (the hand must rest for that long: see RestThenMove). clock_host sets the status frames' clock flag."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, not {mode!r}")
        self.cli = str(cli or build_core())
        self.n_imu, self.sync, self.timeout_s = int(n_imu), bool(sync), float(timeout_s)
        self.cycles = 0
        self._dir = tempfile.mkdtemp(prefix="gloverec-fw-")
        fifo = os.path.join(self._dir, "rx")
        os.mkfifo(fifo)
        self._rx = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)  # read-write: opening never waits for the core
        ack_r, ack_w = os.pipe()
        args = [
            self.cli,
            "run",
            "--live",
            "--stamped",
            "--rx-fifo",
            fifo,
            "--ack-fd",
            str(ack_w),
            "--n-imu",
            str(n_imu),
            "--sense-rate",
            str(int(sense_hz)),
            "--output-rate",
            str(int(output_hz)),
            "--mode",
            mode,
            "--calib-samples",
            str(int(calib_samples)),
            "--glove-id",
            str(int(glove_id)),
        ]
        try:
            self.proc = subprocess.Popen(
                args + (["--clock-host"] if clock_host else []) + ["-"],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                pass_fds=(ack_w,),
            )
        except OSError as exc:
            os.close(ack_r)
            self._cleanup()
            raise FirmwareError(f"cannot start {self.cli}: {exc.strerror or exc}") from None
        finally:
            os.close(ack_w)
        self._ack = ack_r
        self._out = self.proc.stdout.fileno()
        os.set_blocking(self._out, False)
        self._buf = bytearray()
        self._button = False

    # ---------------------------------------------------------------------------------------------- I/O
    def feed(
        self, raw, accel_fs_g: int = 16, gyro_fs_dps: int = 2000, t_us: int | None = None, ok_mask: int | None = None
    ) -> None:
        """One sensing cycle: raw (n_imu, 7) int16 register counts (ax, ay, az, gx, gy, gz, temp) at the given
        full scales, sampled at device time t_us (default: now, host CLOCK_MONOTONIC µs)."""
        t = monotonic_us() if t_us is None else int(t_us) & 0xFFFFFFFF
        sample = counts_to_sample(raw, accel_fs_g, gyro_fs_dps, ok_mask)
        if sample.shape != (self.n_imu, 6):
            raise ValueError(f"raw needs shape ({self.n_imu}, 7), got {np.shape(raw)}")
        self._write(struct.pack("<IB", t, self._button) + sample.astype("<f4").tobytes())
        self._button = False
        self.cycles += 1
        if self.sync:
            self._wait_ack()

    def read(self) -> bytes:
        """Every byte the core has sent so far and not yet returned (never blocks)."""
        self._drain()
        out, self._buf = bytes(self._buf), bytearray()
        return out

    def send(self, data: bytes) -> None:
        """Host bytes (command frames, as read from the pty) for the core; it reads them before its next cycle."""
        view = memoryview(data)
        while view:
            try:
                view = view[os.write(self._rx, view) :]
            except BlockingIOError:  # the core is not reading commands (64 kB waiting): drop, as a full UART
                return

    def press_button(self) -> None:
        """The glove's reset button (pin 5): in the next cycle the core sends a button event and resets its
        reference pose."""
        self._button = True

    def close(self) -> int | None:
        """End the core (end of input) and return its exit status."""
        if getattr(self, "proc", None) is None:
            return None
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        try:
            self.proc.wait(timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self._drain()
        self.proc.stdout.close()
        self.proc.stderr.close()
        os.close(self._ack)
        self._cleanup()
        rc, self.proc = self.proc.returncode, None
        return rc

    def __enter__(self) -> FirmwareCore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ---------------------------------------------------------------------------------------------- internals
    def _drain(self) -> None:
        while True:
            try:
                chunk = os.read(self._out, 65536)
            except BlockingIOError:
                return
            if not chunk:
                return
            self._buf += chunk

    def _write(self, data: bytes) -> None:
        """Write to the core's stdin, draining its stdout meanwhile (so neither side can block the other)."""
        view = memoryview(data)
        stdin = self.proc.stdin.fileno()
        while view:
            self._check_alive()
            _, writable, _ = select.select([], [stdin], [], 0.01)
            if writable:
                try:
                    view = view[os.write(stdin, view) :]
                except BrokenPipeError:
                    self._check_alive(force=True)
            self._drain()

    def _wait_ack(self) -> None:
        deadline = time.monotonic() + self.timeout_s
        while True:
            readable, _, _ = select.select([self._ack, self._out], [], [], 0.05)
            self._drain()
            if self._ack in readable:
                if os.read(self._ack, 1):
                    return
                self._check_alive(force=True)
            self._check_alive()
            if time.monotonic() > deadline:
                raise FirmwareError(f"the glove core did not finish cycle {self.cycles} in {self.timeout_s} s")

    def _check_alive(self, force: bool = False) -> None:
        if self.proc.poll() is not None or force:
            self.proc.wait(timeout=self.timeout_s)
            err = self.proc.stderr.read().decode(errors="replace").strip()
            raise FirmwareError(f"the glove core exited with status {self.proc.returncode}: {err or 'no message'}")

    def _cleanup(self) -> None:
        if getattr(self, "_rx", None) is not None:
            os.close(self._rx)
            self._rx = None
        shutil.rmtree(self._dir, ignore_errors=True)


class RestThenMove(SampledMotion):
    """The hand rests flat in the model's zero pose with the palm level for ``rest_s``, then blends into
    ``motion`` over ``blend_s`` (minimum jerk); afterwards it is ``motion`` delayed by ``rest_s``. The core
    calibrates the gyros and takes its reference pose while it rests."""

    def __init__(self, motion: SampledMotion, rest_s: float = 1.5, blend_s: float = 1.0):
        super().__init__(motion.rate_hz)
        self.motion, self.rest_s, self.blend_s = motion, float(rest_s), float(blend_s)
        self._p0 = motion.at(np.zeros(1)).palm_pos[0]

    def at(self, t) -> MotionBlock:
        t = np.asarray(t, float)
        n = len(t)
        moving = t >= self.rest_s
        m = self.motion.at(np.maximum(t[moving] - self.rest_s, 0.0)) if moving.any() else None
        p0 = self._p0
        angles, palm_quat, palm_pos = np.zeros((n, N_JOINTS)), np.tile(quat.IDENTITY, (n, 1)), np.tile(p0, (n, 1))
        if m is not None:
            w = min_jerk(np.clip((t[moving] - self.rest_s) / self.blend_s, 0.0, 1.0))[:, None]
            angles[moving] = w * m.angles
            palm_quat[moving] = quat.from_rotvec(w * quat.to_rotvec(m.palm_quat))
            palm_pos[moving] = p0 + w * (m.palm_pos - p0)
        return MotionBlock(t, angles, palm_quat, palm_pos)
