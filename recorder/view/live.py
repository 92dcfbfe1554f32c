"""``gloverec view``: a robot hand in MuJoCo follows the glove live, shown by a live view (recorder/view/process.py:
native, web or rerun) or rendered to a video.

    gloverec view --glove emulator|serial:PORT|udp:PORT|mcap:FILE --robot NAME [--task pose|grasp]
                  [--retarget joint|ik|pinch] [--wearer NAME] [--view native|web[:PORT]|rerun[:MODE]] [--video FILE.mp4]
                  [--duration S] [--wrist udp:PORT|marker:CAMERA [--wrist-camera FILE.json] [--wrist-mount FILE.json]
                  [--marker-mm 40]]

The glove's newest HandPose (any glove: pose, compact, or raw frames fused on the host) is retargeted and steps
the task at its control rate. The view shows what `gloverec record` shows: the scene, the target gesture as a
ghost, the human hand, the glove's health; its "next" key starts a new scene, "zero" re-takes the reference pose,
"stop" ends. A video (MUJOCO_GL=egl, headless) has the ghost and the human hand too. ``--wearer NAME``: that
wearer's hand profile (recorder/hand/profile.py), which retargeting and the drawn human hand use.
``--glove emulator`` runs the glove emulator on a pseudo-terminal in this process and reads it through the real
serial path.

``--wrist SOURCE``: a tracker moves the hand's base, as with `gloverec record --wrist` (recorder/wrist: the same
source, fusion with the palm IMU and mapping; zeroed as the view starts, at each new scene and on the zero key),
and the view shows the tracked palm, its tracking and the workspace's bounds (recorder/view/wrist.py). A free-wrist
task (relocate) has no base without one, and says so in one line.

The session (the task with its live settings, the wearer's hand and the retargeter, the glove, the wrist track and
its zero) is built by the rig (recorder/rig/rig.py), as `gloverec record` builds its own. The command's flags:
ViewConfig (recorder/view/config.py), generated in recorder/view/cli.py.
"""

from __future__ import annotations

import threading
import time

import imageio.v2 as imageio
import mujoco

from recorder import GloverecError
from recorder.hand.profile import wearer_profile
from recorder.paths import video_file
from recorder.rig.rig import Rig
from recorder.view import wrist as wrist_view
from recorder.view.config import ViewConfig
from recorder.view.process import ViewSpec, default_view, open_view
from recorder.view.scene import Stage, frame_of, free_camera, layout_of
from recorder.wrist.config import SCRIPTED

VIDEO_SIZE = (480, 640)  # height, width
FIRST_POSE_S = 5.0  # a raw glove shows its first pose after host fusion's rest (about 1.5 s)
STATUS_S = 0.25


def run(cfg: ViewConfig) -> int:
    view = cfg.view
    if view is None and cfg.video is None:
        view, hint = default_view()
        if hint:
            raise GloverecError("no display: pass --view web (a page in a browser) or --video FILE.mp4")
    duration = cfg.duration
    if duration is None and cfg.video and cfg.glove.kind == "emulator":
        duration = 10.0
    profile = wearer_profile(cfg.wearer)  # a missing or impossible profile: one line, before anything opens
    wrist = cfg.wrist_config
    if wrist.follows_wearer:
        raise GloverecError(f"--wrist {wrist.kind} films `gloverec record`'s demonstrator: pass udp:PORT or "
                            "marker:CAMERA")  # fmt: skip
    overrides = cfg.task_options()
    rig = Rig(cfg, options=overrides, seed=None, profile=profile, say=print)
    try:
        if rig.u.config.base_position and wrist.kind == SCRIPTED:
            raise GloverecError(f"the {cfg.task} task needs a tracked wrist: pass --wrist udp:PORT or marker:CAMERA")
        _view(cfg, rig, view, duration, overrides)
    except KeyboardInterrupt:
        pass
    finally:
        rig.close()
    return 0


def _view(cfg: ViewConfig, rig: Rig, view, duration, overrides) -> None:
    requests: list[str] = []
    lock = threading.Lock()

    def request(name: str) -> None:
        with lock:
            requests.append(name)

    shown = None
    if view is not None and ViewSpec.parse(view).kind != "none":
        shown = open_view(view, cfg.task, cfg.robot, layout_of(rig.u), overrides, on_event=request, say=print,
                          hand_size=rig.profile.size())  # fmt: skip
        shown.wait_ready()
    try:
        glove = rig.wear().glove.open()
        rig.env.reset(seed=0)
        if glove.latest(wait_s=FIRST_POSE_S) is None:
            raise GloverecError(f"no hand pose from {cfg.glove} in {FIRST_POSE_S:.0f} s: is it a glove, sending?")
        session = _Session(rig, shown, lock, requests, cfg, overrides)
        video = video_file(cfg.video, time.strftime("view-%Y%m%d-%H%M%S.mp4")) if cfg.video else None
        steps = session.run(duration, video and str(video))
        if video:
            print(f"view: {steps} frames of {cfg.robot} ({cfg.task}) to {video}, {glove.frames} glove frames"
                  + (f", wrist tracked {session.tracked_share:.0%}" if rig.wrist is not None else ""))  # fmt: skip
    finally:
        if shown is not None:
            shown.close()


class _Session:
    """The loop: glove -> retarget -> env, at the task's control rate, shown and/or filmed."""

    def __init__(self, rig: Rig, view, lock, requests, cfg, options):
        self.rig, self.env, self.u, self.retarget, self.glove = rig, rig.env, rig.u, rig.retarget, rig.glove
        self.view, self.lock, self.requests, self.cfg, self.options = view, lock, requests, cfg, options
        self.seed, self._status, self._status_at = 0, {}, -1.0
        self.wrist = rig.wrist  # a WristTrack (None: the task scripts the base)
        self.source = rig.wrist_config.kind
        self.frames = self.untracked = 0  # the wrist's, since it was zeroed
        self._zero_wrist()

    @property
    def tracked_share(self) -> float:
        return 1.0 - self.untracked / max(self.frames, 1)

    def _zero_wrist(self) -> None:
        """The wearer's palm is in the nominal pose now (palm down, fingers forward) where the robot's palm is."""
        if self.wrist is None:
            return

        def wait() -> float:
            time.sleep(0.02)
            return time.monotonic()

        self.rig.zero_wrist(time.monotonic(), self.glove.latest().palm, wait)
        self.frames = self.untracked = 0

    def run(self, duration, video: str | None) -> int:
        rate = self.u.config.control_hz
        writer = stage = renderer = None
        if video:
            writer = imageio.get_writer(video, fps=rate, codec="libx264", quality=7, macro_block_size=8)
            stage = Stage(self.cfg.task, self.cfg.robot, self.options, hand_size=self.retarget.hand_size)
            renderer = mujoco.Renderer(stage.model, *VIDEO_SIZE)
            camera, opt = free_camera(stage), mujoco.MjvOption()
        steps, start = 0, time.monotonic()
        try:
            while duration is None or steps < duration * rate:
                if self._requests():
                    break
                frame = self._step()
                if self.view is not None:
                    self.view.publish(frame)
                    if not self.view.alive:
                        break  # the window was closed
                if writer is not None:
                    stage.apply(frame)
                    renderer.update_scene(stage.data, camera=camera, scene_option=opt)
                    stage.decorate(renderer.scene, opt)
                    writer.append_data(renderer.render())
                steps += 1
                delay = start + steps / rate - time.monotonic()  # follow the glove in real time
                if delay > 0:
                    time.sleep(delay)
        finally:
            if writer is not None:
                writer.close()
                renderer.close()
        return steps

    def _requests(self) -> bool:
        """Act on the view's keys; True to stop."""
        with self.lock:
            todo, self.requests[:] = list(self.requests), []
        for name in todo:
            if name == "stop":
                return True
            if name == "reset":
                self.glove.reset_pose()
                self._zero_wrist()
            elif name in ("next", "rerecord"):
                self._new_scene()
        return False

    def _new_scene(self) -> None:
        self.seed += 1
        self.env.reset(seed=self.seed)
        self.retarget.reset()
        self._zero_wrist()

    def _step(self):
        pose = self.glove.latest()
        wrist = None
        if self.wrist is not None:
            t = time.monotonic()
            self.wrist.update(t, pose.palm)
            wrist = self.wrist.pose(t)
            self.frames += 1
            self.untracked += not wrist.tracked
        palm = pose.palm if wrist is None else wrist.quat
        action, _ = self.retarget(pose.angles, palm, None if wrist is None else wrist.position)
        _, _, terminated, truncated, _ = self.env.step(action)
        if terminated or truncated:
            self._new_scene()
        now = time.monotonic()
        if now - self._status_at >= STATUS_S:
            self._status_at = now
            health = self.glove.health()
            self._status = {"phase": f"viewing {self.cfg.task} on {self.cfg.robot}", "seed": self.seed,
                            "glove": {"rate_hz": health.rate_hz, "up": health.up},
                            "keys": ["hand", "next", "reset", "stop"]}  # fmt: skip
        status = dict(self._status)
        if wrist is not None:
            status["wrist"] = wrist_view.status(wrist, self.u.base_bounds, self.untracked, self.frames, self.source)
        return frame_of(self.u, status, pose, wrist)
