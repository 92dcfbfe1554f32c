"""Bytes in, frames out: splits a byte stream into frames, detects binary vs legacy JSON, counts everything.

The decoder is transport-agnostic: the serial link feeds it what pyserial returns, the UDP source feeds it one
datagram at a time (``feed(..., boundary=True)`` so a datagram's torn tail never joins the next one), the
emulator feeds it the host's commands.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from recorder.protocol.codec import MAX_FRAME, FrameError, decode_frame
from recorder.protocol.frames import Frame
from recorder.protocol.legacy_json import JsonFrameError, decode_line

BINARY, JSON = "binary", "json"
MAX_LINE = 8192  # a legacy JSON line is ~1.2 kB; anything longer without a newline is garbage
MAX_CHUNK = MAX_FRAME + 8  # COBS adds one byte per 254
REDETECT_AFTER = 8  # consecutive bad frames before an auto decoder looks for the other protocol
LATE_WINDOW = 256  # a sequence number this far behind is a late (reordered) frame, dropped
RESTART_JUMP = 0x4000  # a forward jump larger than this is a device restart, not a gap


@dataclass
class DecodeStats:
    frames: int = 0  # frames accepted
    bytes: int = 0  # bytes fed
    crc_errors: int = 0  # frames with a checksum mismatch
    format_errors: int = 0  # bad COBS, bad length, unknown version or kind, malformed JSON, overlong garbage
    gaps: int = 0  # frames missing according to the sequence numbers
    reordered: int = 0  # late or duplicated frames (dropped)
    seq_resets: int = 0  # the device's sequence restarted (reboot, reconnect)
    skipped_bytes: int = 0  # bytes discarded while looking for the first valid frame

    @property
    def errors(self) -> int:
        return self.crc_errors + self.format_errors

    def as_dict(self) -> dict:
        return asdict(self) | {"errors": self.errors}


class StreamDecoder:
    """Incremental decoder. ``protocol`` is "auto", "binary" or "json"."""

    def __init__(self, protocol: str = "auto", sequenced: bool = True):
        """``sequenced=False`` accepts frames whatever their sequence number (a glove reading commands)."""
        if protocol not in ("auto", BINARY, JSON):
            raise ValueError(f"protocol must be auto, binary or json, not {protocol!r}")
        self.auto = protocol == "auto"
        self.protocol: str | None = None if self.auto else protocol
        self.sequenced = sequenced
        self.stats = DecodeStats()
        self._buf = bytearray()
        self._last_seq: int | None = None
        self._bad_run = 0
        self._json_seq = 0

    def reset(self) -> None:
        """Forget partial input and the sequence (after a reconnect). Counters and protocol are kept."""
        self._buf.clear()
        self._last_seq = None
        self._bad_run = 0

    def feed(self, data: bytes, boundary: bool = False) -> list[Frame]:
        """Decode what ``data`` completes. With ``boundary``, input ends here (a datagram): no tail is kept."""
        self.stats.bytes += len(data)
        self._buf += data
        out: list[Frame] = []
        for _ in range(3):  # a protocol switch re-decodes what is buffered with the other protocol
            if self.protocol is None:
                self._detect()
            if self.protocol == BINARY:
                switched = self._feed_split(out, b"\x00", MAX_CHUNK, self._binary)
            elif self.protocol == JSON:
                if self.auto and b"\x00" in self._buf:  # JSON text never holds a zero byte: binary frames
                    self._json_lines_before_zero(out)
                    self.protocol = None
                    continue
                switched = self._feed_split(out, b"\n", MAX_LINE, self._json)
            else:
                break
            if not switched:
                break
        if boundary and self._buf:
            self.stats.format_errors += 1 if self.protocol else 0
            self.stats.skipped_bytes += 0 if self.protocol else len(self._buf)
            self._buf.clear()
        return out

    # -------------------------------------------------------------- internals

    def _feed_split(self, out: list, sep: bytes, limit: int, decode) -> bool:
        """Decode the complete pieces in the buffer; True when an auto decoder dropped its protocol."""
        parts = self._buf.split(sep)
        tail = parts.pop()
        for part in parts:
            if part.strip() if sep == b"\n" else part:
                frame = decode(part)
                if frame is not None and self._sequence_ok(frame):
                    out.append(frame)
        if len(tail) > limit:  # no delimiter for longer than any frame: garbage, or the other protocol
            self.stats.format_errors += 1
            self._bad_run += REDETECT_AFTER
            tail = tail[-limit:]
        self._buf = tail
        if self.auto and self._bad_run >= REDETECT_AFTER:
            self.protocol = None
            self._bad_run = 0
            return True
        return False

    def _json_lines_before_zero(self, out: list) -> None:
        """Decode the JSON lines that precede the first zero byte; keep the rest for detection."""
        cut = self._buf.rfind(b"\n", 0, self._buf.find(b"\x00")) + 1
        head, self._buf = self._buf[:cut], self._buf[cut:]
        for line in head.split(b"\n"):
            if line.strip() and (frame := self._json(line)) is not None and self._sequence_ok(frame):
                out.append(frame)

    def _binary(self, chunk: bytearray) -> Frame | None:
        try:
            frame = decode_frame(bytes(chunk))
        except FrameError as exc:
            if exc.crc:
                self.stats.crc_errors += 1
            else:
                self.stats.format_errors += 1
            self._bad_run += 1
            return None
        self._bad_run = 0
        return frame

    def _json(self, line: bytearray) -> Frame | None:
        try:
            frame = decode_line(bytes(line), self._json_seq)
        except JsonFrameError:
            self.stats.format_errors += 1
            self._bad_run += 1
            return None
        self._bad_run = 0
        self._json_seq = (self._json_seq + 1) & 0xFFFF
        return frame

    def _sequence_ok(self, frame: Frame) -> bool:
        """Count gaps; drop late or duplicated frames (possible on UDP, never on serial)."""
        if self.protocol == JSON or not self.sequenced:
            self.stats.frames += 1
            return True
        if self._last_seq is not None:
            step = (frame.seq - self._last_seq) & 0xFFFF
            if step == 0 or step > 0x10000 - LATE_WINDOW:
                self.stats.reordered += 1
                return False
            if step - 1 > RESTART_JUMP:
                self.stats.seq_resets += 1
            else:
                self.stats.gaps += step - 1
        self._last_seq = frame.seq
        self.stats.frames += 1
        return True

    def _detect(self) -> None:
        """Lock onto the protocol of the earliest valid frame in the buffer; keep the buffer from there."""
        buf = bytes(self._buf)
        start = _first_valid(buf, b"\x00", _is_binary)
        jstart = _first_valid(buf, b"\n", _is_json)
        if start is None and jstart is None:
            keep = max(MAX_CHUNK, MAX_LINE)
            if len(buf) > keep:
                self.stats.skipped_bytes += len(buf) - keep
                del self._buf[:-keep]
            return
        if start is None or (jstart is not None and jstart < start):
            self.protocol, start = JSON, jstart
        else:
            self.protocol = BINARY
        self.stats.skipped_bytes += start
        del self._buf[:start]


def _first_valid(buf: bytes, sep: bytes, valid) -> int | None:
    pos = 0
    while (end := buf.find(sep, pos)) >= 0:
        if valid(buf[pos:end]):
            return pos
        pos = end + 1
    return None


def _is_binary(chunk: bytes) -> bool:
    try:
        decode_frame(chunk)
        return True
    except FrameError:
        return False


def _is_json(line: bytes) -> bool:
    try:
        decode_line(line)
        return True
    except JsonFrameError:
        return False
