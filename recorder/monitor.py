"""Link statistics over a session: rate, errors, gaps, latency percentiles, and a live status line."""

from __future__ import annotations

import sys
import time

import numpy as np

from recorder.link.base import GloveSource
from recorder.protocol.frames import PoseCompactFrame, PoseFrame, RawFrame


class LinkMonitor:
    """Consumes frames from a source and keeps what `gloverec monitor` reports."""

    def __init__(self, source: GloveSource):
        self.source = source
        self.latencies_s: list[float] = []
        self.frames = 0
        self.samples = 0  # pose and raw frames: the ones that carry hand data
        self.first_rx: int | None = None
        self.last_rx: int | None = None
        self.started = time.monotonic()

    def consume(self, frame) -> None:
        self.frames += 1
        if isinstance(frame, (PoseFrame, PoseCompactFrame, RawFrame)):
            self.samples += 1
            if self.first_rx is None:
                self.first_rx = frame.rx_ns
            self.last_rx = frame.rx_ns
            if frame.t_us >= 0:
                self.latencies_s.append(frame.rx_ns * 1e-9 - self.source.host_time_s(frame))

    def run(self, duration: float | None, live: bool = False, tick=None) -> None:
        end = None if duration is None else time.monotonic() + duration
        next_line = time.monotonic() + 0.5
        while end is None or time.monotonic() < end:
            frame = self.source.read(timeout=0.05)
            if frame is not None:
                self.consume(frame)
            elif self.source.finished:
                break
            if live and time.monotonic() >= next_line:
                sys.stderr.write("\r" + self.status_line() + "\x1b[K")
                sys.stderr.flush()
                next_line += 0.5
            if tick is not None:
                tick()
        if live:
            sys.stderr.write("\r" + self.status_line() + "\x1b[K\n")

    def rate_hz(self) -> float:
        if self.first_rx is None or self.samples < 2 or self.last_rx == self.first_rx:
            return 0.0
        return (self.samples - 1) / ((self.last_rx - self.first_rx) * 1e-9)

    def latency_ms(self, q: float) -> float | None:
        if not self.latencies_s:
            return None
        return float(np.percentile(self.latencies_s, q) * 1e3)

    def report(self) -> dict:
        st = self.source.stats()
        d = st.decode
        p50, p99 = self.latency_ms(50), self.latency_ms(99)
        return {
            "source": self.source.name,
            "protocol": st.protocol,
            "frames": self.frames,
            "samples": self.samples,
            "rate_hz": round(self.rate_hz(), 3),
            "errors": d["errors"],
            "crc_errors": d["crc_errors"],
            "format_errors": d["format_errors"],
            "gaps": d["gaps"],
            "reordered": d["reordered"],
            "queue_drops": st.queue_drops,
            "reconnects": st.reconnects,
            "disconnected_s": st.disconnected_s,
            "bytes": d["bytes"],
            "latency_ms_p50": None if p50 is None else round(p50, 4),
            "latency_ms_p99": None if p99 is None else round(p99, 4),
            "clock": "host" if self.source.clock.host_monotonic else "estimated",
            "clock_drift_ppm": round(st.clock_drift_ppm, 2),
            "duration_s": round(time.monotonic() - self.started, 3),
        }

    def status_line(self) -> str:
        r = self.report()
        lat = "-" if r["latency_ms_p50"] is None else f"{r['latency_ms_p50']:.2f}/{r['latency_ms_p99']:.2f} ms"
        link = "up" if self.source.connected else "DOWN"
        return (
            f"{r['protocol'] or 'no frames yet'} {link}  {r['rate_hz']:7.1f} Hz  frames {r['frames']}  "
            f"errors {r['errors']}  gaps {r['gaps']}  drops {r['queue_drops']}  "
            f"reconnects {r['reconnects']}  latency p50/p99 {lat}"
        )
