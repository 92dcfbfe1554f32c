"""Codec round trips, size targets, and a decoder that never accepts a corrupted frame."""

import json
import zlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from recorder import quat
from recorder.hand.kinematics import LIMITS, forward, relative_from_angles, relative_quats
from recorder.protocol import (
    Command,
    CommandCode,
    EventCode,
    EventFrame,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
    StreamDecoder,
    decode_frame,
    encode_command,
    encode_frame,
)
from recorder.protocol.codec import FrameError, frame_body
from recorder.protocol.frames import CalibState, identity_pose
from recorder.protocol.legacy_json import JsonFrameError, decode_line, encode_line

u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)
i16 = st.integers(-32768, 32767)


@st.composite
def unit_quats(draw, n=16):
    q = np.array(draw(st.lists(st.lists(st.floats(-1, 1), min_size=4, max_size=4), min_size=n, max_size=n)))
    q[np.linalg.norm(q, axis=1) < 1e-3] = (1, 0, 0, 0)
    return (q / np.linalg.norm(q, axis=1, keepdims=True)).astype(np.float32)


@st.composite
def frames(draw):
    kind = draw(st.sampled_from(["pose", "pose_compact", "raw", "status", "event", "command"]))
    seq, t = draw(u16), draw(u32)
    if kind == "pose":
        return PoseFrame(seq, t, draw(unit_quats()), draw(u16))
    if kind == "pose_compact":  # radians, beyond the +-204.7 deg range too, and "no value"
        angle = st.one_of(st.floats(-4, 4, width=32), st.just(float("nan")))
        return PoseCompactFrame(
            seq, t, draw(unit_quats(1))[0], np.array(draw(st.lists(angle, min_size=20, max_size=20)), np.float32)
        )
    if kind == "raw":
        n = draw(st.integers(1, 16))
        data = np.array(draw(st.lists(i16, min_size=7 * n, max_size=7 * n)), np.int16).reshape(n, 7)
        return RawFrame(
            seq, t, data, draw(st.sampled_from([2, 4, 8, 16])), draw(st.sampled_from([250, 500, 1000, 2000])), draw(u16)
        )
    if kind == "status":
        n = draw(st.integers(0, 16))
        return StatusFrame(
            seq,
            t,
            tuple(draw(st.lists(st.integers(0, 255), min_size=3, max_size=3))),
            draw(st.sampled_from(list(Mode))),
            draw(u16),
            draw(u16),
            draw(st.sampled_from(list(CalibState))),
            draw(st.integers(0, 100)),
            draw(st.integers(0, 255)),
            draw(u32),
            draw(u16),
            tuple(draw(st.lists(st.integers(0, 7), min_size=n, max_size=n))),
            tuple(draw(st.lists(st.integers(0, 15), min_size=n, max_size=n))),
        )
    if kind == "event":
        return EventFrame(seq, t, draw(st.sampled_from(list(EventCode))), draw(st.integers(0, 255)))
    code = draw(st.sampled_from(list(CommandCode)))
    arg = {CommandCode.SET_MODE: draw(st.sampled_from(list(Mode))), CommandCode.SET_RATE: draw(u16)}.get(code, 0)
    return Command(code, arg, seq, t)


def same(a, b) -> bool:
    if type(a) is not type(b):
        return False
    for name in a.__slots__:
        if name == "rx_ns":
            continue
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            if x.shape != y.shape or not np.array_equal(x, y, equal_nan=True):
                return False
        elif x != y:
            return False
    return True


def quantised(frame):
    """The frame as the wire carries it (pose quaternions rounded to Q14, joint angles to 0.1 degree)."""
    return decode_frame(encode_frame(frame)[:-1])


@given(frames())
def test_round_trip(frame):
    wire = encode_frame(frame)
    assert wire.endswith(b"\x00") and wire.count(0) == 1
    back = decode_frame(wire[:-1])
    if isinstance(frame, PoseFrame):
        assert np.abs(back.quats - frame.quats).max() <= 0.5 / 16384 + 1e-7
        assert same(back, decode_frame(encode_frame(back)[:-1]))  # Q14 values are exact fixed points
    elif isinstance(frame, PoseCompactFrame):
        assert np.abs(back.palm_quat - frame.palm_quat).max() <= 0.5 / 16384 + 1e-7
        a, b = frame.angles.astype(np.float64), back.angles.astype(np.float64)
        limit = np.radians(204.7)
        assert np.array_equal(np.isnan(a), np.isnan(b))
        inside = np.abs(a) <= limit - 1e-6
        assert np.all(np.abs(a - b)[inside] <= np.radians(0.05) + 1e-6)  # 0.1 degree steps, rounded
        assert np.allclose(b[np.abs(a) > limit], np.sign(a[np.abs(a) > limit]) * limit)  # saturated
        assert same(back, decode_frame(encode_frame(back)[:-1]))
    else:
        assert same(back, frame)


def test_pose_frame_is_small_and_raw_carries_twelve_imus():
    pose = encode_frame(PoseFrame(1, 2, identity_pose()))
    raw = encode_frame(RawFrame(1, 2, np.zeros((12, 7), np.int16)))
    legacy = encode_line(identity_pose() + np.float32(0.123456))
    assert len(pose) <= 160
    assert len(raw) < 200
    assert len(legacy) > 5 * len(pose)


def test_compact_pose_frame_carries_the_hand_in_52_bytes():
    """52 bytes: 115200 baud (11 520 B/s) carries 221 frames a second. On the host the angles become the 16
    parent-relative quaternions of the hand model (kinematics.forward), within the 0.05 degree rounding."""
    rng = np.random.default_rng(0)
    angles = rng.uniform(LIMITS[:, 0], LIMITS[:, 1], (50, 20))
    palm = quat.normalize(rng.normal(size=(50, 4)))
    truth = relative_quats(forward(angles, palm)[0])
    for a, p, rel in zip(angles, palm, truth):
        wire = encode_frame(PoseCompactFrame(1, 2, p, a))
        assert len(wire) == 52 and 11520 / len(wire) >= 200
        f = decode_frame(wire[:-1])
        got = relative_from_angles(f.angles, f.palm_quat)
        assert np.degrees(quat.angle_between(got, rel)).max() < 0.1  # flexion and abduction, 0.05 deg each
    with pytest.raises(ValueError, match="20 angles"):
        encode_frame(PoseCompactFrame(1, 2, palm[0], angles[0, :16]))


def test_crc_is_crc32_iso_hdlc():
    assert zlib.crc32(b"123456789") == 0xCBF43926
    body = frame_body(EventFrame(7, 9, EventCode.BUTTON))
    assert int.from_bytes(body[-4:], "little") == zlib.crc32(body[:-4])


def test_crc_mismatch_and_bad_version_are_told_apart():
    body = bytearray(frame_body(EventFrame(7, 9, EventCode.BUTTON)))
    from cobs import cobs

    bad_crc = bytearray(body)
    bad_crc[8] ^= 1
    with pytest.raises(FrameError) as e:
        decode_frame(cobs.encode(bytes(bad_crc)))
    assert e.value.crc
    v2 = bytearray(body)
    v2[0] = 2
    v2[-4:] = zlib.crc32(bytes(v2[:-4])).to_bytes(4, "little")
    with pytest.raises(FrameError, match="version 2") as e:
        decode_frame(cobs.encode(bytes(v2)))
    assert not e.value.crc


@given(
    st.lists(frames(), min_size=1, max_size=8),
    st.lists(st.binary(max_size=40), min_size=9, max_size=9),
    st.integers(1, 64),
)
@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=150)
def test_resynchronises_after_garbage_in_any_chunking(fs, garbage, chunk):
    # garbage ends with a delimiter so it cannot merge into the frame after it; seq numbers increase
    fs = [f.__class__(**{**{k: getattr(f, k) for k in f.__slots__}, "seq": i}) for i, f in enumerate(fs)]
    stream = b"".join(g + b"\x00" + encode_frame(f) for g, f in zip(garbage, fs)) + garbage[-1]
    dec = StreamDecoder("binary")
    out = []
    for i in range(0, len(stream), chunk):
        out += dec.feed(stream[i : i + chunk])
    assert len(out) == len(fs)
    assert all(same(quantised(a), b) for a, b in zip(fs, out))


@given(frames(), st.data())
@settings(max_examples=400)
def test_a_corrupted_frame_is_never_accepted(frame, data):
    wire = bytearray(encode_frame(frame))
    how = data.draw(st.sampled_from(["flip", "truncate", "insert", "delete", "splice"]))
    pos = data.draw(st.integers(0, len(wire) - 2))
    if how == "flip":
        wire[pos] ^= data.draw(st.integers(1, 255))
    elif how == "truncate":
        wire = wire[:pos] + b"\x00"
    elif how == "insert":
        wire.insert(pos, data.draw(st.integers(1, 255)))
    elif how == "delete":
        del wire[pos]
    else:
        wire[pos:pos] = encode_frame(frame)[: data.draw(st.integers(1, len(wire) - 1))]
    dec = StreamDecoder("binary")
    out = dec.feed(bytes(wire))
    original = quantised(frame)
    assert all(same(f, original) for f in out), "a mutated frame decoded as something else"
    if bytes(wire) != encode_frame(frame) and bytes(wire).strip(b"\x00"):
        assert not out or how == "splice" or wire.count(0) > 1
        assert dec.stats.errors + len(out) >= 1


@given(st.binary(max_size=4096), st.sampled_from(["auto", "binary", "json"]))
def test_random_bytes_never_raise(blob, protocol):
    dec = StreamDecoder(protocol)
    for i in range(0, len(blob), 97):
        dec.feed(blob[i : i + 97])
    dec.feed(b"", boundary=True)
    assert dec.stats.bytes == len(blob)


def test_gaps_late_and_duplicate_frames_are_counted():
    dec = StreamDecoder("binary")
    wire = [encode_frame(EventFrame(s, 0, EventCode.BUTTON)) for s in (1, 2, 5, 4, 5, 6)]
    out = dec.feed(b"".join(wire))
    assert [f.seq for f in out] == [1, 2, 5, 6]
    assert dec.stats.gaps == 2 and dec.stats.reordered == 2


def test_sequence_wraps_without_a_gap():
    dec = StreamDecoder("binary")
    out = dec.feed(b"".join(encode_frame(EventFrame(s & 0xFFFF, 0, EventCode.BUTTON)) for s in range(65530, 65545)))
    assert len(out) == 15 and dec.stats.gaps == 0


THESIS_LINE = json.dumps(
    {
        "wrists": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0},
        "fingers": [{"joints": [{"w": 0.9238795, "x": 0.0, "y": 0.3826834, "z": 0.0}] * 3} for _ in range(5)],
    }
)


def test_legacy_json_maps_fingers_and_joints_onto_segments():
    f = decode_line(THESIS_LINE)
    assert np.allclose(f.quats[0], (1, 0, 0, 0))
    assert np.allclose(f.quats[1:], (0.9238795, 0, 0.3826834, 0), atol=1e-6)
    alias = decode_line(THESIS_LINE.replace('"wrists"', '"wrist"'))
    assert np.array_equal(alias.quats, f.quats)
    q = identity_pose()
    q[5] = (0, 1, 0, 0)  # index intermediate: finger 1, joint 1
    assert np.allclose(decode_line(encode_line(q)).quats[5], (0, 1, 0, 0))


@pytest.mark.parametrize(
    "line",
    [
        "{",
        "[]",
        '{"wrists": {"w": 1}}',
        THESIS_LINE.replace('"w": 1.0', '"w": "a"'),
        json.dumps({"wrists": {"w": 0, "x": 0, "y": 0, "z": 0}, "fingers": json.loads(THESIS_LINE)["fingers"]}),
        json.dumps({"wrists": {"w": 1, "x": 0, "y": 0, "z": 0}, "fingers": json.loads(THESIS_LINE)["fingers"][:4]}),
        THESIS_LINE.replace("0.9238795", "NaN"),
    ],
)
def test_malformed_json_lines_are_rejected(line):
    with pytest.raises(JsonFrameError):
        decode_line(line)


def test_auto_detects_json_and_binary_and_follows_a_mode_switch():
    lines = (THESIS_LINE + "\n").encode() * 3
    dec = StreamDecoder("auto")
    assert len(dec.feed(b"\x13garbage\n" + lines)) == 3 and dec.protocol == "json"
    binary = b"".join(encode_frame(PoseFrame(s, s, identity_pose())) for s in range(40))
    out = dec.feed(binary)
    assert dec.protocol == "binary"
    assert len(out) >= 30  # frames in flight while switching may be lost, never misread
    assert all(isinstance(f, PoseFrame) and f.t_us == f.seq for f in out)
    dec2 = StreamDecoder("auto")
    assert len(dec2.feed(binary[5:])) == 39 and dec2.protocol == "binary"


def test_command_encoding():
    for code, arg in [(CommandCode.SET_MODE, 2), (CommandCode.SET_RATE, 1000), (CommandCode.RESET_POSE, 0)]:
        cmd = decode_frame(encode_command(code, arg)[:-1])
        assert (cmd.code, cmd.arg) == (code, arg)
