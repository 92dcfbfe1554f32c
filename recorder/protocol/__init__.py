"""The glove wire protocol (spec: docs/protocol.md): frames, the binary codec, legacy JSON, stream decoding."""

from recorder.protocol.codec import decode_frame, encode_command, encode_frame
from recorder.protocol.frames import (
    Command,
    CommandCode,
    EventCode,
    EventFrame,
    FrameKind,
    Mode,
    PoseCompactFrame,
    PoseFrame,
    RawFrame,
    StatusFrame,
)
from recorder.protocol.stream import DecodeStats, StreamDecoder

__all__ = [
    "Command",
    "CommandCode",
    "DecodeStats",
    "EventCode",
    "EventFrame",
    "FrameKind",
    "Mode",
    "PoseCompactFrame",
    "PoseFrame",
    "RawFrame",
    "StatusFrame",
    "StreamDecoder",
    "decode_frame",
    "encode_command",
    "encode_frame",
]
