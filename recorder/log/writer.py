"""Glove sessions to MCAP: the raw bytes as read (ground truth) plus decoded frames as JSON for Foxglove.

Time base. ``rx_ns`` is the host's ``time.monotonic_ns()`` when a chunk of bytes was read (GloveSource). Every
message's MCAP log_time and publish_time is ``rx_ns + log_time_offset_ns`` where ``log_time_offset_ns =
time.time_ns() - time.monotonic_ns()`` is sampled once when the log is opened: a wall-clock timeline (ns since
the Unix epoch, so Foxglove shows real dates) that keeps the monotonic spacing exactly. The offset is stored in
the session metadata and in the ``/glove/bytes`` channel metadata, so ``rx_ns = log_time - offset``.
Layout and crash behaviour: docs/logs.md.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import socket
import threading
import time

import numpy as np
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer

from recorder import GloverecError, __version__
from recorder.protocol.frames import (
    CLOCK_HOST_MONOTONIC,
    VERSION as PROTOCOL_VERSION,
    EventFrame,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)
from recorder.protocol.layout import JOINTS, SEGMENTS

LOG_FORMAT = "gloverec-log"
LOG_VERSION = 1
BYTES_TOPIC = "/glove/bytes"
BYTES_ENCODING = "gloverec.bytes"  # schemaless: each message is a chunk of transport bytes, exactly as read
POSE_TOPIC, RAW_TOPIC, STATUS_TOPIC, EVENT_TOPIC = "/glove/pose", "/glove/raw", "/glove/status", "/glove/event"
COMPACT_TOPIC = "/glove/pose_compact"
MARKS_TOPIC = "/gloverec/marks"
WRIST_TOPIC = "/wrist/pose"  # a tracker's poses as the recording's wrist fusion took them (docs/logs.md)
SESSION_METADATA = "gloverec.session"
GLOVE_METADATA = "gloverec.glove"
CHUNK_SIZE = 256 * 1024  # bytes (uncompressed) per MCAP chunk
MAX_CHUNK_S = 1.0  # a chunk is also closed when it is older than this (checked on each write)

_INT = {"type": "integer"}
_NUM = {"type": "number"}
_STR = {"type": "string"}
_XYZ = {"type": "object", "properties": {"x": _NUM, "y": _NUM, "z": _NUM}, "required": ["x", "y", "z"]}
_NUM_OR_NULL = {"type": ["number", "null"]}  # null: not finite (an untracked pose's position may be NaN)
_POSITION = {"type": "object", "properties": dict.fromkeys("xyz", _NUM_OR_NULL), "required": list("xyz")}
_QUAT = {"type": "object", "properties": dict.fromkeys("wxyz", _NUM_OR_NULL), "required": list("wxyz")}


def _schema(title: str, props: dict, desc: str) -> dict:
    head = {"seq": _INT, "t_us": _INT, "rx_ns": _INT}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": desc,
        "type": "object",
        "properties": head | props,
        "required": list(head | props),
    }


SCHEMAS = {
    POSE_TOPIC: _schema(
        "gloverec.Pose",
        {
            "measured_mask": _INT,
            "segments": {
                "type": "array",
                "minItems": 16,
                "maxItems": 16,
                "items": {
                    "type": "object",
                    "required": ["name", "measured", "w", "x", "y", "z"],
                    "properties": {
                        "name": _STR,
                        "measured": {"type": "boolean"},
                        "w": _NUM,
                        "x": _NUM,
                        "y": _NUM,
                        "z": _NUM,
                    },
                },
            },
        },
        "16 segment orientations relative to their parent (unit quaternions). t_us: device clock (µs, wraps "
        "at 2^32); rx_ns: host CLOCK_MONOTONIC at receipt.",
    ),
    RAW_TOPIC: _schema(
        "gloverec.Raw",
        {
            "n_imu": _INT,
            "accel_fs_g": _INT,
            "gyro_fs_dps": _INT,
            "ok_mask": _INT,
            "imus": {
                "type": "array",
                "items": {
                    "type": "object",
                    "required": ["index", "ok", "accel_g", "gyro_dps", "temperature_c"],
                    "properties": {
                        "index": _INT,
                        "ok": {"type": "boolean"},
                        "accel_g": _XYZ,
                        "gyro_dps": _XYZ,
                        "temperature_c": _NUM,
                    },
                },
            },
        },
        "MPU9250 readings in the IMU's own axes: acceleration in g, angular rate in deg/s, temperature in °C.",
    ),
    STATUS_TOPIC: _schema(
        "gloverec.Status",
        {
            "firmware": _STR,
            "mode": _STR,
            "sense_rate_hz": _INT,
            "output_rate_hz": _INT,
            "calib_state": _STR,
            "calib_progress": _INT,
            "clock_flags": _INT,
            "clock_host_monotonic": {"type": "boolean"},
            "glove_id": _INT,
            "imu_ok_mask": _INT,
            "n_imu": _INT,
            "mux_map": {"type": "array", "items": _INT},
            "joint_map": {"type": "array", "items": _INT},
        },
        "Glove status (docs/protocol.md).",
    ),
    COMPACT_TOPIC: _schema(
        "gloverec.PoseCompact",
        {
            "palm": {
                "type": "object",
                "properties": {"w": _NUM, "x": _NUM, "y": _NUM, "z": _NUM},
                "required": ["w", "x", "y", "z"],
            },
            "joints_deg": {"type": "object", "additionalProperties": {"type": ["number", "null"]}},
        },
        "Palm orientation (unit quaternion) and the 20 joint angles in degrees (null: not available).",
    ),
    EVENT_TOPIC: _schema(
        "gloverec.Event", {"code": _INT, "name": _STR, "arg": _INT}, "Glove event (docs/protocol.md)."
    ),
    MARKS_TOPIC: {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "gloverec.Mark",
        "type": "object",
        "description": "A recorder mark (episode start/end...). rx_ns: host CLOCK_MONOTONIC; log_time_ns: "
        "the MCAP log time (ns since the Unix epoch); time: the same as ISO 8601 UTC.",
        "properties": {"name": _STR, "fields": {"type": "object"}, "rx_ns": _INT, "log_time_ns": _INT, "time": _STR},
        "required": ["name", "fields", "rx_ns", "log_time_ns", "time"],
    },
}
WRIST_SCHEMA = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "gloverec.WristPose",
    "type": "object",
    "description": "A tracker's wrist pose as the recording's wrist fusion took it. seq: the tracker's counter; "
    "t: when the pose was measured and taken_t: when the fusion took it, both in s on the glove's device clock "
    "(the recording loop's clock); rx_ns: host CLOCK_MONOTONIC when it was logged; position (m) and quat (w, x, "
    "y, z) in the tracker's frame; alternative: a marker's other IPPE pose, or null; errors_px: a marker's "
    "reprojection error of each pose (px), or null.",
    "properties": {
        "seq": _INT,
        "t": _NUM,
        "taken_t": _NUM,
        "rx_ns": _INT,
        "position": _POSITION,
        "quat": _QUAT,
        "tracked": {"type": "boolean"},
        "alternative": {
            "type": ["object", "null"],
            "properties": {"position": _POSITION, "quat": _QUAT},
            "required": ["position", "quat"],
        },
        "errors_px": {"type": ["array", "null"], "items": _NUM},
    },
    "required": ["seq", "t", "taken_t", "rx_ns", "position", "quat", "tracked", "alternative", "errors_px"],
}


def _compression():

    try:
        import zstandard  # noqa: F401

        return CompressionType.ZSTD
    except ImportError:
        pass
    try:
        import lz4.frame  # noqa: F401

        return CompressionType.LZ4
    except ImportError:
        return CompressionType.NONE


def iso_utc(ns: int) -> str:
    """ns since the Unix epoch -> ISO 8601 UTC with microseconds."""
    return datetime.datetime.fromtimestamp(ns / 1e9, datetime.UTC).isoformat()


def _jsonable(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def _finite(values, axes: str) -> dict:
    return {a: (float(v) if np.isfinite(v) else None) for a, v in zip(axes, values)}


def wrist_json(pose, taken_t: float, rx_ns: int) -> dict:
    """The /wrist/pose message of a WristPose (recorder/wrist/format.py) taken at ``taken_t``; full precision, so
    a re-recording feeds the fusion the same numbers."""
    alt, errors = pose.alternative, getattr(pose, "errors_px", None)
    return {
        "seq": int(pose.seq),
        "t": float(pose.t),
        "taken_t": float(taken_t),
        "rx_ns": int(rx_ns),
        "position": _finite(pose.position, "xyz"),
        "quat": _finite(pose.quat, "wxyz"),
        "tracked": bool(pose.tracked),
        "alternative": None if alt is None else {"position": _finite(alt[0], "xyz"), "quat": _finite(alt[1], "wxyz")},
        "errors_px": None if errors is None else [float(e) for e in errors],
    }


def frame_json(frame) -> tuple[str, dict] | None:
    """(topic, JSON-ready dict) for a decoded frame; None for kinds that are not logged (commands)."""
    head = {"seq": frame.seq, "t_us": frame.t_us, "rx_ns": frame.rx_ns}
    if isinstance(frame, PoseFrame):
        q = np.round(np.asarray(frame.quats, np.float64), 6).tolist()
        segs = [
            {"name": SEGMENTS[i], "measured": bool(frame.measured_mask >> i & 1), "w": w, "x": x, "y": y, "z": z}
            for i, (w, x, y, z) in enumerate(q)
        ]
        return POSE_TOPIC, head | {"measured_mask": frame.measured_mask, "segments": segs}
    if isinstance(frame, PoseCompactFrame):
        deg = np.degrees(np.asarray(frame.angles, np.float64))
        joints = {j: (None if np.isnan(a) else round(float(a), 3)) for j, a in zip(JOINTS, deg)}
        palm = dict(zip("wxyz", np.round(np.asarray(frame.palm_quat, np.float64), 6).tolist()))
        return COMPACT_TOPIC, head | {"palm": palm, "joints_deg": joints}
    if isinstance(frame, RawFrame):
        acc = np.round(frame.accel_g, 6).tolist()
        gyr = np.round(frame.gyro_dps, 6).tolist()
        tmp = np.round(frame.temperature_c, 4).tolist()
        imus = [
            {
                "index": i,
                "ok": bool(frame.ok_mask >> i & 1),
                "accel_g": dict(zip("xyz", acc[i])),
                "gyro_dps": dict(zip("xyz", gyr[i])),
                "temperature_c": tmp[i],
            }
            for i in range(len(acc))
        ]
        return RAW_TOPIC, head | {
            "n_imu": len(imus),
            "accel_fs_g": frame.accel_fs_g,
            "gyro_fs_dps": frame.gyro_fs_dps,
            "ok_mask": frame.ok_mask,
            "imus": imus,
        }
    if isinstance(frame, StatusFrame):
        return STATUS_TOPIC, head | {
            "firmware": ".".join(map(str, frame.firmware)),
            "mode": frame.mode.name.lower(),
            "sense_rate_hz": frame.sense_rate_hz,
            "output_rate_hz": frame.output_rate_hz,
            "calib_state": frame.calib_state.name.lower(),
            "calib_progress": frame.calib_progress,
            "clock_flags": frame.clock_flags,
            "clock_host_monotonic": bool(frame.clock_flags & CLOCK_HOST_MONOTONIC),
            "glove_id": frame.glove_id,
            "imu_ok_mask": frame.imu_ok_mask,
            "n_imu": len(frame.joint_map),
            "mux_map": list(frame.mux_map),
            "joint_map": list(frame.joint_map),
        }
    if isinstance(frame, EventFrame):
        return EVENT_TOPIC, head | {"code": int(frame.code), "name": frame.code.name.lower(), "arg": frame.arg}
    return None


class McapLogger:
    """Writes a glove session to ``path``. Use as a GloveSource tap: ``source.taps.append(logger)``.

    ``metadata`` adds (or overrides) keys of the "gloverec.session" metadata record; ``source`` there is the
    glove source spec. ``calibration``: the session's fusion record (recorder/fusion/session.py fusion_record:
    glove id, calibration, fusion config), stored as the JSON string ``calibration`` of that record; when it is
    known only later (a real glove's id comes with its first frames), ``set_calibration`` writes it then, as a
    second "gloverec.session" record holding just that key (readers merge records of a name in file order).
    ``boundary`` says each chunk was a whole datagram (UDP), so playback feeds it the same way; by default it is
    True when ``metadata["source"]`` starts with "udp:". Thread-safe. A write error in
    the reader thread stops logging and is kept in ``error``; ``mark()`` and ``close()`` then raise it.
    """

    def __init__(
        self,
        path: str,
        metadata: dict | None = None,
        *,
        boundary: bool | None = None,
        chunk_size: int = CHUNK_SIZE,
        max_chunk_s: float = MAX_CHUNK_S,
        calibration: dict | None = None,
    ):
        self.path = str(path)
        self._calibration = "{}" if calibration is None else _calibration_json(calibration)
        self.max_chunk_s = max_chunk_s
        self.error: GloverecError | None = None
        self._lock = threading.RLock()
        self._closed = False
        self._glove: tuple | None = None
        self._counts: dict[int, int] = {}
        self._chunk_started: float | None = None
        meta = {str(k): v for k, v in (metadata or {}).items()}
        if boundary is None:
            boundary = str(meta.get("source", "")).startswith("udp:")
        wall_ns, mono_ns = time.time_ns(), time.monotonic_ns()
        self.log_time_offset_ns = wall_ns - mono_ns  # log_time = rx_ns + this
        try:
            self._file = open(self.path, "wb")
        except OSError as exc:
            raise GloverecError(f"cannot create log {self.path}: {exc.strerror or exc}") from None
        try:
            self._start(meta, bool(boundary), wall_ns, mono_ns, chunk_size)
        except OSError as exc:
            self._closed = True
            _close_quietly(self._file)
            raise GloverecError(f"cannot write log {self.path}: {exc.strerror or exc}") from None

    def _start(self, meta: dict, boundary: bool, wall_ns: int, mono_ns: int, chunk_size: int) -> None:
        """Header, the session metadata, the channels and their schemas (they go into the first chunk)."""

        self._writer = Writer(self._file, chunk_size=chunk_size, compression=_compression())
        self._writer.start(library=f"gloverec/{__version__} {LIBRARY_IDENTIFIER}")
        session = {
            "format": LOG_FORMAT,
            "log_version": LOG_VERSION,
            "protocol_version": PROTOCOL_VERSION,
            "gloverec_version": __version__,
            "host": socket.gethostname(),
            "python": platform.python_version(),
            "source": "",
            "start_time": iso_utc(wall_ns),
            "start_time_ns": wall_ns,
            "start_monotonic_ns": mono_ns,
            "log_time_offset_ns": self.log_time_offset_ns,
            "boundary": boundary,
            "calibration": self._calibration,  # "{}": not known when the log opened (set_calibration)
        } | meta
        self._writer.add_metadata(SESSION_METADATA, _str_values(session))
        self._bytes = self._writer.register_channel(
            BYTES_TOPIC,
            BYTES_ENCODING,
            0,
            {
                "log_time_offset_ns": str(self.log_time_offset_ns),
                "boundary": str(boundary).lower(),
                "rx_clock": "CLOCK_MONOTONIC",
                "protocol_version": str(PROTOCOL_VERSION),
            },
        )
        self._wrist = None  # its channel, once wrist_channel() registers it
        self._channels = {}
        for topic, schema in SCHEMAS.items():
            sid = self._writer.register_schema(schema["title"], "jsonschema", json.dumps(schema).encode())
            self._channels[topic] = self._writer.register_channel(topic, "json", sid)
        self._file.flush()
        self._written = self._file.tell()

    # ------------------------------------------------------------ writing
    def __call__(self, data: bytes, rx_ns: int, frames: list) -> None:
        """Tap: log one chunk of bytes as read at host monotonic ``rx_ns`` and the frames decoded from it."""
        with self._lock:
            if self._closed or self.error is not None:
                return
            try:
                t = rx_ns + self.log_time_offset_ns
                self._add(self._bytes, t, bytes(data))
                for f in frames:
                    if isinstance(f, StatusFrame):
                        self._glove_metadata(f, t)
                    msg = frame_json(f)
                    if msg is not None:
                        self._add(self._channels[msg[0]], t, json.dumps(msg[1], separators=(",", ":")).encode())
                self._maybe_flush()
            except (OSError, ValueError) as exc:  # disk full, file closed under us...
                self.error = self._write_error(exc)

    def wrist_channel(self, source: str, latency_s: float = 0.0, marker_in_palm=None) -> None:
        """Register /wrist/pose for a recording with a tracker: ``source`` (its spec), the wrist fusion's
        ``latency_s`` (capture to stamp) and the marker's mounting on the palm it used (``marker_in_palm``, wxyz;
        recorder/wrist/mounting.py) go into the channel's metadata."""
        with self._lock:
            self._check()
            meta = {"source": str(source), "latency_s": repr(float(latency_s)), "clock": "glove device clock, s",
                    "log_time_offset_ns": str(self.log_time_offset_ns)}  # fmt: skip
            if marker_in_palm is not None:
                meta["marker_in_palm"] = json.dumps([float(v) for v in marker_in_palm])
            sid = self._writer.register_schema(WRIST_SCHEMA["title"], "jsonschema", json.dumps(WRIST_SCHEMA).encode())
            self._wrist = self._writer.register_channel(WRIST_TOPIC, "json", sid, meta)

    def wrist(self, pose, taken_t: float) -> None:
        """Log a tracker pose (a WristPose, ``t`` on the glove's clock) the fusion took at glove time ``taken_t``;
        its log time is now. Errors are kept, as the tap's are."""
        with self._lock:
            if self._closed or self.error is not None or self._wrist is None:
                return
            rx_ns = time.monotonic_ns()
            try:
                data = json.dumps(wrist_json(pose, taken_t, rx_ns), separators=(",", ":")).encode()
                self._add(self._wrist, rx_ns + self.log_time_offset_ns, data)
                self._maybe_flush()
            except (OSError, ValueError) as exc:
                self.error = self._write_error(exc)

    def set_calibration(self, calibration: dict) -> None:
        """Store the session's fusion record (see the class) if it differs from the one stored."""
        text = _calibration_json(calibration)
        with self._lock:
            if text == self._calibration:
                return
            self._check()
            try:
                self._writer.add_metadata(SESSION_METADATA, {"calibration": text})
                self._file.flush()
                self._written = self._file.tell()
            except (OSError, ValueError) as exc:
                self.error = self._write_error(exc)
                raise self.error from None
            self._calibration = text

    def mark(self, name: str, /, *, at_ns: int | None = None, **fields) -> None:
        """Write a mark (episode start/end...) on /gloverec/marks and flush it to the OS at once.

        ``at_ns``: the host monotonic time (ns, same clock as rx_ns) the mark refers to; default now.
        ``fields``: any JSON-able values (numpy scalars and arrays are converted)."""
        rx_ns = time.monotonic_ns() if at_ns is None else int(at_ns)
        t = rx_ns + self.log_time_offset_ns
        msg = {"name": str(name), "fields": fields, "rx_ns": rx_ns, "log_time_ns": t, "time": iso_utc(t)}
        with self._lock:
            self._check()
            try:
                self._add(self._channels[MARKS_TOPIC], t, json.dumps(msg, default=_jsonable).encode())
                self._flush()
            except (OSError, ValueError) as exc:
                self.error = self._write_error(exc)
                raise self.error from None

    def flush(self) -> None:
        """Close the current chunk and hand everything to the OS (survives a process crash, not power loss)."""
        with self._lock:
            self._check()
            try:
                self._flush()
            except (OSError, ValueError) as exc:
                self.error = self._write_error(exc)
                raise self.error from None

    def close(self) -> None:
        """Finish the file (summary, indexes, footer). Idempotent. Raises the stored write error, if any."""
        with self._lock:
            if not self._closed:
                self._closed = True
                try:
                    if self.error is None:
                        self._writer.finish()
                        self._file.flush()
                        os.fsync(self._file.fileno())  # the finished log survives power loss too
                except (OSError, ValueError) as exc:
                    self.error = self._write_error(exc)
                finally:
                    _close_quietly(self._file)
            if self.error is not None:
                raise self.error

    def __enter__(self) -> McapLogger:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ internals
    def _write_error(self, exc: Exception) -> GloverecError:
        return GloverecError(f"cannot write log {self.path}: {getattr(exc, 'strerror', None) or exc}")

    def _check(self) -> None:
        if self.error is not None:
            raise self.error
        if self._closed:
            raise GloverecError(f"log {self.path} is closed")

    def _add(self, channel: int, t: int, data: bytes) -> None:
        n = self._counts.get(channel, 0)
        self._counts[channel] = n + 1
        self._writer.add_message(channel, log_time=t, data=data, publish_time=t, sequence=n & 0xFFFFFFFF)
        if self._chunk_started is None:
            self._chunk_started = time.monotonic()

    def _flush(self) -> None:
        self._writer.flush()
        self._written = self._file.tell()
        self._chunk_started = None

    def _maybe_flush(self) -> None:
        pos = self._file.tell()
        if pos != self._written:  # the writer closed a chunk (size limit): push it to the OS now
            self._file.flush()
            self._written = pos
            self._chunk_started = None
        elif self._chunk_started is not None and time.monotonic() - self._chunk_started > self.max_chunk_s:
            self._flush()

    def _glove_metadata(self, f: StatusFrame, t: int) -> None:
        key = (f.glove_id, tuple(f.firmware))
        if key == self._glove:
            return
        self._glove = key
        self._writer.add_metadata(
            GLOVE_METADATA,
            _str_values(
                {
                    "glove_id": f.glove_id,
                    "glove_id_hex": f"0x{f.glove_id:08x}",
                    "firmware": ".".join(map(str, f.firmware)),
                    "mode": f.mode.name.lower(),
                    "sense_rate_hz": f.sense_rate_hz,
                    "output_rate_hz": f.output_rate_hz,
                    "n_imu": len(f.joint_map),
                    "imu_ok_mask": f.imu_ok_mask,
                    "mux_map": list(f.mux_map),
                    "joint_map": list(f.joint_map),
                    "clock_flags": f.clock_flags,
                    "seen_log_time_ns": t,
                    "seen_time": iso_utc(t),
                }
            ),
        )
        self._file.flush()
        self._written = self._file.tell()


def _close_quietly(f) -> None:
    try:
        f.close()
    except OSError:  # the buffered tail could not be written either; the error is already reported
        pass


def _calibration_json(calibration: dict) -> str:
    return json.dumps(calibration, separators=(",", ":"), default=_jsonable)


def _str_values(d: dict) -> dict[str, str]:
    """MCAP metadata holds strings: numbers and booleans as JSON, other non-strings as JSON."""
    return {str(k): v if isinstance(v, str) else json.dumps(v, default=_jsonable) for k, v in d.items()}


__all__ = [
    "McapLogger",
    "frame_json",
    "wrist_json",
    "SCHEMAS",
    "WRIST_SCHEMA",
    "BYTES_TOPIC",
    "MARKS_TOPIC",
    "WRIST_TOPIC",
]
