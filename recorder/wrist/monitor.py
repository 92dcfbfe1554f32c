"""What `gloverec wrist` reports of a wrist source: the latest pose, the rate, the tracked share, latency. A file
read as fast as it reads (``video_clock``: a video or a log, `--fast`) is timed by its own stamps, with no latency."""

from __future__ import annotations

import sys
import time

import numpy as np


class WristMonitor:
    def __init__(self, source):
        self.source = source
        self.poses = 0
        self.tracked = 0
        self.lost = 0  # messages missing from the seq numbers
        self.latencies_s: list[float] = []
        self.first_t = self.last_t = None
        self.last = None
        self._seq = None
        self.started = time.monotonic()
        self.video_clock = bool(getattr(source, "video_clock", False))  # known once the source is open

    def consume(self, pose, arrived: float) -> None:
        self.poses += 1
        self.tracked += pose.tracked
        if self._seq is not None:
            self.lost += max((pose.seq - self._seq) % 2**32 - 1, 0)
        self._seq = pose.seq
        at = pose.t if self.video_clock else arrived
        self.first_t = at if self.first_t is None else self.first_t
        self.last_t, self.last = at, pose
        if not self.video_clock:
            self.latencies_s.append(arrived - pose.t)

    def run(self, duration: float | None, live: bool = False) -> None:
        """Take poses for ``duration`` s (None: until the source finishes or Ctrl-C), with a status line on stderr
        every 0.5 s when ``live`` (as LinkMonitor.run)."""
        end = None if duration is None else time.monotonic() + duration
        next_line = time.monotonic() + 0.5
        while end is None or time.monotonic() < end:
            finished = self.source.finished  # before taking: what came before the end is taken
            for pose, arrived in self.source.take():
                self.consume(pose, arrived)
            if finished:
                break
            if live and time.monotonic() >= next_line:
                sys.stderr.write("\r" + self.status_line() + "\x1b[K")
                sys.stderr.flush()
                next_line += 0.5
            time.sleep(0.01)
        for pose, arrived in self.source.take():
            self.consume(pose, arrived)
        if live:
            sys.stderr.write("\r" + self.status_line() + "\x1b[K\n")

    def status_line(self) -> str:
        r = self.report()
        if self.last is None:
            return f"wrist {self.source.name}: no poses yet ({r['rejected']} rejected)"
        p = r["position_m"]
        lat = "-" if r["latency_ms_p50"] is None else f"{r['latency_ms_p50']:.1f} ms"
        return (f"wrist at ({p[0]:+.3f}, {p[1]:+.3f}, {p[2]:+.3f}) m, {r['rate_hz']:.0f} Hz, tracked "
                f"{100 * r['tracked_fraction']:.0f} %, latency p50 {lat}")  # fmt: skip

    def report(self) -> dict:
        lat = np.asarray(self.latencies_s) * 1000.0
        span = (self.last_t - self.first_t) if self.poses > 1 else 0.0
        return {
            "source": self.source.name,
            "duration_s": round(time.monotonic() - self.started, 3),
            "poses": self.poses,
            "rate_hz": round((self.poses - 1) / span, 2) if span > 0 else 0.0,
            "tracked_fraction": round(self.tracked / self.poses, 4) if self.poses else 0.0,
            "lost": self.lost,
            "late": self.source.late,
            "rejected": self.source.bad,
            "last_rejection": self.source.last_error,
            "latency_ms_p50": round(float(np.percentile(lat, 50)), 3) if lat.size else None,
            "latency_ms_p99": round(float(np.percentile(lat, 99)), 3) if lat.size else None,
            "position_m": None if self.last is None else [round(float(v), 4) for v in self.last.position],
            "quat_wxyz": None if self.last is None else [round(float(v), 5) for v in self.last.quat],
            "tracked": None if self.last is None else self.last.tracked,
        }
