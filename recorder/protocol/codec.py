"""Binary codec: one frame <-> one COBS-framed, CRC-checked byte string (docs/protocol.md).

Layout before COBS, little-endian: version u8 | kind u8 | seq u16 | t_us u32 | payload | crc32 u32.
The CRC is CRC-32/ISO-HDLC (zlib.crc32) over everything before it. On the wire each frame is COBS-encoded
and followed by a single 0x00, so a reader that lands in the middle of garbage resynchronises at the next zero.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
from cobs import cobs

from recorder.protocol.frames import (
    ANGLE_LSB,
    ANGLE_MISSING,
    N_ANGLES,
    Q14,
    VERSION,
    CalibState,
    Command,
    CommandCode,
    EventCode,
    EventFrame,
    Frame,
    FrameKind,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)

HEADER = struct.Struct("<BBHI")
CRC = struct.Struct("<I")
POSE_PAYLOAD = 2 + 16 * 4 * 2
POSE_COMPACT_PAYLOAD = 4 * 2 + N_ANGLES // 2 * 3  # palm Q14, then 20 x 12 bits, two per three bytes
RAW_HEAD = struct.Struct("<BBHH")  # n_imu, accel_fs_g, gyro_fs_dps, ok_mask
STATUS_HEAD = struct.Struct("<BBBBHHBBBIHB")
EVENT = struct.Struct("<BB")
MAX_FRAME = 1024  # no valid frame is longer (raw with 16 IMUs: 8 + 6 + 224 + 4); longer input is garbage

_POSE_I16 = np.dtype("<i2")
_ACCEL_FS = (2, 4, 8, 16)
_GYRO_FS = (250, 500, 1000, 2000)


class FrameError(ValueError):
    """A byte string that is not a valid frame. ``crc`` tells a checksum mismatch from a format error."""

    def __init__(self, message: str, crc: bool = False):
        super().__init__(message)
        self.crc = crc


# ---------------------------------------------------------------- encoding


def q14(values) -> np.ndarray:
    """Quaternion components in fixed point Q14: rint(v * 16384) (ties to even), saturated; NaN gives 0."""
    # ufuncs only: np.nan_to_num and np.clip's Python wrappers cost more than the arithmetic, on every frame
    v = np.minimum(np.maximum(np.rint(np.asarray(values, np.float64) * Q14), -32768.0), 32767.0)
    return np.where(np.isnan(v), 0.0, v).astype(_POSE_I16)


def angle_counts(angles) -> np.ndarray:
    """Joint angles (rad) as pose_compact's 12-bit integers of 0.1 degree: rint(a * 1800 / pi) (ties to even),
    saturated to +-2047; NaN gives ANGLE_MISSING (-2048)."""
    x = np.asarray(angles, np.float64) * (1800.0 / np.pi)
    return np.where(np.isnan(x), ANGLE_MISSING, np.clip(np.rint(np.nan_to_num(x)), -2047, 2047)).astype(np.int16)


def pack12(values) -> bytes:
    """Pairs of 12-bit two's-complement fields a, b as the little-endian 24-bit a | b << 12."""
    v = np.asarray(values, np.int32).reshape(-1, 2) & 0xFFF
    u = v[:, 0] | v[:, 1] << 12
    return np.stack((u & 0xFF, u >> 8 & 0xFF, u >> 16), axis=1).astype(np.uint8).tobytes()


def unpack12(data) -> np.ndarray:
    b = np.frombuffer(data, np.uint8).reshape(-1, 3).astype(np.int32)
    u = b[:, 0] | b[:, 1] << 8 | b[:, 2] << 16
    v = np.stack((u & 0xFFF, u >> 12), axis=1).reshape(-1)
    return (v - ((v & 0x800) << 1)).astype(np.int16)


def _payload(frame: Frame) -> bytes:
    if isinstance(frame, PoseFrame):
        q = q14(frame.quats)
        if q.shape != (16, 4):
            raise ValueError(f"pose needs 16 quaternions, got shape {q.shape}")
        return struct.pack("<H", frame.measured_mask & 0xFFFF) + q.tobytes()
    if isinstance(frame, PoseCompactFrame):
        palm, angles = q14(frame.palm_quat), angle_counts(frame.angles)
        if palm.shape != (4,) or angles.shape != (N_ANGLES,):
            raise ValueError(
                f"pose_compact needs a palm quaternion (4,) and {N_ANGLES} angles, got shapes "
                f"{palm.shape} and {angles.shape}"
            )
        return palm.tobytes() + pack12(angles)
    if isinstance(frame, RawFrame):
        data = np.asarray(frame.data).astype(_POSE_I16)
        if data.ndim != 2 or data.shape[1] != 7 or not 1 <= data.shape[0] <= 16:
            raise ValueError(f"raw data needs shape (n_imu<=16, 7), got {data.shape}")
        return RAW_HEAD.pack(data.shape[0], frame.accel_fs_g, frame.gyro_fs_dps, frame.ok_mask) + data.tobytes()
    if isinstance(frame, StatusFrame):
        n = len(frame.joint_map)
        if len(frame.mux_map) != n:
            raise ValueError("mux_map and joint_map differ in length")
        head = STATUS_HEAD.pack(
            *frame.firmware,
            int(frame.mode),
            frame.sense_rate_hz,
            frame.output_rate_hz,
            int(frame.calib_state),
            frame.calib_progress,
            frame.clock_flags,
            frame.glove_id,
            frame.imu_ok_mask,
            n,
        )
        return head + bytes(frame.mux_map) + bytes(frame.joint_map)
    if isinstance(frame, EventFrame):
        return EVENT.pack(int(frame.code), frame.arg)
    if isinstance(frame, Command):
        if frame.code == CommandCode.SET_RATE:
            return struct.pack("<BH", int(frame.code), frame.arg)
        if frame.code == CommandCode.SET_MODE:
            return struct.pack("<BB", int(frame.code), frame.arg)
        return struct.pack("<B", int(frame.code))
    raise TypeError(f"not a frame: {type(frame).__name__}")


def frame_body(frame: Frame) -> bytes:
    """The unframed bytes: header, payload and CRC."""
    body = HEADER.pack(VERSION, int(frame.kind), frame.seq & 0xFFFF, frame.t_us & 0xFFFFFFFF) + _payload(frame)
    return body + CRC.pack(zlib.crc32(body))


def encode_frame(frame: Frame) -> bytes:
    """The bytes on the wire: COBS(body) followed by the 0x00 delimiter."""
    return cobs.encode(frame_body(frame)) + b"\x00"


def encode_command(code: CommandCode, arg: int = 0, seq: int = 0) -> bytes:
    return encode_frame(Command(CommandCode(code), arg, seq))


# ---------------------------------------------------------------- decoding


def decode_frame(chunk: bytes) -> Frame:
    """Decode one COBS chunk (without its 0x00 delimiter). Raises FrameError on anything invalid."""
    if len(chunk) > MAX_FRAME + MAX_FRAME // 254 + 2:
        raise FrameError(f"chunk of {len(chunk)} bytes is longer than any frame")
    try:
        body = cobs.decode(chunk)
    except cobs.DecodeError as exc:
        raise FrameError(f"bad COBS: {exc}") from None
    return decode_body(body)


def decode_body(body: bytes) -> Frame:
    if len(body) < HEADER.size + CRC.size:
        raise FrameError(f"frame of {len(body)} bytes is shorter than a header")
    (crc,) = CRC.unpack_from(body, len(body) - 4)
    if zlib.crc32(memoryview(body)[:-4]) != crc:
        raise FrameError("CRC mismatch", crc=True)
    version, kind, seq, t_us = HEADER.unpack_from(body)
    if version != VERSION:
        raise FrameError(f"unknown protocol version {version}")
    payload = memoryview(body)[HEADER.size : -4]
    try:
        decoder = _DECODERS[kind]
    except KeyError:
        raise FrameError(f"unknown frame kind 0x{kind:02x}") from None
    try:
        return decoder(seq, t_us, payload)
    except (struct.error, ValueError) as exc:  # wrong length, out-of-range enum value
        raise FrameError(f"bad {FrameKind(kind).name.lower()} payload: {exc}") from None


def _decode_pose(seq: int, t_us: int, p: memoryview) -> PoseFrame:
    if len(p) != POSE_PAYLOAD:
        raise ValueError(f"{len(p)} bytes, expected {POSE_PAYLOAD}")
    (mask,) = struct.unpack_from("<H", p)
    q = np.frombuffer(p, _POSE_I16, 64, 2).astype(np.float32).reshape(16, 4)
    q *= 1.0 / Q14
    return PoseFrame(seq, t_us, q, mask)


def _decode_pose_compact(seq: int, t_us: int, p: memoryview) -> PoseCompactFrame:
    if len(p) != POSE_COMPACT_PAYLOAD:
        raise ValueError(f"{len(p)} bytes, expected {POSE_COMPACT_PAYLOAD}")
    palm = np.frombuffer(p, _POSE_I16, 4).astype(np.float32) * np.float32(1.0 / Q14)
    counts = unpack12(p[8:])
    angles = np.where(counts == ANGLE_MISSING, np.nan, counts * ANGLE_LSB).astype(np.float32)
    return PoseCompactFrame(seq, t_us, palm, angles)


def _decode_raw(seq: int, t_us: int, p: memoryview) -> RawFrame:
    n, afs, gfs, ok = RAW_HEAD.unpack_from(p)
    if not 1 <= n <= 16 or len(p) != RAW_HEAD.size + 14 * n:
        raise ValueError(f"{len(p)} bytes for {n} IMUs")
    if afs not in _ACCEL_FS or gfs not in _GYRO_FS:
        raise ValueError(f"full scale ±{afs} g / ±{gfs} dps is not an MPU9250 setting")
    data = np.frombuffer(p, _POSE_I16, 7 * n, RAW_HEAD.size).reshape(n, 7).copy()
    return RawFrame(seq, t_us, data, afs, gfs, ok)


def _decode_status(seq: int, t_us: int, p: memoryview) -> StatusFrame:
    (ma, mi, pa, mode, sense, out, cstate, cprog, clock, glove_id, ok, n) = STATUS_HEAD.unpack_from(p)
    if len(p) != STATUS_HEAD.size + 2 * n or n > 16:
        raise ValueError(f"{len(p)} bytes for {n} IMUs")
    maps = bytes(p[STATUS_HEAD.size :])
    return StatusFrame(
        seq,
        t_us,
        (ma, mi, pa),
        Mode(mode),
        sense,
        out,
        CalibState(cstate),
        cprog,
        clock,
        glove_id,
        ok,
        tuple(maps[:n]),
        tuple(maps[n:]),
    )


def _decode_event(seq: int, t_us: int, p: memoryview) -> EventFrame:
    if len(p) != EVENT.size:
        raise ValueError(f"{len(p)} bytes")
    code, arg = EVENT.unpack(p)
    return EventFrame(seq, t_us, EventCode(code), arg)


def _decode_command(seq: int, t_us: int, p: memoryview) -> Command:
    code = CommandCode(p[0])
    if code == CommandCode.SET_RATE:
        (arg,) = struct.unpack("<H", p[1:])
    elif code == CommandCode.SET_MODE:
        if len(p) != 2:
            raise ValueError(f"{len(p)} bytes")
        arg = int(Mode(p[1]))
    else:
        if len(p) != 1:
            raise ValueError(f"{len(p)} bytes")
        arg = 0
    return Command(code, arg, seq, t_us)


_DECODERS = {
    FrameKind.POSE: _decode_pose,
    FrameKind.POSE_COMPACT: _decode_pose_compact,
    FrameKind.RAW: _decode_raw,
    FrameKind.STATUS: _decode_status,
    FrameKind.EVENT: _decode_event,
    FrameKind.COMMAND: _decode_command,
}
