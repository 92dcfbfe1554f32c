"""A glove on a serial port (USB CDC on the Teensy, a UART adapter, or the emulator's pseudo-terminal)."""

from __future__ import annotations

import os

import serial

from recorder import GloverecError
from recorder.link.base import GloveSource


class SerialSource(GloveSource):
    def __init__(self, port: str, baudrate: int = 115200, **kw):
        super().__init__(**kw)
        self.port = port
        self.baudrate = baudrate
        self.name = f"serial:{port}"
        self._serial: serial.Serial | None = None

    def check(self) -> None:
        if not os.path.exists(self.port):
            raise GloverecError(f"cannot open {self.name}: no such port")

    def _connect(self) -> None:
        if not os.path.exists(self.port):
            raise FileNotFoundError(2, "no such port")
        try:
            self._serial = serial.Serial(self.port, self.baudrate, timeout=0.02, exclusive=True)
        except serial.SerialException as exc:
            raise OSError(str(exc).split(":")[-1].strip() or "cannot open port") from None
        self._serial.reset_input_buffer()  # bytes queued before we opened are stale samples

    def _read(self) -> bytes:
        s = self._serial
        try:
            return s.read(s.in_waiting or 1)
        except (serial.SerialException, TypeError) as exc:  # TypeError: pyserial on a closed fd
            raise OSError(str(exc)) from None

    def _disconnect(self) -> None:
        if self._serial is not None:
            self._serial.close()
            self._serial = None

    def send(self, data: bytes) -> None:
        if self._serial is None:
            return  # the port is gone; the command is lost like a keypress on an unplugged device
        try:
            self._serial.write(data)
        except serial.SerialException:
            pass
