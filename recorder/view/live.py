"""``gloverec view``: a robot hand in MuJoCo follows the glove live, shown by a live view (recorder/view/process.py:
native, web or rerun) or rendered to a video.

    gloverec view --glove emulator|serial:PORT|udp:PORT|mcap:FILE --robot NAME [--task pose|grasp]
                  [--mode joint|ik|pinch] [--wearer NAME] [--view native|web[:PORT]|rerun[:MODE]] [--video FILE.mp4]
                  [--duration S]

The glove's newest HandPose (any glove: pose, compact, or raw frames fused on the host) is retargeted and steps
the task at its control rate. The view shows what `gloverec record` shows: the scene, the target gesture as a
ghost, the human hand, the glove's health; its "next" key starts a new scene, "zero" re-takes the reference pose,
"stop" ends. A video (MUJOCO_GL=egl, headless) has the ghost and the human hand too. ``--wearer NAME``: that
wearer's hand profile (recorder/hand/profile.py), which retargeting and the drawn human hand use.
``--glove emulator`` runs the glove emulator on a pseudo-terminal in this process and reads it through the real
serial path.

The command's flags: recorder/view/cli.py.
"""

from __future__ import annotations

import threading
import time

import imageio.v2 as imageio
import mujoco

from envs.tasks import get_task, make_task
from recorder import GloverecError
from recorder.glove.config import GloveConfig
from recorder.glove.glove import open_glove
from recorder.hand.profile import wearer_profile
from recorder.retarget import Retargeter
from recorder.view.process import ViewSpec, default_view, open_view
from recorder.view.scene import Stage, frame_of, free_camera, layout_of

VIDEO_SIZE = (480, 640)  # height, width
FIRST_POSE_S = 5.0  # a raw glove shows its first pose after host fusion's rest (about 1.5 s)
STATUS_S = 0.25


def run(args) -> int:
    view = args.view
    if view is None and args.video is None:
        view, hint = default_view()
        if hint:
            raise GloverecError("no display: pass --view web (a page in a browser) or --video FILE.mp4")
    duration = args.duration
    if duration is None and args.video and args.glove == "emulator":
        duration = 10.0
    size = wearer_profile(args.wearer).size()  # a missing or impossible profile: one line, before anything opens
    overrides = get_task(args.task).live  # the task's endless live scene
    env = make_task(args.task, args.robot, **overrides)
    u = env.unwrapped
    retarget = Retargeter(u.robot, args.mode, base_rotation=u.config.base_rotation, hand_size=size)
    requests: list[str] = []
    lock = threading.Lock()

    def request(name: str) -> None:
        with lock:
            requests.append(name)

    shown = None
    if view is not None and ViewSpec.parse(view).kind != "none":
        shown = open_view(view, args.task, args.robot, layout_of(u), overrides, on_event=request, say=print,
                          hand_size=size)  # fmt: skip
        shown.wait_ready()
    glove = open_glove(GloveConfig.parse(args.glove), motion="gestures")
    try:
        env.reset(seed=0)
        if glove.latest(wait_s=FIRST_POSE_S) is None:
            raise GloverecError(f"no hand pose from {args.glove} in {FIRST_POSE_S:.0f} s: is it a glove, sending?")
        session = _Session(env, retarget, glove, shown, lock, requests, args)
        steps = session.run(duration, args.video)
        if args.video:
            print(f"view: {steps} frames of {args.robot} ({args.task}) to {args.video}, {glove.frames} glove frames")
    except KeyboardInterrupt:
        pass
    finally:
        glove.close()
        if shown is not None:
            shown.close()
        env.close()
    return 0


class _Session:
    """The loop: glove -> retarget -> env, at the task's control rate, shown and/or filmed."""

    def __init__(self, env, retarget, glove, view, lock, requests, args):
        self.env, self.u, self.retarget, self.glove, self.view = env, env.unwrapped, retarget, glove, view
        self.lock, self.requests, self.args = lock, requests, args
        self.seed, self._status, self._status_at = 0, {}, -1.0

    def run(self, duration, video: str | None) -> int:
        rate = self.u.config.control_hz
        writer = stage = renderer = None
        if video:
            writer = imageio.get_writer(video, fps=rate, codec="libx264", quality=7, macro_block_size=8)
            stage = Stage(self.args.task, self.args.robot, get_task(self.args.task).live,
                          hand_size=self.retarget.hand_size)  # fmt: skip
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
            elif name in ("next", "rerecord"):
                self._new_scene()
        return False

    def _new_scene(self) -> None:
        self.seed += 1
        self.env.reset(seed=self.seed)
        self.retarget.reset()

    def _step(self):
        pose = self.glove.latest()
        action, _ = self.retarget(pose.angles, pose.palm)
        _, _, terminated, truncated, _ = self.env.step(action)
        if terminated or truncated:
            self._new_scene()
        now = time.monotonic()
        if now - self._status_at >= STATUS_S:
            self._status_at = now
            health = self.glove.health()
            self._status = {"phase": f"viewing {self.args.task} on {self.args.robot}", "seed": self.seed,
                            "glove": {"rate_hz": health.rate_hz, "up": health.up},
                            "keys": ["hand", "next", "reset", "stop"]}  # fmt: skip
        return frame_of(self.u, dict(self._status), pose)
