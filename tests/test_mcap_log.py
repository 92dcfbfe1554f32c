"""MCAP session logs: McapLogger as a tap, read back with mcap's reader and ours, playback, crashes, bad files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from mcap.data_stream import ReadDataStream
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Chunk
from mcap.stream_reader import breakup_chunk
from mcap.writer import Writer

from recorder import GloverecError
from recorder.link.base import GloveSource
from recorder.log import McapLogger, McapSource, iter_chunks, iter_frames, read_log
from recorder.log.playback import _read_through
from recorder.log.writer import BYTES_TOPIC, MARKS_TOPIC, SCHEMAS
from recorder.protocol import StreamDecoder, encode_frame
from recorder.protocol.frames import (
    CLOCK_HOST_MONOTONIC,
    EventCode,
    EventFrame,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)

STEP_NS = 2_000_000  # recorded spacing of the chunks: 2 ms
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Recorder(GloveSource):
    """A glove source without a transport: the test feeds it chunks with chosen receive times."""

    name = "test"

    def __init__(self, **kw):
        super().__init__(**kw)
        self.frames = []

    def feed(self, data: bytes, rx_ns: int) -> None:
        n = len(self._queue)
        self._ingest(data, rx_ns)
        self.frames += list(self._queue)[n:]


def glove_bytes(n: int = 300, seed: int = 1) -> bytes:
    """A stream with every frame kind, a gap, a CRC error and leading garbage."""
    rng = np.random.default_rng(seed)
    out = [b"\x13\x37garbage"]
    seq = 0
    for i in range(n):
        if i % 50 == 0:
            f = StatusFrame(
                seq, i * 5000, firmware=(1, 2, 3), glove_id=0xCAFE0001, sense_rate_hz=200, output_rate_hz=200
            )
        elif i % 37 == 0:
            f = EventFrame(seq, i * 5000, EventCode.IMU_FAULT, 3)
        elif i % 3 == 0:
            f = RawFrame(seq, i * 5000, rng.integers(-32768, 32767, (12, 7), dtype=np.int16), ok_mask=0xFF7)
        elif i % 7 == 0:
            q = rng.normal(size=4)
            f = PoseCompactFrame(
                seq, i * 5000, (q / np.linalg.norm(q)).astype(np.float32), rng.uniform(-1.5, 1.5, 20).astype(np.float32)
            )
        else:
            q = rng.normal(size=(16, 4))
            f = PoseFrame(seq, i * 5000, (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32))
        wire = encode_frame(f)
        if i == 100:
            wire = wire[:5] + bytes([wire[5] ^ 0x40]) + wire[6:]  # CRC error
        out.append(wire)
        seq += 2 if i == 150 else 1  # one gap
    return b"".join(out)


def split(data: bytes, seed: int = 2) -> list[bytes]:
    """Cut a stream as a serial port would return it: arbitrary sizes, frames torn across reads."""
    rng = np.random.default_rng(seed)
    cuts = np.cumsum(rng.integers(1, 400, len(data) // 100))
    cuts = [0, *[int(c) for c in cuts if c < len(data)], len(data)]
    return [data[a:b] for a, b in zip(cuts, cuts[1:])]


def record(path, chunks, t0=None, step_ns=STEP_NS, metadata=None, **kw):
    """Log ``chunks`` through McapLogger as a tap; returns (source, receive times, logger)."""
    src = Recorder(queue_size=100_000)
    t0 = time.monotonic_ns() if t0 is None else t0
    rxs = [t0 + i * step_ns for i in range(len(chunks))]
    with McapLogger(str(path), {"source": "serial:/dev/test", "operator": "ada"} | (metadata or {}), **kw) as log:
        src.taps.append(log)
        for data, rx in zip(chunks, rxs):
            src.feed(data, rx)
    return src, rxs, log


def wire(frame) -> bytes:
    return encode_frame(frame)


def same_frames(a, b) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert type(x) is type(y)
        assert wire(x) == wire(y) and x.rx_ns == y.rx_ns


@pytest.fixture
def log(tmp_path):
    chunks = split(glove_bytes())
    src, rxs, logger = record(tmp_path / "s.mcap", chunks)
    return tmp_path / "s.mcap", chunks, rxs, src, logger


# ---------------------------------------------------------------- round trip


def test_round_trip_bytes_and_frames(log):
    path, chunks, rxs, src, logger = log
    assert len({type(f) for f in src.frames}) == 5 and src.decoder.stats.crc_errors == 1
    with open(path, "rb") as f:
        msgs = [m for _, _, m in make_reader(f).iter_messages(topics=[BYTES_TOPIC])]
    assert [m.data for m in msgs] == chunks  # every raw byte, as read
    assert [m.log_time - logger.log_time_offset_ns for m in msgs] == rxs  # the time base is invertible
    assert all(m.publish_time == m.log_time for m in msgs)
    assert abs(msgs[0].log_time - time.time_ns()) < 60e9  # a wall-clock timeline
    assert [c.data for c in iter_chunks(path)] == chunks
    assert [c.rx_ns for c in iter_chunks(path)] == rxs
    decoder = StreamDecoder()
    same_frames(list(iter_frames(path, decoder=decoder)), src.frames)
    assert decoder.stats == src.decoder.stats


def test_decoded_channels_match_frames(log):
    path, _, _, src, _ = log
    with open(path, "rb") as f:
        msgs = {}
        for _, ch, m in make_reader(f).iter_messages(log_time_order=False):
            if ch.topic != BYTES_TOPIC:
                msgs.setdefault(ch.topic, []).append(json.loads(m.data))
    poses = [f for f in src.frames if isinstance(f, PoseFrame)]
    raws = [f for f in src.frames if isinstance(f, RawFrame)]
    assert len(msgs["/glove/pose"]) == len(poses) and len(msgs["/glove/raw"]) == len(raws)
    assert len(msgs["/glove/status"]) == sum(isinstance(f, StatusFrame) for f in src.frames)
    assert len(msgs["/glove/event"]) == sum(isinstance(f, EventFrame) for f in src.frames)
    for m, f in zip(msgs["/glove/pose"], poses):
        assert (m["seq"], m["t_us"], m["rx_ns"]) == (f.seq, f.t_us, f.rx_ns)
        q = [[s["w"], s["x"], s["y"], s["z"]] for s in m["segments"]]
        np.testing.assert_allclose(q, f.quats, atol=1e-6)
        assert m["segments"][6] == m["segments"][6] | {"name": "index_distal", "measured": False}
    compact = [f for f in src.frames if isinstance(f, PoseCompactFrame)]
    assert len(msgs["/glove/pose_compact"]) == len(compact) > 0
    for m, f in zip(msgs["/glove/pose_compact"], compact):
        np.testing.assert_allclose([m["palm"][k] for k in "wxyz"], f.palm_quat, atol=1e-6)
        np.testing.assert_allclose(list(m["joints_deg"].values()), np.degrees(f.angles), atol=1e-3)
    for m, f in zip(msgs["/glove/raw"], raws):
        np.testing.assert_allclose([[i["accel_g"][k] for k in "xyz"] for i in m["imus"]], f.accel_g, atol=1e-6)
        np.testing.assert_allclose([[i["gyro_dps"][k] for k in "xyz"] for i in m["imus"]], f.gyro_dps, atol=1e-5)
        np.testing.assert_allclose([i["temperature_c"] for i in m["imus"]], f.temperature_c, atol=1e-4)
        assert [i["ok"] for i in m["imus"]] == [bool(0xFF7 >> i & 1) for i in range(12)]
    st = msgs["/glove/status"][0]
    assert st["firmware"] == "1.2.3" and st["glove_id"] == 0xCAFE0001 and st["mode"] == "pose"
    assert msgs["/glove/event"][0]["name"] == "imu_fault" and msgs["/glove/event"][0]["arg"] == 3


def _validate(obj, schema, where="$"):
    """A small JSON-schema check (type, required, properties, items, min/maxItems) when jsonschema is absent."""
    types = {"object": dict, "array": list, "string": str, "boolean": bool, "integer": int, "number": (int, float)}
    t = schema.get("type")
    if t:
        ok = isinstance(obj, types[t]) and not (t in ("integer", "number") and isinstance(obj, bool))
        assert ok, f"{where}: {obj!r} is not {t}"
    for key in schema.get("required", []):
        assert key in obj, f"{where}: missing {key}"
    for key, sub in schema.get("properties", {}).items():
        if isinstance(obj, dict) and key in obj:
            _validate(obj[key], sub, f"{where}.{key}")
    if isinstance(obj, list):
        assert len(obj) >= schema.get("minItems", 0) and len(obj) <= schema.get("maxItems", len(obj))
        for i, item in enumerate(obj):
            _validate(item, schema.get("items", {}), f"{where}[{i}]")


def test_json_messages_validate_against_their_schemas(log):
    path, *_, logger = log
    try:
        import jsonschema

        def validate(obj, schema):
            try:
                jsonschema.validate(obj, schema)
            except jsonschema.ValidationError as exc:
                raise AssertionError(exc.message) from None
    except ImportError:
        validate = _validate
    seen = set()
    with open(path, "rb") as f:
        for schema, ch, m in make_reader(f).iter_messages(log_time_order=False):
            if ch.topic == BYTES_TOPIC:
                assert schema is None and ch.message_encoding == "gloverec.bytes"
                continue
            assert ch.message_encoding == "json" and schema.encoding == "jsonschema"
            assert json.loads(schema.data) == SCHEMAS[ch.topic]
            validate(json.loads(m.data), json.loads(schema.data))
            seen.add(ch.topic)
    assert seen == {"/glove/pose", "/glove/pose_compact", "/glove/raw", "/glove/status", "/glove/event"}
    with pytest.raises(AssertionError):  # the validator itself can fail
        validate({k: 0 for k in SCHEMAS["/glove/pose"]["required"] if k != "segments"}, SCHEMAS["/glove/pose"])
    with pytest.raises(AssertionError):
        validate({"name": "x", "fields": {}, "rx_ns": "1", "log_time_ns": 1, "time": ""}, SCHEMAS[MARKS_TOPIC])


def test_metadata_and_summary(log):
    path, chunks, rxs, src, logger = log
    info = read_log(path)
    s = info.session
    assert s["format"] == "gloverec-log" and s["protocol_version"] == "1" and s["source"] == "serial:/dev/test"
    assert s["operator"] == "ada" and s["host"] and s["start_time"].startswith("20") and s["gloverec_version"]
    assert json.loads(s["calibration"]) == {} and int(s["log_time_offset_ns"]) == logger.log_time_offset_ns
    assert info.glove["glove_id"] == str(0xCAFE0001) and info.glove["firmware"] == "1.2.3"
    assert info.message_counts[BYTES_TOPIC] == len(chunks)
    assert info.message_counts["/glove/pose"] == sum(isinstance(f, PoseFrame) for f in src.frames)
    assert info.start_ns == rxs[0] + logger.log_time_offset_ns and info.complete
    assert info.duration_s == pytest.approx((rxs[-1] - rxs[0]) * 1e-9)
    assert info.channels["/glove/pose"]["schema"] == "gloverec.Pose"
    assert info.library.startswith("gloverec/")
    assert _read_through(str(path)) == info  # the summary section and a full read agree


def test_marks_and_closed_logger(tmp_path):
    path = tmp_path / "m.mcap"
    t0 = time.monotonic_ns()
    logger = McapLogger(str(path))
    logger(wire(PoseFrame(0, 0, np.eye(4, dtype=np.float32)[[0] * 16])), t0, [])
    logger.mark("episode_start", episode=np.int64(1), task="grasp")
    logger.mark("episode_end", at_ns=t0 - 5_000_000, episode=1)  # an explicit time, earlier than the first
    logger.mark("note", name="a field called name")
    unclosed = read_log(path)  # marks are flushed at once: readable before close (and after a crash)
    assert not unclosed.complete and [m["name"] for m in unclosed.marks] == ["episode_end", "episode_start", "note"]
    logger.close()
    logger.close()
    with pytest.raises(GloverecError, match="closed"):
        logger.mark("late")
    with pytest.raises(GloverecError, match="closed"):
        logger.flush()
    logger(b"\x00", t0, [])  # a tap call after close is ignored (the reader thread may still be running)
    marks = read_log(path).marks
    assert [m["name"] for m in marks] == ["episode_end", "episode_start", "note"]  # in time order
    assert marks[1]["fields"] == {"episode": 1, "task": "grasp"} and marks[0]["rx_ns"] == t0 - 5_000_000
    assert marks[0]["log_time_ns"] == t0 - 5_000_000 + logger.log_time_offset_ns


def test_concurrent_taps_and_marks(tmp_path):
    path = tmp_path / "c.mcap"
    data = wire(EventFrame(0, 0, EventCode.BUTTON))
    with McapLogger(str(path), chunk_size=2048) as logger:

        def marker():
            for i in range(200):
                logger.mark("m", i=i)

        th = threading.Thread(target=marker)
        th.start()
        for _ in range(2000):
            logger(data, time.monotonic_ns(), [])
        th.join()
    info = read_log(path)
    assert info.message_counts[BYTES_TOPIC] == 2000 and info.message_counts[MARKS_TOPIC] == 200
    assert sorted(m["fields"]["i"] for m in info.marks) == list(range(200))


def test_write_error_is_kept_and_raised(tmp_path):
    logger = McapLogger(str(tmp_path / "e.mcap"), chunk_size=256)

    def full(*_):
        raise OSError(28, "No space left on device")

    logger._file.write = full
    logger(wire(EventFrame(0, 0, EventCode.BOOT)) * 20, time.monotonic_ns(), [])  # must not raise
    assert "No space left" in str(logger.error)
    with pytest.raises(GloverecError, match="No space left"):
        logger.close()
    with pytest.raises(GloverecError, match="cannot"):
        McapLogger(str(tmp_path / "missing" / "x.mcap"))


# ---------------------------------------------------------------- playback


def test_fast_playback_is_lossless_and_faithful(log):
    path, chunks, rxs, src, _ = log
    started = time.monotonic_ns()
    with McapSource(str(path), realtime=False, queue_size=16) as play:
        time.sleep(0.2)  # let the reader fill the small queue: it must wait, not drop
        frames = []
        while (f := play.read(timeout=2.0)) is not None:
            frames.append(f)
        assert play.finished and play.read(timeout=0) is None
        stats = play.stats()
    assert stats.queue_drops == 0 and stats.decode == src.decoder.stats.as_dict()
    assert 0 <= play.shift_ns + rxs[0] - started < 0.2e9  # the first chunk lands when playback starts
    for f in frames:
        f.rx_ns -= play.shift_ns  # back onto the recording's clock
    same_frames(frames, src.frames)


def test_realtime_playback_keeps_the_recorded_spacing(tmp_path):
    chunks = split(glove_bytes(200))[:120]
    path = tmp_path / "rt.mcap"
    src, _, _ = record(path, chunks, step_ns=5_000_000)  # 0.595 s of recording
    t = time.monotonic()
    frames = []
    with McapSource(path, realtime=True) as play:
        while (f := play.read(timeout=2.0)) is not None:
            assert f.rx_ns <= time.monotonic_ns()  # delivered no earlier than its (mapped) receive time
            frames.append(f)
    elapsed = time.monotonic() - t
    assert elapsed > 0.55  # paced: never faster than recorded (a loaded machine can only make it later)
    assert [f.rx_ns - frames[0].rx_ns for f in frames] == [f.rx_ns - src.frames[0].rx_ns for f in src.frames]


def test_close_stops_realtime_playback_at_once(tmp_path):
    record(tmp_path / "slow.mcap", [wire(EventFrame(i, 0, EventCode.BUTTON)) for i in range(3)], step_ns=60 * 10**9)
    play = McapSource(str(tmp_path / "slow.mcap"), realtime=True).open()
    assert play.read(timeout=10.0).seq == 0 and play.read(timeout=0.1) is None  # the next one is a minute away
    t = time.monotonic()
    play.close()
    assert time.monotonic() - t < 30 and not play._thread.is_alive()  # a close that waited for it: 60 s


def test_playback_replays_host_clock_latency(tmp_path):
    """Emulator-style logs (device clock = host CLOCK_MONOTONIC) keep their exact latencies in playback."""
    t0 = time.monotonic_ns()
    delays_us = [100 + 7 * i for i in range(100)]
    chunks = [wire(StatusFrame(0, (t0 // 1000) & 0xFFFFFFFF, clock_flags=CLOCK_HOST_MONOTONIC))]
    for i, d in enumerate(delays_us):
        rx_us = (t0 + (i + 1) * STEP_NS) // 1000
        chunks.append(wire(PoseFrame(i + 1, (rx_us - d) & 0xFFFFFFFF, np.eye(4, dtype=np.float32)[[0] * 16])))
    record(tmp_path / "h.mcap", chunks, t0=t0)
    with McapSource(str(tmp_path / "h.mcap"), realtime=False) as play:
        got = []
        while (f := play.read(timeout=2.0)) is not None:
            if isinstance(f, PoseFrame):
                got.append(f.rx_ns * 1e-9 - play.host_time_s(f))
        assert play.clock.host_monotonic
    np.testing.assert_allclose(got, np.array(delays_us) * 1e-6, atol=2e-6)


def test_udp_logs_replay_datagram_boundaries(tmp_path):
    ev = [wire(EventFrame(i, 0, EventCode.BUTTON)) for i in range(5)]
    chunks = [ev[0] + ev[1], ev[2] + ev[3][:4], ev[4]]  # the second datagram was cut short
    src = Recorder(queue_size=100)
    src.boundary = True
    with McapLogger(str(tmp_path / "u.mcap"), {"source": "udp:5000"}) as logger:
        src.taps.append(logger)
        for i, c in enumerate(chunks):
            src.feed(c, 1_000_000 * (i + 1))
    assert [f.seq for f in src.frames] == [0, 1, 2, 4]  # as one stream, the torn tail would spoil frame 4
    with McapSource(str(tmp_path / "u.mcap"), realtime=False) as play:
        frames = list(iter(lambda: play.read(timeout=2.0), None))
        assert play.boundary and play.stats().decode == src.decoder.stats.as_dict()
    assert [f.seq for f in frames] == [0, 1, 2, 4]
    assert [f.seq for f in iter_frames(tmp_path / "u.mcap")] == [0, 1, 2, 4]


# ---------------------------------------------------------------- crashes and bad files


def _chunk_layout(path):
    """(end offset, /glove/bytes messages) of every chunk of a complete log."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        ids = {c.id for c in summary.channels.values() if c.topic == BYTES_TOPIC}
        out = []
        for ci in summary.chunk_indexes:
            f.seek(ci.chunk_start_offset + 9)
            recs = breakup_chunk(Chunk.read(ReadDataStream(f)))
            out.append(
                (
                    ci.chunk_start_offset + ci.chunk_length,
                    [r.data for r in recs if getattr(r, "channel_id", None) in ids],
                )
            )
    return out


def test_truncated_logs_play_up_to_their_last_complete_chunk(tmp_path):
    chunks = split(glove_bytes(200, seed=5), seed=6)
    path = tmp_path / "full.mcap"
    record(path, chunks, chunk_size=4096)
    layout = _chunk_layout(path)
    assert len(layout) >= 5
    data = path.read_bytes()
    ends = [end for end, _ in layout]
    cuts = sorted(
        {
            0,
            3,
            8,
            20,
            60,
            200,
            len(data) - 1,
            len(data) - 30,
            *ends,
            *[e - 1 for e in ends],
            *[e + 1 for e in ends],
            *range(0, len(data), len(data) // 15),
        }
    )
    cut_path = tmp_path / "cut.mcap"
    for cut in cuts:
        cut_path.write_bytes(data[:cut])
        expect = [m for end, msgs in layout if end <= cut for m in msgs]
        try:
            got = [c.data for c in iter_chunks(cut_path)]
        except GloverecError as exc:
            assert cut < 200 and "\n" not in str(exc), (cut, exc)  # only before the first chunk
            continue
        assert got[: len(expect)] == expect and got == chunks[: len(got)], cut
        decoder = StreamDecoder()
        assert [wire(f) for f in iter_frames(cut_path)] == [wire(f) for c in got for f in decoder.feed(c)]
        info = read_log(cut_path)
        assert info.message_counts.get(BYTES_TOPIC, 0) == len(got)
        assert info.complete == (cut >= len(data) - 8)  # complete once the footer record is whole
        if cut > len(data) // 2:
            with open(cut_path, "rb") as f:  # mcap's own recovery: a non-seeking reader, stopped by the cut
                seen = []
                try:
                    for _, ch, m in NonSeekingReader(f).iter_messages(log_time_order=False):
                        if ch.topic == BYTES_TOPIC:
                            seen.append(m.data)
                except Exception:  # noqa: BLE001 - mcap raises whatever the cut record gives
                    pass
            assert seen[: len(expect)] == expect
    cut_path.write_bytes(data[: ends[2] + 10])
    with McapSource(str(cut_path), realtime=False) as play:
        n = sum(1 for _ in iter(lambda: play.read(timeout=2.0), None))
        assert play.finished and play.error is None
    assert n == len(list(iter_frames(cut_path))) > 0


def test_closed_chunks_reach_the_disk_at_once(tmp_path):
    """What a crash would leave: every chunk the writer closed is on disk, not in a userspace buffer."""
    path = tmp_path / "live.mcap"
    logger = McapLogger(str(path), chunk_size=1024, max_chunk_s=1e9)  # chunks close by size only
    for i in range(600):
        frame = EventFrame(i, i, EventCode.BUTTON)
        logger(wire(frame), time.monotonic_ns(), [frame])
    on_disk = [c.data for c in iter_chunks(path)]
    assert 590 <= len(on_disk) < 600  # all but the open chunk
    assert on_disk == [wire(EventFrame(i, i, EventCode.BUTTON)) for i in range(len(on_disk))]
    logger.close()


CRASH = """
import sys, time
from recorder.log import McapLogger
from recorder.protocol import encode_frame
from recorder.protocol.frames import EventFrame, EventCode
log = McapLogger(sys.argv[1], max_chunk_s=0.05)
for i in range(100000):
    log(encode_frame(EventFrame(i & 0xFFFF, i, EventCode.BUTTON)), time.monotonic_ns(), [])
    if i == 500:
        print("ready", flush=True)
    time.sleep(0.0005)
"""


@pytest.mark.process
def test_killed_writer_leaves_a_playable_log(tmp_path):
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-c", CRASH, str(path)],
        stdout=subprocess.PIPE,
        cwd=ROOT,
        env=os.environ | {"PYTHONPATH": ROOT},
    )
    try:
        assert proc.stdout.readline().strip() == b"ready"
        time.sleep(0.3)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    info = read_log(path)
    assert not info.complete and info.message_counts[BYTES_TOPIC] > 400
    frames = list(iter_frames(path))
    assert len(frames) == info.message_counts[BYTES_TOPIC]
    assert [f.seq for f in frames] == list(range(len(frames)))


def test_bad_files_raise_one_line_errors(tmp_path):
    text = tmp_path / "notes.txt"
    text.write_text("hello, this is not a log\n" * 10)
    foreign = tmp_path / "foreign.mcap"
    with open(foreign, "wb") as f:
        w = Writer(f)
        w.start()
        cid = w.register_channel("/camera/info", "json", 0)
        w.add_message(cid, log_time=1, data=b"{}", publish_time=1)
        w.finish()
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    cases = {
        text: "not an MCAP file",
        foreign: "not a gloverec log",
        empty: "empty or truncated",
        tmp_path / "missing.mcap": "cannot open",
        tmp_path: "cannot open",
    }
    for path, message in cases.items():
        with pytest.raises(GloverecError, match=message) as exc:
            McapSource(path, realtime=False).open()
        assert "\n" not in str(exc.value) and str(path) in str(exc.value)
    assert "/camera/info" in str(pytest.raises(GloverecError, read_log, foreign).value)
    for path in (text, foreign, empty):
        with pytest.raises(GloverecError):
            read_log(path)
        with pytest.raises(GloverecError):
            list(iter_frames(path))
