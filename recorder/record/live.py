"""What the person demonstrating sees while `gloverec record` runs (``--view``, recorder/view): the scene as it
is simulated, the target gesture as a ghost, their own hand as the glove measures it, and the status: the task,
episode k of N and its phase (reset with a countdown, recording with the time left), the scripted move coming up
("lift in 1.2 s"), the successes so far, the glove's health and the keys; with a free wrist, the tracked palm,
its tracking and the workspace's bounds (recorder/view/wrist.py), which the terminal's status line also gets
when it has room. The view's keys and buttons come back as the same requests as the terminal's keys.

Publishing costs the loop a copy of a few kilobytes, at most ``PUBLISH_HZ`` times a second; the status figures
are refreshed every ``STATUS_S``.
"""

from __future__ import annotations

import os
import time

import numpy as np

from recorder.view import wrist as wrist_view
from recorder.view.overlay import wrist_brief
from recorder.view.process import ViewSpec, default_view, open_view
from recorder.view.scene import frame_of, layout_of

PUBLISH_HZ = 60.0
STATUS_S = 0.25


class LiveView:
    def __init__(self, view: str | None, cfg, env, glove, control, root, say, hand_size=None, beside_realtime=False):
        """``view``: a view spec, None for the default (native with a display and a terminal, else none, said).
        ``hand_size``: the wearer's, for the human hand the view draws. ``beside_realtime``: the episodes run in
        the real-time class (the clock's ``precedence``), so the view need not yield to the loop
        (recorder/view/process.py)."""
        if view is None:
            view, hint = default_view()
            if hint:
                say(hint)
        spec = ViewSpec.parse(view)
        if spec.kind == "rerun" and spec.mode == "save" and not spec.target:
            (root / "logs").mkdir(parents=True, exist_ok=True)
            spec = ViewSpec("rerun", mode="save", target=str(root / "logs" / time.strftime("view-%Y%m%d-%H%M%S.rrd")))
        self.env, self.glove, self.cfg = env, glove, cfg
        options = {"control_hz": float(cfg.fps), "episode_s": float(env.config.episode_s)}
        if env.config.base_position:  # a free wrist: the view frames the workspace's bounds
            options["base_position"] = True
        self.view = open_view(spec, cfg.task, cfg.robot, layout_of(env), options, on_event=control.request, say=say,
                              hand_size=hand_size, beside_realtime=beside_realtime)  # fmt: skip
        if self.view is not None:
            self.view.wait_ready()
        self.saved, self.successes = 0, 0
        self.task_text = ""
        self.seed = 0  # the scene's seed: the view resets its copy of the scene with it
        self._last = 0.0
        self._status_at = -1.0
        self._glove: dict = {}
        self._late_ms = 0.0  # the loop's latest ticks, how late at most: views draw less when it is late
        self.control: str | None = None  # a takeover recording's driver now: "policy" or "wearer"
        self.wrist: dict | None = None  # the status' wrist now (recorder/view/wrist.py); None: the task scripts it

    @property
    def on(self) -> bool:
        return self.view is not None

    def saved_episode(self, success: bool) -> None:
        self.saved += 1
        self.successes += bool(success)

    def reset_period(self, index: int, countdown: float | None, waiting: str | None = None) -> None:
        """``countdown``: seconds until the episode starts (None: no limit, or not running yet); ``waiting``: what
        the glove's first pose waits for."""
        if self.env.config.base_position:
            self.wrist = wrist_view.waiting(self.cfg.wrist_config.kind)
        self._publish({"phase": "reset", "episode": index, "countdown": countdown, "waiting": waiting})

    def recording(self, index: int, k: int, frames: int, stats, wrist=None) -> None:
        """Frame ``k`` of ``frames``; ``wrist``: a free wrist's FusedWrist."""
        if wrist is not None:
            self.wrist = wrist_view.status(wrist, self.env.base_bounds, stats.wrist_lost, k + 1,
                                           self.cfg.wrist_config.kind)  # fmt: skip
        left = (frames - k - 1) / self.cfg.fps
        self._publish({"phase": "recording", "episode": index, "time_left": left, "next": self._next_move()},
                      stats, wrist)  # fmt: skip

    def with_wrist(self, line: str, out) -> str:
        """The terminal's status ``line`` with the wrist's state when there is one and the terminal ``out`` has room."""
        brief = wrist_brief(self.wrist)
        try:
            columns = os.get_terminal_size(out.fileno()).columns
        except (AttributeError, OSError, ValueError):
            columns = 80
        return f"{line}  {brief}" if brief and len(line) + 2 + len(brief) < columns else line

    def close(self) -> None:
        if self.view is not None:
            self.view.close()

    def summary(self) -> dict:
        """The view, the frame rate it drew at and the frames it drew (known once closed)."""
        if self.view is None:
            return {"view": "none"}
        stats = self.view.stats
        return {
            "view": str(self.view.spec),
            "view_fps": round(stats.get("fps", 0.0), 1),
            "view_frames": stats.get("frames", 0),
        }

    # ------------------------------------------------------------ internals
    def _publish(self, status: dict, stats=None, wrist=None) -> None:
        now = time.monotonic()
        if self.view is None or now - self._last < 1.0 / PUBLISH_HZ:
            return
        self._last = now
        if now - self._status_at >= STATUS_S:
            self._status_at = now
            self._glove = self._health(stats)
        status.update(late_ms=self._late_ms, period_ms=1e3 / self.cfg.fps, seed=self.seed, task=self.task_text,
                      episodes=self.cfg.episodes, saved=self.saved, successes=self.successes,
                      glove=self._glove)  # fmt: skip
        if self.wrist is not None:
            status["wrist"] = self.wrist
        if self.control is not None:
            status["control"] = self.control
        self.view.publish(frame_of(self.env, status, self.glove.track.newest, wrist))

    def _health(self, stats) -> dict:
        g = self.glove
        health = g.health()
        out = {"rate_hz": health.rate_hz, "up": health.up}
        if stats is not None:
            out["late"] = stats.held
            self._late_ms = max(stats.jitter_s[-25:], default=0.0) * 1e3
            if stats.latency_s:
                out["latency_ms_p99"] = float(np.percentile(stats.latency_s, 99) * 1e3)
            counted = stats.counted(g.counters())
            out["dropped"] = counted["gaps"] + counted["queue_drops"]
        return out

    def _next_move(self) -> str | None:
        """The task's guidance now ("press with your ring"), else its next scripted move and when ("lift in 1.2 s"),
        from its schedule (HandGrasp)."""
        said = self.env.guidance()
        if said:
            return said
        schedule = getattr(self.env, "schedule", None) or {}
        t = self.env.t
        upcoming = [(at, name) for name, at in schedule.items() if at > t and name not in ("end", "hold")]
        if not upcoming:
            return None
        at, name = min(upcoming)
        return f"{name} in {at - t:.1f} s"
