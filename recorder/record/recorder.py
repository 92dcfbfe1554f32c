"""The recording session: episodes of a fixed-rate loop from the glove through retargeting into the
environment, written frame by frame into a crash-safe LeRobot dataset.

Each frame k of an episode, at glove time tick_k = start + k / fps:
  glove pose at tick_k (interpolated between the samples around it) -> retarget -> env.step
  -> one dataset frame: the observation *before* the step, the action the env applied (after clipping),
  the human pose, quality, and the real clocks. So action[k] moves state[k] to state[k+1], and lerobot's
  timestamps are k / fps.
In real time the loop ticks on the host clock and reads the glove ``delay_s`` behind it so that a sample on
either side of the frame time has usually arrived; faster than real time it ticks on the glove's clock.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from recorder import GloverecError
from recorder.hand.profile import HandProfile, wearer_profile
from recorder.log.writer import McapLogger
from recorder.record.clock import ENDED, LOST, clock_for
from recorder.record.config import RecordConfig
from recorder.record.control import NEXT, RERECORD, STOP, TAKEOVER, Control
from recorder.record.dart import Dart
from recorder.record.features import DatasetSchema, Row
from recorder.record.live import LiveView
from recorder.record.sidecar import episode_notes
from recorder.record.store import EpisodeStore
from recorder.record.takeover import WEARER, Takeover, TakeoverConfig
from recorder.record.writer import EpisodeWriter
from recorder.rig.rig import Rig
from recorder.wrist.config import SCRIPTED
from recorder.wrist.fusion import FusedWrist

FIRST_SAMPLE_TIMEOUT_S = 5.0
NO_POSE_S = 30.0  # the reset period waits this long for the glove's first hand pose, saying what for
WAITING_NOTE_S = 1.0  # a wait longer than this is said in the terminal (the view shows it at once)

STDERR = object()  # ``out``'s default: sys.stderr as it is when the object is made


@dataclass
class EpisodeStats:
    """What the loop counts during one episode; stored in the episode's sidecar metadata."""

    counters0: dict  # the glove's link counters at the episode's start (Glove.counters)
    frames: int = 0
    held: int = 0  # frames whose glove pose had to be held (the glove was late)
    overruns: int = 0  # ticks that started more than one period late
    jitter_s: list = field(default_factory=list)
    latency_s: list = field(default_factory=list)
    retarget_mm: list = field(default_factory=list)
    wrist_lost: int = 0  # frames whose wrist the tracker did not see (held, or catching up)
    wrist_delays_s: list = field(default_factory=list)  # per live tracker pose: (its tracking, stamp to applied)

    def counted(self, now: dict) -> dict:
        """The link's counters over the episode so far."""
        return {k: now[k] - self.counters0.get(k, 0) for k in now}

    def summary(self, counters: dict) -> dict:
        def pct(xs, q, scale=1e3):
            return round(float(np.percentile(xs, q)) * scale, 3) if len(xs) else None

        c = self.counted(counters)
        return {
            "frames": self.frames,
            "glove_dropped": c["gaps"] + c["queue_drops"],
            "glove_late": self.held,
            "glove_errors": c["errors"],
            "loop_overruns": self.overruns,
            "jitter_ms_p99": pct(self.jitter_s, 99),
            "latency_ms_p50": pct(self.latency_s, 50),
            "latency_ms_p99": pct(self.latency_s, 99),
            "retarget_error_mm_mean": round(float(np.mean(self.retarget_mm)), 3) if self.retarget_mm else None,
            "wrist_untracked": self.wrist_lost,
            "wrist_tracking_ms_p99": pct([d[0] for d in self.wrist_delays_s], 99),
            "wrist_to_target_ms_p50": pct([d[1] for d in self.wrist_delays_s], 50),
            "wrist_to_target_ms_p99": pct([d[1] for d in self.wrist_delays_s], 99),
        }


class Recorder:
    def __init__(
        self,
        cfg: RecordConfig,
        control: Control | None = None,
        out=STDERR,
        plan=None,
        profile: HandProfile | None = None,
        agent=None,
    ):
        """``agent(env) -> policy``: with ``cfg.policy``, what loads and checks that policy for this environment (an
        object with ``reset(env, seed)`` and ``act(obs) -> action``; the command passes it, policies/ being a layer
        above this one): it drives the hand and the wearer takes over (recorder/record/takeover.py).
        ``plan``: (seed, device_start_s, frames) per episode, to re-record a log's episodes exactly
        (`gloverec rerecord`); episodes then start at those device times instead of at buttons or keys.
        ``profile``: the wearer's hand (default: ``cfg.wearer``'s saved profile, or the reference hand)."""
        self.cfg = cfg
        profile = profile if profile is not None else wearer_profile(cfg.wearer)  # missing: one line, first
        self.plan = list(plan) if plan is not None else None
        self.out = sys.stderr if out is STDERR else out  # None: silent; stderr resolved now (it may be redirected)
        cfg.check()
        # the session's parts: the task (reset: a setting that cannot work fails before anything is written), the
        # wearer's hand and the retargeter, the demonstrator when the emulated wearer performs its demonstrations
        self.rig = Rig(cfg, options=cfg.task_options(), seed=cfg.seed, profile=profile, demonstrator=cfg.demonstrator,
                       failure_rate=cfg.failure_rate, watches=not cfg.open_loop, say=self._say)  # fmt: skip
        self.profile, self.env, self.u, self.retarget = profile, self.rig.env, self.rig.u, self.rig.retarget
        self.demonstrator = self.rig.demonstrator
        wrist = cfg.wrist_config
        if self.u.config.base_position and wrist.kind == SCRIPTED and self.demonstrator is None:
            raise GloverecError(f"the {cfg.task} task needs a tracked wrist: --wrist udp:PORT or marker:CAMERA "
                                "(only the emulator's demonstrator moves a scripted one)")  # fmt: skip
        if wrist.follows_wearer and self.demonstrator is None:
            raise GloverecError(f"--wrist {wrist.kind} films the emulated wearer: record with --glove emulator")
        self.demo = None  # the demonstration being performed (its plan)
        if (agent is None) != (cfg.policy is None):
            raise GloverecError("a takeover recording needs its policy loaded: record it with `gloverec record`")
        self.agent = agent(self.env) if agent is not None else None  # a wrong policy: one line, before any file
        space = self.env.action_space
        self.takeover = None
        if agent is not None:
            config = TakeoverConfig(cfg.takeover_threshold, cfg.takeover_hold_s, auto=cfg.takeover)
            self.takeover = Takeover(config, space.low, space.high, cfg.fps)
        # DART: the executed action is the wearer's with noise, the wearer's kept beside it (recorder/record/dart.py)
        self.dart = Dart(cfg.dart, cfg.dart_time_s, space.low, space.high, cfg.fps) if cfg.dart else None
        # the wearer's action beside the executed one: DART's, and a takeover recording's, where the policy's frames
        # carry what the wearer would have done there (DAgger's labels: `gloverec train --learn-from intended`)
        self.schema = DatasetSchema(self.u, use_videos=bool(cfg.cameras), takeover=agent is not None,
                                    expert=self.dart is not None or agent is not None)  # fmt: skip
        self.store = EpisodeStore(
            cfg.root_path,
            cfg.repo_id,
            cfg.fps,
            self.schema.lerobot_features(),
            robot_type=cfg.robot,
            resume=cfg.resume,
            use_videos=bool(cfg.cameras),
        )
        self.writer = EpisodeWriter(self.store)  # forked now: before the glove, the log or any thread opens
        try:
            self._open_session(control)
        except BaseException:
            self.writer.close()  # an idle writer: ends at once (else the exit would wait for it forever)
            self.store.close()
            raise

    def _open_session(self, control) -> None:
        cfg = self.cfg
        self.rig.wear(fast=cfg.is_fast, say=self._say)  # the glove (worn by the performer) and the tracked wrist
        self.glove, self.wrist = self.rig.glove, self.rig.wrist
        self.clock = clock_for(cfg.is_fast, self.glove, cfg.fps, cfg.glove.rate_hz)
        self.glove.fusion.keep_in(self.store.work, self._say)  # meta/gloverec/calibration.json, before any episode
        write_profile(self.store.work, self.profile)  # meta/gloverec/hand_profile.json: whose hand it was
        self._device_shift = 0.0  # the glove's device clock - the loop's, at the frame in progress (the wrist's log)
        self.logger = None
        self.log_rel = None
        if cfg.log:
            self._open_log()
        self.control = control if control is not None else Control()
        self.control.on_reset(self.glove.reset_pose)  # the reset key re-takes host fusion's reference pose
        self.live = LiveView(cfg.view, cfg, self.u, self.glove, self.control, self.store.work, self._say,
                             self.profile.size(), beside_realtime=self.clock.precedence)  # fmt: skip
        self.period = 1.0 / cfg.fps
        self._last_line = 0.0

    def _open_log(self) -> None:
        logs = self.store.work / "logs"
        logs.mkdir(parents=True, exist_ok=True)
        name = time.strftime("session-%Y%m%d-%H%M%S.mcap")
        self.logger = McapLogger(
            logs / name,
            {
                "source": str(self.cfg.glove_config),
                "repo_id": self.cfg.repo_id,
                "robot": self.cfg.robot,
                "task": self.cfg.task,
                "fps": str(self.cfg.fps),
                "hand_profile": json.dumps(self.profile.as_dict()),
                **({"dart": str(self.cfg.dart), "dart_time_s": str(self.cfg.dart_time_s)} if self.dart else {}),
            },
            calibration=self.glove.fusion.record,
        )
        self.glove.fusion.on_record(self.logger.set_calibration)  # a real glove's: once its first frames came
        self.glove.tap(self.logger)
        self.log_rel = f"logs/{name}"
        if self.wrist is not None:  # every tracker pose the fusion takes, on the glove's clock (rerecord plays them)
            f = self.wrist.fusion
            self.logger.wrist_channel(str(self.cfg.wrist_config), f.config.latency_s, f.marker_in_palm)
            self.wrist.on_pose = self._log_wrist

    def _log_wrist(self, pose, t: float) -> None:
        """A tracker pose the fusion took at loop time ``t``, into the log with its times on the glove's clock."""
        shift = self._device_shift
        self.logger.wrist(replace(pose, t=pose.t + shift), t + shift)

    # ------------------------------------------------------------ the session
    def run(self) -> dict:
        """Record until ``episodes`` are saved or the user stops; returns a summary."""
        cfg = self.cfg
        interrupted = False
        self.saved = []
        note = self.clock.session()
        if note:
            self._say(note)
        try:
            self._episodes(cfg)
        except KeyboardInterrupt:  # Ctrl-C or `kill`: what the writer was handed is saved, the rest dropped
            interrupted = True
        finally:
            self.close()
        saved = self.saved
        return {
            "root": str(cfg.root_path),
            "repo_id": cfg.repo_id,
            "episodes_saved": len(saved),
            "total_episodes": self.store.num_episodes + len(saved),  # this process' store: as opened
            "total_frames": self.store.num_frames + sum(s["frames"] for s in saved),
            "rerecorded": self.rerecorded,
            "lost": self.lost,
            "interrupted": interrupted,
            "success_rate": round(float(np.mean([s["success"] for s in saved])), 3) if saved else None,
            "log": self.log_rel,
            **self.live.summary(),
        }

    def _episodes(self, cfg: RecordConfig) -> None:
        """The session's episodes, until ``episodes`` are saved, the user stops or the glove source ends."""
        recorded, self.rerecorded, self.lost = 0, 0, 0
        self.glove.open()
        self._say(
            f"recording {cfg.episodes} episode(s) of {cfg.task} on {cfg.robot} from {self.glove.name} "
            f"({self.clock.label}) into {cfg.root_path}"
        )
        while recorded < (cfg.episodes if self.plan is None else len(self.plan) + recorded):
            index = self.store.next_index
            outcome, result = self._one_episode(index)
            self._report_saved()
            if outcome == "saved":
                recorded += 1
            elif outcome == "rerecord":
                self.rerecorded += 1
                self._say(f"episode {index} discarded: re-recording it")
            elif outcome == "lost":
                self.lost += 1
                self._say(f"episode {index} discarded: the glove went away; it will be re-recorded")
            if outcome == "stop" or (outcome == "saved" and result.get("stop")):
                break
            if outcome == "ended":
                self._say("the glove source ended")
                break

    def _report_saved(self, wait: bool = False) -> None:
        """Say which episodes the writer process has saved (published) since the last call."""
        for index, result in self.writer.results(wait):
            self.saved.append(result)
            self.live.saved_episode(result["success"])
            self._say(
                f"episode {index} saved: {result['frames']} frames, success={result['success']}, "
                f"late {result['glove_late']}, dropped {result['glove_dropped']}, "
                f"latency p99 {result['latency_ms_p99']} ms" + "".join(f"; {n}" for n in episode_notes(result))
            )

    def close(self) -> None:
        self.glove.close()
        try:
            self._report_saved(wait=True)
        finally:
            self.writer.close()
            # no episode ended (a glove that failed to open, a stop before the first): no hidden folder left behind
            self.store.close(discard_empty=self.writer.submitted == 0)
        if self.logger is not None:
            self.logger.close()
        self.live.close()
        self.control.close()
        self.rig.close()  # the wrist and the task (the glove again: closing it twice is fine)
        if self.out is not None and self.out.isatty():  # the status line ends: what is printed next starts afresh
            self.out.write("\r\x1b[K")
            self.out.flush()

    # ------------------------------------------------------------ one episode
    def _one_episode(self, index: int) -> tuple[str, dict | None]:
        planned = self.plan.pop(0) if self.plan else None
        seed = self.cfg.seed + index if planned is None else planned[0]
        obs, info = self.env.reset(seed=seed)
        self.task_text = self.live.task_text = self.cfg.task_text or self.u.instruction()
        self.live.seed = seed
        self.retarget.reset()
        if self.agent is not None:
            self.agent.reset(self.env, seed)
            self.takeover.reset()
            self.live.control = self.takeover.who
        if self.dart is not None:
            self.dart.reset(seed)
        self.demo = self.rig.demonstrate(seed) if self.demonstrator is not None else None
        if planned is not None:
            start = planned[1] if self.glove.wait_past(planned[1]) else None
            self.glove.buttons.clear()
        else:
            start = self._wait_for_start(index)
        if start is None:
            return ("ended" if self.glove.finished else "stop"), None
        if self.logger is not None:
            self.logger.mark("episode_start", episode=index, seed=seed, glove_time_s=start)
        if self.clock.realtime:  # a person is watching (faster than real time, the saved lines say enough)
            self._say(f"episode {index} started: {self.task_text} (→ ends it, ← records it again, Esc stops)")
        with self.clock.episode():
            return self._record(index, seed, obs, start, None if planned is None else planned[2])

    def _wait_for_start(self, index: int) -> float | None:
        """The reset period: ends at the glove's button, → on the keyboard, or ``reset_time_s`` after the glove's
        first hand pose (the countdown runs only once there is one; until then the view and the terminal say
        what it waits for, and after NO_POSE_S of waiting the session ends with that, in one line)."""
        g = self.glove
        if not self.clock.first_frames(FIRST_SAMPLE_TIMEOUT_S):
            raise GloverecError(self._no_pose(FIRST_SAMPLE_TIMEOUT_S))
        if self.demonstrator is None:
            g.buttons.clear()  # a press from before the reset period does not skip it
        limit = float("inf") if self.demonstrator is not None else self.cfg.reset_time_s
        begin = None  # glove time of the first pose seen in this reset period
        waiting_since = state_since = time.monotonic()  # since when it waits at all / for this same thing
        said = shown = None
        asked = False
        while True:
            g.poll(timeout=0.02)
            self._report_saved()
            waiting = g.waiting_for()
            if waiting is None and begin is None:
                begin = g.now()
            if waiting is None:
                waiting_since = time.monotonic()
            if waiting != shown:
                shown, state_since = waiting, time.monotonic()
            countdown = None if limit == float("inf") or begin is None else max(0.0, limit - (g.now() - begin))
            self.live.reset_period(index, countdown, waiting)
            if waiting is not None and waiting != said and time.monotonic() - state_since > WAITING_NOTE_S:
                said = waiting
                self._say(f"waiting for {waiting}")
            button = g.take_button()
            what = self.control.take()
            if what == STOP:
                return None
            if button is not None and begin is not None:
                return button
            asked = asked or what == NEXT or button is not None
            if begin is not None and (asked or g.now() - begin >= limit):
                return g.now()
            if g.finished and g.poll() == 0:
                return None
            if waiting is not None and time.monotonic() - waiting_since > NO_POSE_S:
                raise GloverecError(self._no_pose(NO_POSE_S))
            if begin is not None:
                self.clock.advance()

    def _no_pose(self, seconds: float) -> str:
        """Why no episode could start, from what the glove did (frames it sent, what its first pose waits for)."""
        g = self.glove
        if g.finished:
            fusion = g.fusion.waiting  # a raw log cut before host fusion could start
            return f"{g.name} ended after {g.received} frames without a hand pose" + (f" ({fusion})" if fusion else "")
        if g.received == 0:
            return f"no glove frames from {g.name} in {seconds:.0f} s: is it connected and sending?"
        came = f"{g.received} frames came"
        return f"no hand pose from {g.name} in {seconds:.0f} s ({came}): waiting for {g.waiting_for()}"

    def _record(
        self, index: int, seed: int, obs: dict, start: float, frames: int | None = None
    ) -> tuple[str, dict | None]:
        """The episode's frames from glove time ``start`` (``frames`` of them when re-recording a log), until the
        task ends, the time is up, a key or the glove's button ends it, or the glove goes away."""
        g, clock = self.glove, self.clock
        stats = EpisodeStats(g.counters())
        n_max = frames or int(round(self.u.config.episode_s * self.cfg.fps))
        clock.start(start)
        self.rig.episode_start = start  # the emulated wearer's palm as planned is the demonstration's from here
        if self.wrist is not None:
            self._zero_wrist(start)
        device_start, success, stop_after, host_tick = None, False, False, None
        for k in range(n_max):
            tick = start + k * self.period
            host_tick = clock.tick(k, tick, stats)
            if host_tick == ENDED:
                break
            t_pose = clock.pose_time(tick)
            at = g.track.at(t_pose) if host_tick != LOST else None
            if at is None:
                return self._lost(index)
            device_time = clock.device_time(at, t_pose)
            device_start = device_time if device_start is None else device_start
            obs, info, done = self._frame(index, k, n_max, obs, at, host_tick, device_time, stats, t_pose)
            success = bool(info["is_success"])
            self._status_line(index, k, n_max, stats)
            what = self.control.take()
            if what == RERECORD:
                self.store.discard_episode()
                return "rerecord", None
            if what in (NEXT, STOP):
                stop_after = what == STOP
                break
            button = g.take_button() is not None
            if (what == TAKEOVER or button and self.demonstrator is None) and self.takeover is not None:
                self.takeover.toggle()  # the key, or a wearer's button: control to the other one
                self.live.control = self.takeover.who
            elif button and self.demonstrator is None and self.plan is None:
                break  # the glove's button ends the episode (the demonstrator uses it to start one; a re-recorded
                # log's episodes end where they ended)
            if done:
                break
        if stats.frames == 0:
            self.store.discard_episode()
            return ("ended" if host_tick == ENDED else "stop"), None
        result = self._saved(index, seed, success, start, device_start, stats)
        if stop_after:
            result["stop"] = True
        return "saved", result

    def _zero_wrist(self, start: float) -> None:
        """The episode starts with the wearer's palm in the nominal pose: the tracker's mapping is set on it."""
        g = self.glove
        t = self.clock.pose_time(start)
        steps = [t]

        def wait() -> float:
            """The loop's time while the zero waits for a tracked pose: the host's now in real time; faster, one
            frame period a step from the frame time, so that the session's log re-records the same steps."""
            if self.clock.realtime:
                g.poll(timeout=0.02)
                return g.now()
            steps.append(steps[-1] + self.period)
            g.wait_past(steps[-1])
            return steps[-1]

        at = g.track.at(t)
        if at is None:
            raise GloverecError(f"no hand pose from {g.name} to start the wrist's tracking on")
        self._shift_to_device(self.clock.device_time(at, t), t)
        self.rig.zero_wrist(t, at.pose.palm, wait)

    def _shift_to_device(self, device_time: float, t: float) -> None:
        """The glove's device clock less the loop's (0 faster than real time, or for a glove without a clock)."""
        self._device_shift = device_time - t if device_time >= 0 else 0.0

    def _wrist(self, t: float, palm) -> FusedWrist | None:
        """The palm's pose in the robot's world at glove time ``t`` for a free-wrist task: tracked and fused with the
        glove's ``palm``, or the emulated wearer's (a demonstrator's scripted wrist); None: the task scripts it."""
        if self.wrist is not None:
            self.wrist.update(t, palm)
            return self.wrist.pose(t)
        if self.u.config.base_position:
            pos, _ = self.rig.wearer_palm(t)
            return FusedWrist(pos, np.asarray(palm, float), True, 0.0)
        return None

    def _frame(self, index, k, n_max, obs, at, host_tick, device_time, stats, t_pose):
        """One dataset frame: the glove's pose retargeted, the env stepped, the observation before the step and
        the applied action stored. Returns (the next observation, the step's info, whether the task ended)."""
        stats.held += at.held
        self._shift_to_device(device_time, t_pose)
        wrist = self._wrist(t_pose, at.pose.palm)
        if wrist is not None:
            stats.wrist_lost += not wrist.tracked
        palm = at.pose.palm if wrist is None else wrist.quat
        action, rinfo = self.retarget(at.pose.angles, palm, None if wrist is None else wrist.position)
        decision, intended = None, None
        if self.agent is not None or self.dart is not None:
            intended = self.u.clip_action(action)  # the wearer's action, as the environment would apply it
        if self.agent is not None:  # the policy drives unless the wearer has taken over
            decision = self.takeover.decide(self.agent.act(obs), action)
            action = decision.action
            self.live.control = self.takeover.who
        if self.dart is not None:  # the wearer's action perturbed: the env clips the executed one
            action = self.dart.perturb(intended)
        if intended is not None:
            intended = intended.astype(np.float32)
        latency = self.clock.latency(at)
        nxt, _, terminated, truncated, info = self.env.step(action)
        if self.wrist is not None:
            stats.wrist_delays_s.extend(self.wrist.applied())  # its target applied: a tracker's frame's delay
        if self.demo is not None:
            self.demo.watch(self.u, into=self.rig.performer)  # a demonstrator that watches corrects what is still ahead
        row = Row(obs, info["applied_action"], at.pose, latency, at.age_s, rinfo["tip_error_mean"], host_tick,
                  device_time, self.task_text, wrist, decision, intended)  # fmt: skip
        self.live.recording(index, k, n_max, stats, wrist)
        self.store.add_frame(self.schema.frame(row))
        stats.frames += 1
        if latency is not None:
            stats.latency_s.append(latency)
        stats.retarget_mm.append(rinfo["tip_error_mean"] * 1e3)
        return nxt, info, terminated or truncated

    def _saved(self, index: int, seed: int, success: bool, start: float, device_start, stats) -> dict:
        """The episode handed to the writer process, with its sidecar line (and its marks in the session log)."""
        cfg = self.cfg
        result = {
            "task": self.task_text,
            "seed": seed,
            "success": success,
            "robot": cfg.robot,
            "env_task": cfg.task,
            "repo_id": cfg.repo_id,  # a folder passed where a dataset is expected (train --also) says its own name
            "fps": cfg.fps,
            "glove": self.glove.name,
            "realtime": self.clock.realtime,
            **({"loop_priority": "realtime" if self.clock.precedence else "normal"} if self.clock.realtime else {}),
            "retarget": cfg.retarget,
            "wearer": self.profile.wearer,
            "hand_length_mm": self.profile.hand_length_mm,
            "start_glove_time_s": start,
            "start_device_time_s": device_start,
            **stats.summary(self.glove.counters()),
        }
        if self.u.unstable_s is not None:  # MuJoCo reset the state mid-episode: said in the line and the sidecar
            result["physics_unstable_s"] = self.u.unstable_s
        if self.takeover is not None:
            result["takeover"] = {"policy": self.cfg.policy, **self.takeover.summary()}
        if self.dart is not None:
            result["dart"] = self.dart.summary()
        if self.demo is not None and self.demo.intent is not None:
            result["demonstration"] = self.demo.intent  # what the human-like wearer meant: strategy, failure
        why = None if success else self.u.failure()  # where the take went wrong, as the task sees it
        if why is not None:
            result["failed_because"] = why
        if self.logger is not None:
            self.logger.mark("episode_end", episode=index, seed=seed, frames=stats.frames, success=success,
                             device_start_s=device_start)  # fmt: skip
            self.logger.flush()
            result["log"] = {"file": self.log_rel, **self.clock.log_range(self.logger, start, stats.frames)}
        self.writer.submit(self.store.take_episode(), result)
        return result

    def _lost(self, index: int) -> tuple[str, None]:
        """The glove vanished mid-episode: drop the episode, wait for the glove, then carry on."""
        self.store.discard_episode()
        if self.logger is not None:
            self.logger.mark("episode_discarded", episode=index, reason="glove disconnected")
        self._say("the glove is gone: waiting for it to come back (Ctrl-C to stop)")
        while not self.glove.connected:
            if self.control.take() == STOP:
                break
            time.sleep(0.1)
        self.glove.track = type(self.glove.track)()
        return "lost", None

    # ------------------------------------------------------------ reporting
    def _say(self, text: str) -> None:
        if self.out is not None:
            print(("\r\x1b[K" if self.out.isatty() else "") + text, file=self.out, flush=True)

    def _status_line(self, index: int, k: int, n: int, stats: EpisodeStats) -> None:
        if self.out is None or not self.out.isatty() or time.monotonic() - self._last_line < 0.25:
            return
        self._last_line = time.monotonic()
        lat = np.percentile(stats.latency_s, 99) * 1e3 if stats.latency_s else 0.0
        line = (
            f"episode {index}  frame {k + 1}/{n}  late {stats.held}  overruns {stats.overruns}  "
            f"latency p99 {lat:.1f} ms  glove {'up' if self.glove.connected else 'DOWN'}"
        )
        if self.takeover is not None:
            line += f"  control {'WEARER' if self.takeover.who == WEARER else 'policy'}"
        self.out.write("\r\x1b[K" + self.live.with_wrist(line, self.out))
        self.out.flush()


PROFILE_FILE = Path("meta") / "gloverec" / "hand_profile.json"  # beside the glove's calibration.json


def write_profile(folder, profile: HandProfile) -> Path:
    """The wearer's hand profile into a dataset's metadata (atomically)."""
    path = Path(folder) / PROFILE_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(profile.as_dict(), indent=1) + "\n")
    tmp.replace(path)
    return path


def record(cfg: RecordConfig, profile: HandProfile | None = None, agent=None) -> dict:
    return Recorder(cfg, profile=profile, agent=agent).run()
