"""The wrist from a printed marker seen by a camera: OpenCV's ArUco detector (corners refined by the AprilTag
method) and its planar pose solver (``solvePnPGeneric`` with IPPE_SQUARE, which returns both poses a square's
image allows), and a MuJoCo scene that renders what a webcam would see of the marker, with the truth, so that the
whole camera path runs, and is scored, without a webcam.

Frames: the camera's is OpenCV's (x right, y down, z forward); the marker's has its origin at the marker's centre,
x to the right of the printed image, y up it, z out of the paper.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from recorder import GloverecError, quat

DICTIONARIES = {"4X4_50": cv2.aruco.DICT_4X4_50, "5X5_100": cv2.aruco.DICT_5X5_100, "6X6_250": cv2.aruco.DICT_6X6_250}


@dataclass(frozen=True)
class MarkerSpec:
    """The printed marker: its ArUco dictionary, id and the black square's side (m)."""

    dictionary: str = "4X4_50"
    marker_id: int = 0
    size_m: float = 0.04

    def __post_init__(self):
        if self.dictionary not in DICTIONARIES:
            raise GloverecError(f"unknown marker dictionary {self.dictionary!r}; valid: {', '.join(DICTIONARIES)}")
        if not self.size_m > 0:
            raise GloverecError("the marker's size must be positive")

    def aruco(self):
        return cv2.aruco.getPredefinedDictionary(DICTIONARIES[self.dictionary])

    def image(self, pixels_per_cell: int = 40, border_cells: int = 1) -> np.ndarray:
        """The printable marker (uint8 grey) with a white quiet zone ``border_cells`` wide around it."""
        cells = self.aruco().markerSize + 2  # the data bits and the black frame
        side = cells * pixels_per_cell
        img = cv2.aruco.generateImageMarker(self.aruco(), self.marker_id, side)
        pad = border_cells * pixels_per_cell
        return cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)

    def corners(self) -> np.ndarray:
        """The black square's corners in the marker's frame (4, 3), in ArUco's order (top-left, clockwise)."""
        h = self.size_m / 2
        return np.array([[-h, h, 0], [h, h, 0], [h, -h, 0], [-h, -h, 0]], np.float64)


@dataclass(frozen=True)
class CameraModel:
    """A camera's intrinsics: image size, focal lengths and principal point (px), distortion (OpenCV's 5)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)

    @classmethod
    def from_fovy(cls, width: int, height: int, fovy_deg: float) -> CameraModel:
        """An ideal pinhole with MuJoCo's vertical field of view (what its offscreen renderer draws)."""
        f = 0.5 * height / np.tan(np.radians(fovy_deg) / 2)
        return cls(width, height, f, f, (width - 1) / 2, (height - 1) / 2)

    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1]], np.float64)

    def save(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.__dict__ | {"dist": list(self.dist)}, indent=2) + "\n")

    @classmethod
    def load(cls, path: str | Path) -> CameraModel:
        """A saved calibration (``save``, `gloverec calibrate --camera`), checked: a file that is not one, or one
        with a value missing, of the wrong type or out of range, is one line naming it."""
        try:
            data = json.loads(Path(path).read_bytes())
        except (OSError, ValueError) as exc:
            raise GloverecError(f"bad camera calibration {path}: {exc}") from None
        if not isinstance(data, dict):
            raise GloverecError(f"bad camera calibration {path}: expected a JSON object (gloverec calibrate --camera)")
        values = {}
        for name, kind in (("width", int), ("height", int), ("fx", float), ("fy", float), ("cx", float), ("cy", float)):
            v = data.get(name)
            if v is None:
                raise GloverecError(f"bad camera calibration {path}: {name} is missing")
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not np.isfinite(v)
                or (kind is int and v != int(v))
            ):
                raise GloverecError(f"bad camera calibration {path}: {name} must be a number, got {v!r}")
            if name in ("width", "height", "fx", "fy") and v <= 0:
                raise GloverecError(f"bad camera calibration {path}: {name} must be positive, got {v!r}")
            values[name] = kind(v)
        dist = data.get("dist", (0.0,) * 5)
        if (
            not isinstance(dist, list | tuple)
            or len(dist) != 5
            or not all(isinstance(d, (int, float)) and not isinstance(d, bool) and np.isfinite(d) for d in dist)
        ):
            raise GloverecError(f"bad camera calibration {path}: dist must be OpenCV's 5 distortion numbers")
        return cls(**values, dist=tuple(float(d) for d in dist))


@dataclass(frozen=True)
class MarkerPose:
    """The marker in the camera's frame: ``position`` (3, m), ``quat`` (wxyz, marker to camera), the other pose
    the square's image allows (``alternative``: (position, quat), or None), the reprojection error of each (px),
    and the detected corners (4, 2)."""

    position: np.ndarray
    quat: np.ndarray
    error_px: float
    alternative: tuple | None
    alternative_error_px: float | None
    corners: np.ndarray

    @property
    def errors_px(self) -> tuple:
        """The reprojection error of each pose (px): (the pose's,) or (the pose's, the alternative's)."""
        return (self.error_px,) if self.alternative is None else (self.error_px, self.alternative_error_px)


# How the detector refines the marker's corners. AprilTag's (fitting lines to the black square's edges, OpenCV's
# CORNER_REFINE_APRILTAG) is the default: ``cornerSubPix`` ("subpix") pulls each L-shaped corner 0.1-0.2 px into
# the square on a blurred edge, which reads as a marker 0.5 % (0.45 m) to 1.3 % (0.75 m) too far away, several
# millimetres, where the edge fit is unbiased (bench/wrist.py measures both).
REFINEMENTS = {
    "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
    "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
    "none": cv2.aruco.CORNER_REFINE_NONE,
}


class MarkerTracker:
    """Per-frame marker pose: ``track(image)`` -> MarkerPose, or None when the marker is not in the image."""

    def __init__(self, marker: MarkerSpec, camera: CameraModel, refinement: str = "apriltag"):
        self.marker, self.camera = marker, camera
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = REFINEMENTS[refinement]
        self.detector = cv2.aruco.ArucoDetector(marker.aruco(), params)
        self._k, self._dist = camera.matrix(), np.asarray(camera.dist, np.float64)

    def track(self, image: np.ndarray) -> MarkerPose | None:
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
        corners, ids, _ = self.detector.detectMarkers(grey)
        if ids is None or self.marker.marker_id not in ids.ravel():
            return None
        found = corners[int(np.flatnonzero(ids.ravel() == self.marker.marker_id)[0])].reshape(4, 2)
        n, rvecs, tvecs, errors = cv2.solvePnPGeneric(self.marker.corners(), found.astype(np.float64), self._k,
                                                      self._dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)  # fmt: skip
        if n == 0:
            return None
        poses = [(tvecs[i].ravel(), quat.from_rotvec(rvecs[i].ravel())) for i in range(n)]
        errs = [float(e) for e in np.asarray(errors).ravel()]
        return MarkerPose(poses[0][0], poses[0][1], errs[0], poses[1] if n > 1 else None,
                          errs[1] if n > 1 else None, found)  # fmt: skip


_CV_FROM_MJ = np.diag([1.0, -1.0, -1.0])  # MuJoCo's camera looks down its -z with y up; OpenCV's down +z, y down


class PlateScene:
    """What a webcam sees of a printed plate: a camera at the world origin looking along +x (a desk webcam), and
    ``image`` (uint8 grey) printed ``plate_m`` (width, height, m) on a mocap body; ``render(position, quat)`` places
    the plate's centre (world frame) and returns the RGB image and the plate's true pose in the camera's frame."""

    def __init__(self, image: np.ndarray, plate_m: tuple[float, float], width: int = 640, height: int = 480,
                 fovy_deg: float = 45.0):  # fmt: skip
        import mujoco  # the rendered marker scene only: tests and benchmarks, not a tracker

        self.camera = CameraModel.from_fovy(width, height, fovy_deg)
        spec = mujoco.MjSpec()
        spec.visual.global_.offwidth, spec.visual.global_.offheight = width, height
        spec.stat.extent = 1.0  # clipping planes 1 cm to 50 m (the model alone is a 5 cm plate)
        with tempfile.TemporaryDirectory() as tmp:
            png = Path(tmp) / "marker.png"
            cv2.imwrite(str(png), image)
            spec.add_texture(name="marker", type=mujoco.mjtTexture.mjTEXTURE_2D, file=str(png))
            mat = spec.add_material(name="marker", texrepeat=[1, 1], texuniform=False, specular=0.0, shininess=0.0)
            mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "marker"
            spec.worldbody.add_light(pos=[0, 0, 2], dir=[0, 0, -1], diffuse=[0.5, 0.5, 0.5], castshadow=False)
            spec.worldbody.add_light(pos=[0, 0, 0], dir=[1, 0, 0], diffuse=[0.5, 0.5, 0.5], castshadow=False)
            spec.visual.headlight.ambient = [0.4, 0.4, 0.4]
            body = spec.worldbody.add_body(name="marker", mocap=True)
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[plate_m[0] / 2, plate_m[1] / 2, 0.001],
                          material="marker", contype=0, conaffinity=0)  # fmt: skip
            # the camera at the origin looking along +x, up +z: its -z axis is world +x
            spec.worldbody.add_camera(name="webcam", pos=[0, 0, 0], xyaxes=[0, -1, 0, 0, 0, 1], fovy=fovy_deg)
            self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.renderer = mujoco.Renderer(self.model, height, width)
        self._mujoco = mujoco

    def render(self, position, quat_wxyz) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(RGB image (H, W, 3) uint8, true position (3) and quat (wxyz) of the marker in the camera's frame)."""
        mj = self._mujoco
        self.data.mocap_pos[0], self.data.mocap_quat[0] = position, quat_wxyz
        mj.mj_forward(self.model, self.data)
        self.renderer.update_scene(self.data, camera="webcam")
        image = self.renderer.render()
        cam = self.model.camera("webcam").id
        r_cam = self.data.cam_xmat[cam].reshape(3, 3)
        r_cv = r_cam @ _CV_FROM_MJ  # the OpenCV camera frame's axes in the world
        p = r_cv.T @ (np.asarray(position, float) - self.data.cam_xpos[cam])
        r_marker = r_cv.T @ quat.to_matrix(quat_wxyz)
        return image, p, _matrix_to_quat(r_marker)

    def record(self, path: str | Path, positions, quats, fps: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
        """A lossless video (FFV1; a .mkv or .avi) of the marker at each (position, quat), world frame, at ``fps``:
        what a webcam would have filmed. Returns the truth, (n, 3) positions and (n, 4) quats in the camera's frame."""
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), fps,
                                 (self.camera.width, self.camera.height))  # fmt: skip
        if not writer.isOpened():
            raise GloverecError(f"cannot write the video {path} (FFV1: use .mkv or .avi)")
        truth_p, truth_q = [], []
        try:
            for position, q in zip(positions, quats):
                image, p, qc = self.render(position, q)
                writer.write(image[..., ::-1])  # OpenCV writes BGR
                truth_p.append(p)
                truth_q.append(qc)
        finally:
            writer.release()
        return np.array(truth_p), np.array(truth_q)

    def close(self) -> None:
        self.renderer.close()


class MarkerScene(PlateScene):
    """The printed marker (with its white quiet zone) seen by the webcam; its frame is the marker's."""

    def __init__(self, marker: MarkerSpec = MarkerSpec(), width: int = 640, height: int = 480, fovy_deg: float = 45.0):
        cells = marker.aruco().markerSize + 2
        plate = marker.size_m * (cells + 2) / cells  # the square plus its quiet zone
        super().__init__(marker.image(), (plate, plate), width, height, fovy_deg)
        self.marker = marker


def _matrix_to_quat(r: np.ndarray) -> np.ndarray:
    rvec, _ = cv2.Rodrigues(np.asarray(r, np.float64))
    return quat.from_rotvec(rvec.ravel())
