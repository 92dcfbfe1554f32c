"""Frame types of the glove protocol, as Python values. Layouts and semantics: docs/protocol.md."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from recorder.protocol.layout import JOINT_MAP, MEASURED_MASK, MUX_MAP, N_JOINTS, N_SEGMENTS

VERSION = 1
Q14 = 16384.0  # pose quaternion fixed point: 1.0 == 16384
MPU_TEMP_SENSITIVITY = 333.87  # LSB/degC, MPU9250 datasheet; degC = raw / 333.87 + 21
MPU_TEMP_OFFSET_C = 21.0
ANGLE_LSB = np.pi / 1800.0  # pose_compact joint angles: 12-bit integers of 0.1 degree
ANGLE_MISSING = -2048  # pose_compact: the joint angle is not available (NaN)
N_ANGLES = N_JOINTS  # pose_compact: the joint angles of layout.JOINTS


class FrameKind(enum.IntEnum):
    POSE = 0x01
    RAW = 0x02
    STATUS = 0x03
    EVENT = 0x04
    POSE_COMPACT = 0x05
    COMMAND = 0x10  # host -> glove


class Mode(enum.IntEnum):
    RAW = 0
    POSE = 1
    JSON = 2
    COMPACT = 3  # pose_compact frames (52 bytes: >= 200 Hz over a 115200-baud UART)


class EventCode(enum.IntEnum):
    BOOT = 1
    BUTTON = 2  # reset button pressed (the glove also resets its reference pose)
    POSE_RESET = 3  # reference pose reset (button or command)
    IMU_FAULT = 4  # arg: IMU index that stopped answering
    IMU_RECOVERED = 5  # arg: IMU index
    CALIB_START = 6
    CALIB_DONE = 7
    CALIB_REFUSED = 8  # the hand moved during gyro calibration; it is retried


class CommandCode(enum.IntEnum):
    SET_MODE = 1  # arg u8: Mode
    SET_RATE = 2  # arg u16: output rate in Hz
    RECALIBRATE = 3
    RESET_POSE = 4
    GET_STATUS = 5


class CalibState(enum.IntEnum):
    IDLE = 0
    RUNNING = 1
    DONE = 2
    REFUSED = 3


CLOCK_HOST_MONOTONIC = 0x01  # StatusFrame.clock_flags: t_us is the host's CLOCK_MONOTONIC in µs (emulator)


@dataclass(slots=True)
class PoseFrame:
    """16 parent-relative segment quaternions (w, x, y, z), float32 array of shape (16, 4)."""

    seq: int
    t_us: int
    quats: np.ndarray
    measured_mask: int = MEASURED_MASK
    rx_ns: int = 0  # host receive time (time.monotonic_ns), set by the link
    kind = FrameKind.POSE


@dataclass(slots=True)
class PoseCompactFrame:
    """The hand in 52 bytes (docs/protocol.md, pose_compact): ``palm_quat`` (4,) float32, the palm's
    orientation (w, x, y, z) as in a pose frame, and ``angles`` (20,) float32, the joint angles of
    recorder.protocol.layout.JOINTS in radians (NaN: not available)."""

    seq: int
    t_us: int
    palm_quat: np.ndarray
    angles: np.ndarray
    rx_ns: int = 0
    kind = FrameKind.POSE_COMPACT


@dataclass(slots=True)
class RawFrame:
    """Raw MPU9250 readings: int16 array (n_imu, 7) of ax, ay, az, gx, gy, gz, temperature."""

    seq: int
    t_us: int
    data: np.ndarray
    accel_fs_g: int = 16
    gyro_fs_dps: int = 2000
    ok_mask: int = 0xFFF
    rx_ns: int = 0
    kind = FrameKind.RAW

    @property
    def accel_g(self) -> np.ndarray:
        return self.data[:, 0:3].astype(np.float64) * (self.accel_fs_g / 32768.0)

    @property
    def gyro_dps(self) -> np.ndarray:
        return self.data[:, 3:6].astype(np.float64) * (self.gyro_fs_dps / 32768.0)

    @property
    def temperature_c(self) -> np.ndarray:
        return self.data[:, 6].astype(np.float64) / MPU_TEMP_SENSITIVITY + MPU_TEMP_OFFSET_C


@dataclass(slots=True)
class StatusFrame:
    seq: int
    t_us: int
    firmware: tuple[int, int, int] = (0, 0, 0)
    mode: Mode = Mode.POSE
    sense_rate_hz: int = 0
    output_rate_hz: int = 0
    calib_state: CalibState = CalibState.IDLE
    calib_progress: int = 0
    clock_flags: int = 0
    glove_id: int = 0
    imu_ok_mask: int = 0xFFF
    mux_map: tuple[int, ...] = MUX_MAP
    joint_map: tuple[int, ...] = JOINT_MAP
    rx_ns: int = 0
    kind = FrameKind.STATUS


@dataclass(slots=True)
class EventFrame:
    seq: int
    t_us: int
    code: EventCode
    arg: int = 0
    rx_ns: int = 0
    kind = FrameKind.EVENT


@dataclass(slots=True)
class Command:
    """Host -> glove. ``arg`` is the mode for SET_MODE and the rate in Hz for SET_RATE."""

    code: CommandCode
    arg: int = 0
    seq: int = 0
    t_us: int = 0
    rx_ns: int = 0
    kind = FrameKind.COMMAND


Frame = PoseFrame | PoseCompactFrame | RawFrame | StatusFrame | EventFrame | Command


def identity_pose() -> np.ndarray:
    q = np.zeros((N_SEGMENTS, 4), np.float32)
    q[:, 0] = 1.0
    return q
