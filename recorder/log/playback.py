"""Reading gloverec MCAP logs: play one back as a glove source, list what it holds, or decode it offline.

The ground truth is the "/glove/bytes" channel: the transport bytes exactly as read, at their recorded host
receive times (``rx_ns = log_time - log_time_offset_ns``, host CLOCK_MONOTONIC of the recording machine; see
recorder/log/writer.py). Playback feeds these chunks through the normal decoder path, so frames, counters and
link statistics come out as they did live.

Files are read linearly and stop cleanly at the first incomplete or corrupt record, so a log whose writer was
killed plays up to its last complete chunk. Anything that is not a gloverec log raises GloverecError.
"""

from __future__ import annotations

import io
import json
import os
import struct
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import NamedTuple

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError, UnsupportedCompressionError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk

from recorder import GloverecError
from recorder.link.base import GloveSource
from recorder.log.writer import BYTES_ENCODING, BYTES_TOPIC, MARKS_TOPIC, SESSION_METADATA
from recorder.protocol import StreamDecoder
from recorder.protocol.frames import Frame

MAGIC = b"\x89MCAP0\r\n"
_RECORDS = {
    Opcode.HEADER: Header,
    Opcode.METADATA: Metadata,
    Opcode.CHUNK: Chunk,
    Opcode.CHANNEL: Channel,
    Opcode.SCHEMA: Schema,
    Opcode.DATA_END: DataEnd,
    Opcode.FOOTER: Footer,
}
_CORRUPT = (McapError, ValueError, struct.error, EOFError, RuntimeError, IndexError, KeyError)
try:
    import zstandard

    _CORRUPT += (zstandard.ZstdError,)
except ImportError:
    pass


class LoggedChunk(NamedTuple):
    log_time_ns: int  # MCAP log time: ns since the Unix epoch
    rx_ns: int  # host CLOCK_MONOTONIC (ns) of the recording machine when the bytes were read
    data: bytes


class LogReader:
    """One linear, crash-tolerant pass over an MCAP file. Attributes fill in as ``records()`` proceeds."""

    def __init__(self, path: str):
        self.path = str(path)
        self.header: Header | None = None
        self.metadata: dict[str, dict[str, str]] = {}  # name -> keys; a later record of a name updates it
        self.channels: dict[int, Channel] = {}
        self.bytes_channel: Channel | None = None
        self.complete = False  # the footer was reached (the writer closed the file)
        self.size = 0  # bytes in the file

    @property
    def ours(self) -> bool:
        lib = self.header.library if self.header else ""
        return self.bytes_channel is not None or SESSION_METADATA in self.metadata or lib.startswith("gloverec/")

    @property
    def log_time_offset_ns(self) -> int:
        """log_time - rx_ns of the /glove/bytes messages."""
        meta = (self.bytes_channel.metadata if self.bytes_channel else {}) or self.metadata.get(SESSION_METADATA, {})
        try:
            return int(meta.get("log_time_offset_ns", 0))
        except ValueError:
            return 0

    @property
    def boundary(self) -> bool:
        """Each chunk is a whole datagram (recorded from UDP)."""
        return bool(self.bytes_channel and self.bytes_channel.metadata.get("boundary") == "true")

    def records(self) -> Iterator:
        """Header, Metadata, Schema, Channel and Message records in file order (chunks opened)."""
        with open(self.path, "rb") as f:
            size = self.size = os.fstat(f.fileno()).st_size
            magic = f.read(8)
            if magic != MAGIC and not MAGIC.startswith(magic):
                raise GloverecError(f"{self.path} is not an MCAP file")
            while True:
                head = f.read(9)
                if len(head) < 9:
                    return
                opcode, length = struct.unpack("<BQ", head)
                if length > size - f.tell():
                    return  # cut short: the writer was killed mid-record
                body = f.read(length)
                try:
                    recs = self._parse(opcode, body)
                except UnsupportedCompressionError as exc:
                    raise GloverecError(f"cannot read {self.path}: {exc}") from None
                except _CORRUPT:
                    return  # a corrupt record: stop here, as after a crash
                for rec in recs:
                    if isinstance(rec, Footer):
                        self.complete = True
                        return
                    self._note(rec)
                    yield rec

    def chunks(self) -> Iterator[LoggedChunk]:
        """The /glove/bytes messages in file (= receive) order. Raises GloverecError if not a gloverec log."""
        offset = None
        for rec in self.records():
            if isinstance(rec, Message) and self.bytes_channel is not None and rec.channel_id == self.bytes_channel.id:
                if offset is None:
                    offset = self.log_time_offset_ns
                yield LoggedChunk(rec.log_time, rec.log_time - offset, rec.data)
        self.check()

    def messages(self, topic: str) -> Iterator[Message]:
        """The messages of ``topic`` in file order, up to where the file is readable (a killed writer's too).
        Raises GloverecError if not a gloverec log."""
        for rec in self.records():
            if isinstance(rec, Message) and rec.channel_id in self.channels:
                if self.channels[rec.channel_id].topic == topic:
                    yield rec
        self.check()

    def check(self) -> None:
        """Raise GloverecError unless what was read is (the start of) a gloverec log."""
        if self.header is None:
            raise GloverecError(f"{self.path} is an empty or truncated MCAP file ({self.size} bytes)")
        if not self.ours:
            topics = sorted({c.topic for c in self.channels.values()})
            raise GloverecError(
                f"{self.path} is not a gloverec log: an MCAP file without a {BYTES_TOPIC} channel "
                f"(topics: {', '.join(topics) or 'none'})"
            )

    def _parse(self, opcode: int, body: bytes) -> list:
        stream = ReadDataStream(io.BytesIO(body))
        if opcode == Opcode.MESSAGE:
            return [Message.read(stream, len(body))]
        cls = _RECORDS.get(opcode)
        if cls is None:
            return []  # indexes, statistics, attachments...: not needed
        rec = cls.read(stream)
        return breakup_chunk(rec, validate_crc=True) if isinstance(rec, Chunk) else [rec]

    def _note(self, rec) -> None:
        if isinstance(rec, Header):
            self.header = rec
        elif isinstance(rec, Metadata):
            self.metadata.setdefault(rec.name, {}).update(rec.metadata)
        elif isinstance(rec, Channel):
            self.channels[rec.id] = rec
            if rec.topic == BYTES_TOPIC and rec.message_encoding == BYTES_ENCODING:
                self.bytes_channel = rec


def probe(path: str) -> LogReader:
    """Read up to the /glove/bytes channel record (the file's first chunk): raises unless a gloverec log."""
    reader = LogReader(path)
    records = reader.records()
    try:
        for _ in records:
            if reader.bytes_channel is not None:
                break
    finally:
        records.close()
    reader.check()
    return reader


def iter_chunks(path: str) -> Iterator[LoggedChunk]:
    """The recorded chunks of transport bytes with their times (offline, no thread)."""
    return LogReader(path).chunks()


def iter_frames(path: str, protocol: str = "auto", decoder: StreamDecoder | None = None) -> Iterator[Frame]:
    """Decode a log offline: frames with ``rx_ns`` = the recorded host receive time (recording's monotonic ns).
    Pass ``decoder`` to read its counters afterwards."""
    reader = LogReader(path)
    decoder = decoder or StreamDecoder(protocol)
    for chunk in reader.chunks():
        for frame in decoder.feed(chunk.data, boundary=reader.boundary):
            frame.rx_ns = chunk.rx_ns
            yield frame


# ---------------------------------------------------------------- summary


@dataclass
class LogInfo:
    """What a log holds. Times are MCAP log times (ns since the Unix epoch); None when it has no messages."""

    path: str
    library: str = ""
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)  # name -> keys (later records update)
    channels: dict[str, dict] = field(default_factory=dict)  # topic -> message_encoding, schema, metadata
    message_counts: dict[str, int] = field(default_factory=dict)
    start_ns: int | None = None
    end_ns: int | None = None
    marks: list[dict] = field(default_factory=list)  # /gloverec/marks messages, in time order
    complete: bool = False  # False: the writer did not close the file; counts cover the readable chunks

    @property
    def duration_s(self) -> float:
        return 0.0 if self.start_ns is None else (self.end_ns - self.start_ns) * 1e-9

    @property
    def session(self) -> dict[str, str]:
        return self.metadata.get(SESSION_METADATA, {})

    @property
    def glove(self) -> dict[str, str]:
        return self.metadata.get("gloverec.glove", {})


def log_calibration(path: str) -> dict | None:
    """The fusion record a log was recorded with (its session metadata's ``calibration``, see
    recorder/fusion/session.py), None when it has none ("{}": a glove that fused on board, or an older log)."""
    text = read_log(path).session.get("calibration", "{}")
    try:
        record = json.loads(text)
    except ValueError:
        raise GloverecError(f"{path}: its calibration metadata is not JSON") from None
    if not isinstance(record, dict):
        raise GloverecError(f"{path}: its calibration metadata is not a JSON object")
    return record or None


def read_log(path: str) -> LogInfo:
    """Summarise a log: from its summary section when the file is complete, else by reading it through."""
    info = _read_summary(str(path))
    return info if info is not None else _read_through(str(path))


def _read_summary(path: str) -> LogInfo | None:

    try:
        with open(path, "rb") as f:
            if f.read(8) != MAGIC:
                return None  # let the linear reader raise the right error
            f.seek(-8, io.SEEK_END)
            if f.read(8) != MAGIC:
                return None  # no footer: the writer was killed
            f.seek(0)
            reader = SeekingReader(f, validate_crcs=True)
            summary = reader.get_summary()
            if summary is None or summary.statistics is None:
                return None
            info = LogInfo(path, reader.get_header().library, complete=True)
            for m in reader.iter_metadata():
                info.metadata.setdefault(m.name, {}).update(m.metadata)
            if not any(c.topic == BYTES_TOPIC for c in summary.channels.values()):
                return None
            stats = summary.statistics
            for cid, ch in summary.channels.items():
                info.channels[ch.topic] = _channel_info(ch, summary.schemas.get(ch.schema_id))
                info.message_counts[ch.topic] = stats.channel_message_counts.get(cid, 0)
            if stats.message_count:
                info.start_ns, info.end_ns = stats.message_start_time, stats.message_end_time
            if info.message_counts.get(MARKS_TOPIC):
                info.marks = [json.loads(m.data) for _, _, m in reader.iter_messages(topics=[MARKS_TOPIC])]
            return info
    except UnsupportedCompressionError as exc:
        raise GloverecError(f"cannot read {path}: {exc}") from None
    except (OSError, *_CORRUPT):
        return None


def _read_through(path: str) -> LogInfo:
    reader = LogReader(path)
    info = LogInfo(path)
    schemas: dict[int, Schema] = {}
    marks = []
    try:
        for rec in reader.records():
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Message) and rec.channel_id in reader.channels:
                topic = reader.channels[rec.channel_id].topic
                info.message_counts[topic] = info.message_counts.get(topic, 0) + 1
                info.start_ns = rec.log_time if info.start_ns is None else min(info.start_ns, rec.log_time)
                info.end_ns = rec.log_time if info.end_ns is None else max(info.end_ns, rec.log_time)
                if topic == MARKS_TOPIC:
                    marks.append((rec.log_time, json.loads(rec.data)))
    except OSError as exc:
        raise GloverecError(f"cannot read {path}: {exc.strerror or exc}") from None
    reader.check()
    info.library = reader.header.library if reader.header else ""
    info.metadata = reader.metadata
    info.channels = {c.topic: _channel_info(c, schemas.get(c.schema_id)) for c in reader.channels.values()}
    info.message_counts = {topic: info.message_counts.get(topic, 0) for topic in info.channels}
    info.marks = [m for _, m in sorted(marks, key=lambda m: m[0])]
    info.complete = reader.complete
    return info


def _channel_info(ch: Channel, schema: Schema | None) -> dict:
    return {
        "message_encoding": ch.message_encoding,
        "schema": schema.name if schema else "",
        "schema_encoding": schema.encoding if schema else "",
        "metadata": dict(ch.metadata),
    }


# ---------------------------------------------------------------- playback


class McapSource(GloveSource):
    """Plays a gloverec log back as a glove source, through the normal decoder path (``_ingest``).

    Time base: a frame's ``rx_ns`` is its recorded receive time shifted onto this process's monotonic clock,
    ``rx_ns = recorded_rx_ns + shift_ns`` with ``shift_ns`` chosen so the first chunk lands at the moment
    playback starts. With ``realtime`` the chunks are delivered at those times (original spacing, so rx_ns
    ≈ time.monotonic_ns() at delivery); without it they are delivered as fast as the consumer reads, losslessly
    (the reader blocks while the queue is full), and rx_ns runs ahead of the clock. Either way the spacing of
    receive times is exact, so rate, clock fit and latency statistics replay as recorded; ``host_time_s`` undoes
    the shift for host-clock devices (the emulator). When the log ends, ``finished`` becomes True.
    """

    can_reconnect = False

    def __init__(self, path: str, realtime: bool = True, **kw):
        super().__init__(**kw)
        self.path = str(path)
        self.realtime = realtime
        self.name = f"mcap:{self.path}"
        self.shift_ns = 0  # rx_ns - recorded rx_ns
        self.info: LogReader | None = None
        self.error: GloverecError | None = None  # a problem met during playback (it then ends)
        self._chunks: Iterator[LoggedChunk] | None = None

    def host_time_s(self, frame: Frame) -> float:
        if frame.t_us >= 0 and self.clock.host_monotonic:  # the device clock is the recording host's
            return self.clock.unwrap(frame.t_us, frame.rx_ns - self.shift_ns) + self.shift_ns * 1e-9
        return super().host_time_s(frame)

    def _connect(self) -> None:
        self.info = probe(self.path)
        self.boundary = self.info.boundary
        self._chunks = LogReader(self.path).chunks()

    def _disconnect(self) -> None:
        if self._chunks is not None and (self._thread is None or not self._thread.is_alive()):
            self._chunks.close()

    def _read(self) -> bytes:  # not used: _run drives playback itself to set the recorded receive times
        return b""

    def _run(self) -> None:
        start = time.monotonic_ns()
        first: int | None = None
        try:
            for chunk in self._chunks:
                if first is None:
                    first = chunk.rx_ns
                    self.shift_ns = start - first
                rx_ns = chunk.rx_ns + self.shift_ns
                if self.realtime:
                    self._stop.wait(max(0, rx_ns - time.monotonic_ns()) * 1e-9)
                else:
                    self._wait_for_room(chunk.data)
                if self._stop.is_set():
                    return
                self._ingest(chunk.data, rx_ns)
        except GloverecError as exc:
            self.error = exc
        except OSError as exc:
            self.error = GloverecError(f"cannot read {self.path}: {exc.strerror or exc}")
        finally:
            self._chunks.close()
        self._finish()

    def _wait_for_room(self, data: bytes) -> None:
        """Block until the frames ``data`` can complete (at most one per delimiter) fit in the queue."""
        need = min(data.count(0) + data.count(b"\n") + 1, self._queue.maxlen)
        while len(self._queue) + need > self._queue.maxlen and not self._stop.is_set():
            self._stop.wait(0.002)


__all__ = ["LogInfo", "LogReader", "LoggedChunk", "McapSource", "iter_chunks", "iter_frames", "probe", "read_log"]
