"""``gloverec view``: a robot hand in MuJoCo follows the glove live.

    gloverec view --glove emulator|serial:PORT|udp:PORT|mcap:FILE --robot NAME [--task pose|grasp]
                  [--mode joint|ik] [--video FILE.mp4] [--duration S]

The glove's newest HandPose (any glove: pose, compact, or raw frames fused on the host) is retargeted and steps
the task at its control rate. With a display and no --video, MuJoCo's interactive viewer shows it; otherwise
frames go to an mp4 (headless: MUJOCO_GL=egl). ``--glove emulator`` runs the glove emulator on a
pseudo-terminal in this process and reads it through the real serial path.

The command's flags: recorder/view/cli.py.
"""

from __future__ import annotations

import os
import time

import imageio.v2 as imageio
import mujoco

from envs.tasks import make_task
from recorder import GloverecError
from recorder.glove.config import GloveConfig
from recorder.glove.glove import open_glove
from recorder.retarget import Retargeter

VIDEO_SIZE = (480, 640)  # height, width
FIRST_POSE_S = 5.0  # a raw glove shows its first pose after host fusion's rest (about 1.5 s)


def run(args) -> int:
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
    glove = open_glove(GloveConfig.parse(args.glove), motion="gestures")
    try:
        env.reset(seed=0)
        if glove.latest(wait_s=FIRST_POSE_S) is None:
            raise GloverecError(f"no hand pose from {args.glove} in {FIRST_POSE_S:.0f} s: is it a glove, sending?")
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
    pose = glove.latest()
    action, info = retarget(pose.angles, pose.palm)
    _, _, terminated, truncated, _ = env.step(action)
    if terminated or truncated:
        env.reset()
        retarget.reset()
    return info


def _to_video(env, retarget, glove, path: str, duration, camera: str) -> int:
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
    import mujoco.viewer  # only with a display: it loads GLFW

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
