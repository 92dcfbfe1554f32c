"""EmulatedCamera: what a webcam filming the glove's marker would see, rendered, so the whole camera path (image,
detection, pose, fusion, mapping) runs with no webcam. The palm's pose in the robot's world W (an emulated
wearer's, a demonstrator's) places the marker (mounted as ``marker_in_palm``) in a MuJoCo scene filmed by a
640×480 camera ``distance_m`` from ``centre``, across the table (+x of W) and ``elevation_deg`` above it, looking
back at the hand. ``capture(t, position, quat)`` renders that frame, tracks it (recorder/wrist/marker.py) and
returns the WristPose a camera source would queue, stamped ``latency_s`` later, with the truth in the camera's
frame kept beside it for the benchmark. ``record`` writes such frames to a lossless video instead: a file for
``marker:VIDEO``."""

from __future__ import annotations

import numpy as np

from recorder import quat
from recorder.wrist.format import WristPose
from recorder.wrist.fusion import MARKER_ON_BACK
from recorder.wrist.marker import MarkerScene, MarkerSpec, MarkerTracker


class EmulatedCamera:
    def __init__(
        self,
        marker: MarkerSpec | None = None,
        centre=(0.0, 0.0, 0.15),
        distance_m: float = 0.55,
        elevation_deg: float = 50.0,
        latency_s: float = 0.05,
        fps: float = 30.0,
        marker_in_palm=MARKER_ON_BACK,
    ):
        marker = marker or MarkerSpec()
        self.scene = MarkerScene(marker)
        self.camera = self.scene.camera
        self.tracker = MarkerTracker(marker, self.camera)
        self.latency_s, self.fps = latency_s, fps
        self.marker_in_palm = np.asarray(marker_in_palm, float)
        e = np.radians(elevation_deg)
        self._eye = np.asarray(centre, float) + distance_m * np.array([np.cos(e), 0.0, np.sin(e)])
        # W -> the scene's frame (its camera at the origin looking along +x, z up): turn W half a turn about z
        # (the camera looks back along -x), then tilt it down by the elevation about the scene's y
        self._scene_from_w = quat.mul(quat.from_axis_angle([0, 1.0, 0], -e), quat.from_axis_angle([0, 0, 1.0], np.pi))
        self.frames = 0

    def placement(self, position, palm_quat) -> tuple[np.ndarray, np.ndarray]:
        """The marker's pose in the scene for the palm at (position, palm_quat) in W."""
        p = quat.rotate(self._scene_from_w, np.asarray(position, float) - self._eye)
        q = quat.mul(self._scene_from_w, quat.mul(np.asarray(palm_quat, float), self.marker_in_palm))
        return p, q

    def capture(self, t: float, position, palm_quat) -> tuple[WristPose, tuple[np.ndarray, np.ndarray]]:
        """(the tracked pose, stamped ``t + latency_s``; untracked when the marker is not found, (true position,
        true quat) in the camera's frame) for the palm at (position, palm_quat), W, at capture time ``t``."""
        image, p_true, q_true = self.scene.render(*self.placement(position, palm_quat))
        return self.tracked(t, image), (p_true, q_true)

    def tracked(self, t: float, image: np.ndarray, tracker: MarkerTracker | None = None) -> WristPose:
        """The pose a camera source would queue for ``image``, captured at ``t`` (by ``tracker``, default its own)."""
        found = (tracker or self.tracker).track(image)
        self.frames += 1
        stamp = t + self.latency_s
        if found is None:
            return WristPose(self.frames, stamp, np.full(3, np.nan), quat.IDENTITY.copy(), False)
        return WristPose(self.frames, stamp, found.position, found.quat, True, found.alternative, found.errors_px)

    def record(self, path, positions, quats) -> tuple[np.ndarray, np.ndarray]:
        """A lossless video of the palm at each (position, quat) in W, at ``fps``; returns the truth."""
        placed = [self.placement(p, q) for p, q in zip(positions, quats)]
        return self.scene.record(path, [p for p, _ in placed], [q for _, q in placed], self.fps)

    def close(self) -> None:
        self.scene.close()
