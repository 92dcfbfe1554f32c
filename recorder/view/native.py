"""The native view: MuJoCo's own viewer (``mujoco.viewer.launch_passive``) on the view process's copy of the
scene, with the ghost and the human hand in its user scene and the status text in its overlay. Its keys F8..F12
(recorder/view/overlay.py) go back to the command as requests; Esc, the arrows, the letters and F1..F7 stay the
viewer's own."""

from __future__ import annotations

import os
import time

import mujoco
import mujoco.viewer

from recorder.view import overlay
from recorder.view.pace import Pace
from recorder.view.scene import Stage, free_camera

FPS = 30.0


def run(stage: Stage, shared, events, closing, ready=None, meter=None) -> None:
    """Show frames until ``closing()`` or the window is closed; ``events(name)`` sends a request back."""

    def key(code: int) -> None:
        name = overlay.KEYS.get(code)
        if name == "hand":
            stage.show_hand = not stage.show_hand
        elif name is not None:
            events(name)

    viewer = mujoco.viewer.launch_passive(
        stage.model, stage.data, key_callback=key, show_left_ui=False, show_right_ui=False
    )
    if ready is not None:
        ready("live view: MuJoCo's viewer")
    # the viewer sets its default camera as it starts up: ours is set for the first second of frames
    pace, period, framing, cam = Pace(FPS), 1.0 / FPS, int(FPS), free_camera(stage)
    while viewer.is_running() and not closing():
        t = time.monotonic()
        frame = shared.read()
        if frame is not None:
            with viewer.lock():
                if framing > 0:
                    framing -= 1
                    viewer.cam.lookat[:] = cam.lookat
                    viewer.cam.distance, viewer.cam.azimuth = cam.distance, cam.azimuth
                    viewer.cam.elevation = cam.elevation
                stage.apply(frame)
                viewer.user_scn.ngeom = 0
                stage.decorate(viewer.user_scn, viewer.opt)
            left, right = overlay.columns(frame.status)
            viewer.set_texts([(None, mujoco.mjtGridPos.mjGRID_TOPLEFT, left, right)])  # locks by itself
            viewer.sync()
            period = pace.period(frame.status)
            if meter is not None:
                meter.tick()
        time.sleep(max(0.0, period - (time.monotonic() - t)))
    # Closing MuJoCo's viewer window from Python makes its render thread swap a destroyed drawable under some X
    # servers (GLXBadDrawable, printed or fatal). This process has nothing left to save: it ends here, and the
    # window goes with it.
    if meter is not None:
        meter.report()
    os._exit(0)
