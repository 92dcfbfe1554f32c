"""What a live view shows, passed from the process that records to the process that draws, never blocking the
first: ``ViewFrame`` (the scene's state, the human hand, the text) in a shared-memory slot that the writer
overwrites and the reader copies when it has a complete one (a sequence lock: the counter is odd while a frame is
written). The view only ever sees the newest frame; frames it is too slow for are skipped, and the writer never
waits for it. (multiprocessing's queues and pipes block or grow when the reader lags: a latest-value slot is the
structure this needs, and the standard library has no such thing.)"""

from __future__ import annotations

import json
import mmap
import os
import tempfile
from dataclasses import dataclass, field

import numpy as np

from recorder.hand.kinematics import N_JOINTS

TEXT_BYTES = 8192
WRIST_FLOATS = 7  # the tracked wrist's pose: position, quaternion (wxyz)


@dataclass(frozen=True)
class Layout:
    """The sizes of one scene's arrays: qpos, mocap bodies, actuators, the task's state (then the fixed ones: the
    human hand's, the tracked wrist's)."""

    nq: int
    nmocap: int
    nu: int
    ntask: int

    @property
    def floats(self) -> int:
        return self.nq + 7 * self.nmocap + self.nu + self.ntask + 4 + 2 * N_JOINTS + 1 + WRIST_FLOATS

    @property
    def size(self) -> int:
        return 8 + 8 * self.floats + 4 + TEXT_BYTES


@dataclass
class ViewFrame:
    """One view frame: the scene (qpos, mocap bodies, actuator targets, the task's state: goal or object), the
    human hand as the glove measures it (joint angles, palm, per-joint validity; ``hand`` False: none yet), and
    the status text (a JSON-able mapping, recorder/view/overlay.py). A free-wrist task adds the palm pose its
    wrist source gives (``wrist``: position in the robot's world, before the workspace's bounds clip it, and
    quaternion); its quality and the bounds it is pressed against are the status' ``wrist`` (recorder/view/wrist.py)."""

    qpos: np.ndarray
    mocap_pos: np.ndarray
    mocap_quat: np.ndarray
    ctrl: np.ndarray
    task: np.ndarray
    angles: np.ndarray = field(default_factory=lambda: np.zeros(N_JOINTS))
    palm: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    valid: np.ndarray = field(default_factory=lambda: np.zeros(N_JOINTS, bool))
    hand: bool = False
    status: dict = field(default_factory=dict)
    wrist: np.ndarray = field(default_factory=lambda: np.array([0.0, 0, 0, 1, 0, 0, 0]))


class SharedFrame:
    """The latest-frame slot: a memory-mapped file (in /dev/shm where there is one) that both processes map.
    ``SharedFrame.create(layout)`` in the writer, ``SharedFrame.attach(path, layout)`` in the reader; ``write``
    never waits, ``read`` returns the newest complete frame (None when there is no new one since the last read).
    (A plain file rather than multiprocessing.shared_memory: the resource tracker of Python 3.12 unlinks a
    segment when any process that attached it exits; ``track=False`` arrives only in 3.13.)"""

    def __init__(self, path: str, layout: Layout, owner: bool):
        self.path, self.layout, self.owner = path, layout, owner
        with open(path, "r+b") as f:
            self._map = mmap.mmap(f.fileno(), layout.size)
        buf = memoryview(self._map)
        self._seq = np.ndarray((1,), np.uint64, buf, 0)
        self._floats = np.ndarray((layout.floats,), np.float64, buf, 8)
        self._text_len = np.ndarray((1,), np.uint32, buf, 8 + 8 * layout.floats)
        self._text = np.ndarray((TEXT_BYTES,), np.uint8, buf, 8 + 8 * layout.floats + 4)
        self._read_seq = 0

    @classmethod
    def create(cls, layout: Layout) -> SharedFrame:
        folder = "/dev/shm" if os.path.isdir("/dev/shm") else None
        fd, path = tempfile.mkstemp(prefix="gloverec-view-", dir=folder)
        with os.fdopen(fd, "wb") as f:
            f.write(bytes(layout.size))
        return cls(path, layout, owner=True)

    @classmethod
    def attach(cls, path: str, layout: Layout) -> SharedFrame:
        return cls(path, layout, owner=False)

    def write(self, frame: ViewFrame) -> None:
        L = self.layout
        parts = [frame.qpos, frame.mocap_pos.reshape(-1), frame.mocap_quat.reshape(-1), frame.ctrl, frame.task,
                 frame.palm, frame.angles, frame.valid.astype(float), [float(frame.hand)], frame.wrist]  # fmt: skip
        flat = np.concatenate([np.asarray(p, float).reshape(-1) for p in parts])
        if flat.size != L.floats:
            raise ValueError(f"view frame of {flat.size} values for a layout of {L.floats}")
        text = json.dumps(frame.status, default=str).encode()[:TEXT_BYTES]
        self._seq[0] += 1  # odd: being written
        self._floats[:] = flat
        self._text[: len(text)] = np.frombuffer(text, np.uint8)
        self._text_len[0] = len(text)
        self._seq[0] += 1  # even: complete

    def read(self) -> ViewFrame | None:
        for _ in range(8):
            seq = int(self._seq[0])
            if seq == self._read_seq or seq == 0:
                return None
            if seq & 1:
                continue
            flat = self._floats.copy()
            n = int(self._text_len[0])
            text = self._text[: min(n, TEXT_BYTES)].tobytes()
            if int(self._seq[0]) == seq:
                self._read_seq = seq
                return self._unpack(flat, text)
        return None

    def _unpack(self, flat: np.ndarray, text: bytes) -> ViewFrame:
        L = self.layout
        sizes = [L.nq, 3 * L.nmocap, 4 * L.nmocap, L.nu, L.ntask, 4, N_JOINTS, N_JOINTS, 1, WRIST_FLOATS]
        qpos, mpos, mquat, ctrl, task, palm, angles, valid, hand, wrist = np.split(flat, np.cumsum(sizes)[:-1])
        try:
            status = json.loads(text or b"{}")
        except ValueError:
            status = {}
        return ViewFrame(qpos, mpos.reshape(-1, 3), mquat.reshape(-1, 4), ctrl, task, angles, palm, valid > 0.5,
                         bool(hand[0] > 0.5), status, wrist)  # fmt: skip

    def close(self) -> None:
        self._seq = self._floats = self._text_len = self._text = None
        try:
            self._map.close()
        except BufferError:  # a view of it is still alive somewhere: the OS frees it with the process
            pass
        if self.owner:
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
