"""Rig: one session's parts, built in one place from one SessionConfig (recorder/rig/config.py).

    rig = Rig(cfg, options=task_options, seed=seed, demonstrator="scripted")  # env, profile, retargeter, ...
    rig.wear(fast=...)         # the glove (not open yet) and the tracked wrist (open)
    ...
    rig.close()

Built in two steps because `gloverec record` forks its writer process between them: the task environment, the
wearer's hand profile, the retargeter (fitted to that hand) and the scripted demonstrator first (a task setting that
cannot work fails there, before any file is written), then what opens threads and devices: the glove, worn by the
Performer (recorder/demonstrator/performer.py) when the emulated wearer performs the demonstrator's demonstrations,
else ``make_glove``'s; and the tracked wrist (``open_wrist`` in a WristTrack with the tracker's latency and the
marker's mounting; ``marker:emulated`` films the performer's palm). ``zero_wrist`` sets the tracker's mapping as an
episode (or a live scene) starts. record, rerecord, view, the rollout (recorder/rig/rollout.py) and the LeRobot
teleoperator build their sessions here; `gloverec calibrate --wrist` takes its glove and wrist track from here too.
"""

from __future__ import annotations

import envs
from envs.robots import robot_names
from recorder import GloverecError
from recorder.demonstrator import make_demonstrator
from recorder.demonstrator.performer import Performer, performs
from recorder.glove.config import GloveConfig
from recorder.glove.glove import Glove, make_glove
from recorder.hand.profile import HandProfile, wearer_profile
from recorder.retarget import Retargeter
from recorder.rig.config import SessionConfig
from recorder.wrist import open_wrist
from recorder.wrist.config import SCRIPTED
from recorder.wrist.fusion import MARKER_ON_BACK, FusionConfig
from recorder.wrist.mounting import mounting
from recorder.wrist.track import WristTrack


def task_env(task: str, robot: str, options: dict | None = None, seed: int | None = None):
    """The task environment with ``options`` (its settings over the task's defaults), reset with ``seed`` (None: not
    reset); a name or a setting that cannot work: one-line GloverecError."""
    try:
        env = envs.make(task, robot, **(options or {}))
        if seed is not None:
            env.reset(seed=seed)  # a task setting that cannot work fails here, before anything opens
    except ValueError as exc:
        raise GloverecError(str(exc)) from None
    return env


def wear_glove(config: GloveConfig, *, performer: bool, **options) -> tuple[Glove, Performer | None]:
    """The glove a session reads, not open yet, and who wears it: the Performer when ``performer`` (the emulated
    wearer performing demonstrations), else None (a person, or the emulator's own motion). ``options``: Glove's."""
    if performer:
        wearer = Performer(config, **options)
        return wearer.glove, wearer
    return make_glove(config, **options), None


def wrist_track(source, marker_in_palm=MARKER_ON_BACK) -> WristTrack:
    """A wrist source's poses fused with the glove's palm: with the tracker's latency where the source knows it (a
    log's: its recording's; the emulated webcam's), the marker mounted on the palm as ``marker_in_palm``."""
    return WristTrack(source, FusionConfig(latency_s=getattr(source, "latency_s", 0.0)), marker_in_palm)


def open_wrist_track(cfg: SessionConfig, *, fast: bool = False, wearer=None, say=None) -> WristTrack | None:
    """The tracked wrist ``cfg`` names, open (None: the task's script, or a free-wrist task's demonstrator, moves
    the base). ``fast``: a video or a log is read as fast as it goes; ``wearer(t) -> (position, quat)``: the
    emulated wearer's palm, for a source that films it; ``say``: where the line naming the marker's mounting goes."""
    wrist = cfg.wrist_config
    if wrist.kind == SCRIPTED:
        return None
    source = open_wrist(wrist, cfg.wrist_camera, cfg.marker_mm, paced=not fast, glove=cfg.glove_config,
                        wearer=wearer)  # fmt: skip
    return wrist_track(source, mounting(source, cfg.wrist_mount, say=say, spec=str(wrist))).open()


def zero_wrist(track: WristTrack, env, t: float, palm, wait=None) -> None:
    """At time ``t`` the wearer's palm (the glove's orientation ``palm``) is in the nominal pose (palm down, fingers
    forward) where ``env``'s robot palm is: the tracker's mapping is set on it (``wait() -> t``: the time while it
    waits for a tracked pose)."""
    track.zero(t, env.unwrapped.palm_pose()[0], palm, wait)


class Rig:
    """See the module docstring. ``cfg``: the session; ``options``: the task's settings this command gives (None:
    the task's defaults); ``seed``: the environment's first reset (None: the command resets it); ``profile``: the
    wearer's hand (default: ``cfg.wearer``'s saved profile in ``folder``, or the reference hand); ``demonstrator``,
    ``failure_rate``: the scripted demonstrator's kind (scripted, human), made when the emulated wearer performs
    demonstrations (None: no demonstrator), ``watches=False`` its open-loop wearer; ``env=False``: no task
    environment (the teleoperator drives a robot,
    not a task), the retargeter then the robot hand's with its base turned by the palm (None for a robot that is
    not a gloverec hand); ``say``: where the rig's own lines go."""

    def __init__(
        self,
        cfg: SessionConfig,
        *,
        options: dict | None = None,
        seed: int | None = 0,
        profile: HandProfile | None = None,
        demonstrator: str | None = None,
        failure_rate: float | None = None,
        watches: bool = True,
        folder=None,
        env: bool = True,
        say=None,
    ):
        self.cfg, self.say = cfg, say
        self.profile = profile if profile is not None else wearer_profile(cfg.wearer, folder)  # missing: one line
        self.glove_config = cfg.glove_config
        self.wrist_config = cfg.wrist_config
        self.env = task_env(cfg.task, cfg.robot, options, seed) if env else None
        self.u = self.env.unwrapped if env else None
        size = self.profile.size()
        if env:
            self.retarget = Retargeter.for_env(self.env, cfg.retarget, hand_size=size)
        else:
            self.retarget = Retargeter(cfg.robot, cfg.retarget, hand_size=size) if cfg.robot in robot_names() else None
        scripted = demonstrator is not None and performs(self.glove_config)  # the emulated wearer performs them
        self.demonstrator = make_demonstrator(cfg.task, demonstrator, failure_rate, watches) if scripted else None
        self.glove: Glove | None = None
        self.performer: Performer | None = None  # the emulated wearer (with the demonstrator): it wears the glove
        self.wrist: WristTrack | None = None
        self.demo = None  # the demonstration being performed (its plan)
        self.episode_start = 0.0  # glove time at which the episode being performed started

    def wear(self, *, fast: bool = False, **glove_options) -> Rig:
        """The glove (not open yet: the command opens it once it has tapped it) and the tracked wrist (open);
        ``fast``: faster than real time; ``glove_options``: Glove's."""
        self.glove, self.performer = wear_glove(self.glove_config, performer=self.demonstrator is not None,
                                                fast=fast, **glove_options)  # fmt: skip
        wearer = self.wearer_palm if self.performer is not None else None  # what marker:emulated films
        self.wrist = open_wrist_track(self.cfg, fast=fast, wearer=wearer, say=self.say)
        return self

    def demonstrate(self, seed: int):
        """The demonstrator plans the episode's demonstration (the environment just reset with ``seed``) and the
        emulated wearer performs it next; returns the plan."""
        self.demo = self.demonstrator.plan(self.u, seed=seed)
        self.performer.demonstrate(self.demo)
        return self.demo

    def wearer_palm(self, t: float):
        """The emulated wearer's palm (position, quat) in the robot's world at glove time ``t``: as the emulator
        performs it (its IMUs measure that palm, drift included) faster than real time, else the demonstration's
        plan."""
        if self.glove.fast:
            return self.performer.performed(t)
        b = self.demo.at([t - self.episode_start])
        return b.palm_pos[0], b.palm_quat[0]

    def zero_wrist(self, t: float, palm, wait=None) -> None:
        """The tracked wrist's zero at time ``t`` (``zero_wrist``)."""
        zero_wrist(self.wrist, self.env, t, palm, wait)

    def close(self) -> None:
        for part in (self.glove, self.wrist, self.env):
            if part is not None:
                part.close()
