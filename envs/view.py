"""``gloverec view``: a robot hand in MuJoCo follows the glove live.

    gloverec view --glove emulator|serial:PORT|udp:PORT|mcap:FILE --robot NAME [--task pose|grasp]
                  [--mode joint|ik] [--video FILE.mp4] [--duration S]

Pose frames (16 parent-relative quaternions) become the hand model's joint angles
(kinematics.joint_angles_from_relative; palm orientation = quats[0]), are retargeted and step the task at its
control rate. With a display and no --video, MuJoCo's interactive viewer shows it; otherwise frames go to an
mp4 (headless: MUJOCO_GL=egl). ``--glove emulator`` runs the glove emulator on a pseudo-terminal in this
process and reads it through the real serial path.

Wire into the CLI with ``view.add_parser(subparsers)``; the parser's ``func`` is ``run``.
"""

from __future__ import annotations

import os
import threading
import time

import numpy as np

from recorder import GloverecError

VIDEO_SIZE = (480, 640)  # height, width


def add_parser(subparsers):
    from envs.robots import robot_names
    from envs.tasks import TASKS

    v = subparsers.add_parser("view", help="a MuJoCo robot hand follows the glove live")
    v.add_argument("--glove", required=True, help="emulator, serial:PORT (or a path), udp:PORT or mcap:FILE")
    v.add_argument("--robot", default="glovehand", choices=robot_names())
    v.add_argument("--task", default="pose", choices=tuple(TASKS))
    v.add_argument("--mode", default="joint", choices=("joint", "ik"), help="retargeting mode")
    v.add_argument("--video", metavar="FILE.mp4", help="render to this video instead of a window")
    v.add_argument("--duration", type=float, help="seconds (default: until Ctrl-C; 10 s for a video from the emulator)")
    v.add_argument("--camera", default="front", help="camera for the video (front, top, side)")
    v.set_defaults(func=run)
    return v


class _Glove:
    """The latest pose frame of a glove source, as (joint angles, palm quaternion); the emulator on a pty."""

    def __init__(self, spec: str):
        from recorder.link.sources import open_source

        self.emulator = None
        if spec == "emulator":
            from recorder.emulator.emulator import Emulator

            self.emulator = Emulator(rate_hz=200.0, mode="pose", motion="gestures")
            port = self.emulator.plug()
            threading.Thread(target=self.emulator.run, name="gloverec-emulator", daemon=True).start()
            spec = f"serial:{port}"
        self.source = open_source(spec)
        self.frames = 0
        self._last = None

    def latest(self, wait_s: float = 0.0):
        from recorder.hand.kinematics import joint_angles_from_relative

        frames = self.source.drain()
        if not frames and self._last is None:
            f = self.source.read(timeout=wait_s)
            frames = [f] if f is not None else []
        for f in frames:
            if getattr(f, "quats", None) is not None:
                self._last = f
                self.frames += 1
        if self._last is None:
            return None
        q = np.asarray(self._last.quats, float)
        return joint_angles_from_relative(q), q[0]

    def close(self):
        self.source.close()
        if self.emulator is not None:
            self.emulator.close()


def run(args) -> int:
    from envs.tasks import make_task
    from recorder.retarget import Retargeter

    headless = args.video is not None or not os.environ.get("DISPLAY")
    if headless and args.video is None:
        raise GloverecError("no display: pass --video FILE.mp4 to render the view to a video")
    duration = args.duration
    if duration is None and args.video and args.glove == "emulator":
        duration = 10.0
    overrides = {"episode_s": 1e9, "terminate_on_success": False} if args.task == "pose" else {}
    env = make_task(args.task, args.robot, **overrides)
    u = env.unwrapped
    retarget = Retargeter(u.robot, args.mode, base_rotation=u.config.base_rotation)
    glove = _Glove(args.glove)
    try:
        env.reset(seed=0)
        if glove.latest(wait_s=5.0) is None:
            raise GloverecError(f"no pose frames from {args.glove} in 5 s: is it a glove in pose mode?")
        if headless:
            steps = _to_video(env, retarget, glove, args.video, duration, args.camera)
            print(f"view: {steps} frames of {args.robot} ({args.task}) to {args.video}, {glove.frames} glove frames")
        else:
            _interactive(env, retarget, glove, duration)
    except KeyboardInterrupt:
        pass
    finally:
        glove.close()
        env.close()
    return 0


def _step(env, retarget, glove) -> dict:
    angles, palm = glove.latest()
    action, info = retarget(angles, palm)
    _, _, terminated, truncated, _ = env.step(action)
    if terminated or truncated:
        env.reset()
        retarget.reset()
    return info


def _to_video(env, retarget, glove, path: str, duration, camera: str) -> int:
    import imageio.v2 as imageio
    import mujoco

    u = env.unwrapped
    rate = u.config.control_hz
    h, w = VIDEO_SIZE
    renderer = mujoco.Renderer(u.model, h, w)
    steps = 0
    start = time.monotonic()
    with imageio.get_writer(path, fps=rate, codec="libx264", quality=7, macro_block_size=8) as out:
        try:
            while duration is None or steps < duration * rate:
                _step(env, retarget, glove)
                renderer.update_scene(u.data, camera=camera)
                out.append_data(renderer.render())
                steps += 1
                delay = start + steps / rate - time.monotonic()  # follow the glove in real time
                if delay > 0:
                    time.sleep(delay)
        finally:
            renderer.close()
    return steps


def _interactive(env, retarget, glove, duration) -> None:
    import mujoco.viewer

    u = env.unwrapped
    rate = u.config.control_hz
    with mujoco.viewer.launch_passive(u.model, u.data) as viewer:
        start = time.monotonic()
        steps = 0
        while viewer.is_running() and (duration is None or steps < duration * rate):
            _step(env, retarget, glove)
            viewer.sync()
            steps += 1
            delay = start + steps / rate - time.monotonic()
            if delay > 0:
                time.sleep(delay)
