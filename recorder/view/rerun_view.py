"""The rerun view, LeRobot's convention (`lerobot-record --display_data`; rerun-sdk comes with lerobot): per
actuator the joint target against the joint state, the scene rendered offscreen (with the ghost and the human
hand, and a tracked wrist with the workspace's bounds), the glove's health, a tracked wrist's tracking and the
status text, on rerun's timeline. Where the data goes:

    rerun:spawn             a local rerun viewer (needs a display)
    rerun:serve[:PORT]      rerun's web viewer served on 127.0.0.1 (its gRPC stream on PORT, default 9876)
    rerun:connect[:URL]     a rerun viewer that is already running (default rerun+http://127.0.0.1:9876/proxy)
    rerun:save[:FILE.rrd]   a recording file (default: beside the dataset, <root>/logs/view-<time>.rrd)
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import rerun as rr

from recorder.view import overlay
from recorder.view.pace import Pace
from recorder.view.scene import Stage, free_camera

FPS = 30.0
IMAGE_FPS = 5.0  # software rendering is costly: the scene image is logged at a lower rate
SIZE = (240, 320)
SCALARS = {"glove": ("rate_hz", "latency_ms_p99", "late", "dropped"), "wrist": ("tracked_share", "age_s")}


def open_sink(mode: str, target: str | None) -> str:
    """Start rerun's recording stream toward ``mode``; returns where it goes (for the operator)."""
    rr.init("gloverec", spawn=False)
    if mode == "spawn":
        rr.spawn()
        return "a local rerun viewer"
    if mode == "serve":
        port = int(target or 9876)
        url = rr.serve_grpc(grpc_port=port)
        rr.serve_web_viewer(open_browser=False, connect_to=url)
        return f"rerun's web viewer at http://127.0.0.1:9090 (stream {url})"
    if mode == "connect":
        url = target or "rerun+http://127.0.0.1:9876/proxy"
        rr.connect_grpc(url)
        return f"the rerun viewer at {url}"
    rr.save(target)
    return f"{target}"


def run(
    stage: Stage, shared, events, closing, mode: str = "save", target: str | None = None, ready=None, meter=None
) -> None:
    where = open_sink(mode, target)
    if ready is not None:
        ready(where)
    actuators = [stage.model.actuator(i).name for i in range(stage.model.nu)]
    renderer = mujoco.Renderer(stage.model, *SIZE)
    camera, opt = free_camera(stage), mujoco.MjvOption()
    start, k, pace, period = time.monotonic(), 0, Pace(FPS), 1.0 / FPS
    last_image = float("-inf")

    def log(frame, t: float) -> None:
        nonlocal k, last_image
        stage.apply(frame)
        rr.set_time("frame", sequence=k)
        rr.set_time("time", duration=t - start)
        k += 1
        state = stage.data.actuator_length
        for i, name in enumerate(actuators):
            rr.log(f"joints/{name}/target", rr.Scalars(float(frame.ctrl[i])))
            rr.log(f"joints/{name}/state", rr.Scalars(float(state[i])))
        for part, keys in SCALARS.items():  # the glove's health, a tracked wrist's tracking
            values = frame.status.get(part) or {}
            for key in keys:
                if values.get(key) is not None:
                    rr.log(f"{part}/{key}", rr.Scalars(float(values[key])))
        if frame.hand:
            rr.log("glove/joint_angles_deg", rr.Scalars(np.degrees(frame.angles)))
        rows = overlay.lines(frame.status, overlay.TERMINAL_KEY_NAMES)  # rerun has no keys: the terminal's
        rr.log("status", rr.TextDocument("\n".join(f"**{a}** {b}  " for a, b in rows), media_type="text/markdown"))
        if t - last_image >= 1.0 / IMAGE_FPS:
            last_image = t
            renderer.update_scene(stage.data, camera=camera, scene_option=opt)
            stage.decorate(renderer.scene, opt)
            rr.log("scene", rr.Image(renderer.render()).compress(jpeg_quality=80))
        if meter is not None:
            meter.tick()

    try:
        while not closing():
            t = time.monotonic()
            frame = shared.read()
            if frame is not None:
                log(frame, t)
                period = pace.period(frame.status)
            time.sleep(max(0.0, period - (time.monotonic() - t)))
        # the command's newest frame, if the loop has not logged it: the recording ends with the session's last
        # state, however little CPU the view had (a session faster than real time can end before its first turn)
        frame = shared.read()
        if frame is not None:
            last_image = float("-inf")
            log(frame, time.monotonic())
    finally:
        renderer.close()
        rr.disconnect()
