"""The scene a live view draws: the task as simulated (robot hand, object, table) from a ViewFrame, plus what
only the view shows: HandPose's target gesture as a translucent ghost of the robot, and the human hand as the
glove measures it (the 16-segment hand model through forward kinematics), beside the robot, and with a tracked
wrist (recorder/view/wrist.py) where it puts the palm, coloured by its tracking, and the workspace's bounds, the
sides the palm target is pressed against highlighted. The extras are added to an MjvScene after MuJoCo fills it,
so they are never part of the physics, the cameras or the dataset."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

import envs
from recorder.hand.kinematics import JOINTS, HandSize, forward
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS
from recorder.view.state import Layout, ViewFrame
from recorder.wrist.config import seen

GHOST_RGBA = np.array([0.35, 0.8, 1.0, 0.3], np.float32)
SKIN_RGBA = np.array([0.93, 0.72, 0.58, 1.0], np.float32)
INVALID_RGBA = np.array([0.9, 0.2, 0.2, 1.0], np.float32)  # a joint the glove did not measure in this sample
HAND_OFFSET = np.array([0.0, 0.22, 0.0])  # where the human hand's wrist is drawn, from the workspace centre (m)
BONE_RADIUS = 0.006
LABEL_LIFT = np.array([0.0, 0.0, 0.09])  # a hand's label floats this far above its wrist (m)
# the tracked wrist: a ball at the palm's origin, the palm's axes, and the workspace's bounds
WRIST_RGBA = {
    "tracked": np.array([0.25, 0.9, 0.35, 1.0], np.float32),
    "catching up": np.array([1.0, 0.78, 0.1, 1.0], np.float32),
    "lost": np.array([1.0, 0.15, 0.15, 1.0], np.float32),
}
BOUNDS_RGBA = np.array([0.85, 0.9, 1.0, 0.45], np.float32)
EDGE_RGBA = np.array([0.95, 0.3, 0.9, 0.9], np.float32)  # a side the palm target is pressed against
FACE_RGBA = np.array([0.95, 0.3, 0.9, 0.4], np.float32)
MARKER_M, MARKER_LIFT_M, ARROW_M, LINE_RADIUS = 0.04, 0.05, 0.05, 0.0015
FREE_HAND_MARGIN_M = 0.1  # with a free wrist, the human hand's wrist is drawn this far beyond the bounds' y+ side
FIT = 0.9  # of the distance at which the workspace's bounding sphere fills the view: the box just fits
PATCH_M = 0.05  # half the side of the patch drawn where the palm target presses against the workspace's side


class Stage:
    """The view's own copy of the task: the same model as the recording's environment (its task, robot and
    options, without cameras), its data set from each ViewFrame. ``hide_robot``: only the human hand (calibration).
    ``hand_size``: the wearer's hand (their profile), which the human hand is drawn at."""

    def __init__(
        self,
        task: str,
        robot: str,
        options: dict | None = None,
        hide_robot: bool = False,
        hand_size: HandSize = HandSize(),
    ):
        opts = {k: v for k, v in (options or {}).items() if k not in ("cameras", "image_size")}
        self.env = envs.make(task, robot, **opts).unwrapped
        self.env.reset(seed=0)
        self.model, self.data = self.env.model, self.env.data
        self.ghost = mujoco.MjData(self.model)
        self.robot_geoms = set(self.env._robot_geoms.tolist())
        self.robot_shown = not hide_robot
        if hide_robot:
            self.model.geom_rgba[list(self.robot_geoms), 3] = 0.0
        self.workspace = np.array(self.env.workspace, float)
        self.hand_at = self.workspace + HAND_OFFSET  # the human hand's wrist
        self.hand_label_at = self.hand_at + LABEL_LIFT
        if self.env.config.base_position:  # a free wrist: the robot goes anywhere in the bounds; the hand, beside them
            self.hand_at[1] = self.env.base_bounds[1][1] + FREE_HAND_MARGIN_M
            self.hand_label_at = self.hand_at + LABEL_LIFT - [0.0, 0.12, 0.0]  # its text runs right, out of the view
        self.size = hand_size
        self.show_ghost = hasattr(self.env, "goal_qpos")
        self.show_hand = True
        self.seed = 0
        self.frame: ViewFrame | None = None

    @property
    def layout(self) -> Layout:
        return layout_of(self.env)

    def apply(self, frame: ViewFrame) -> None:
        """The scene as the frame says (a new scene seed first resets the copy: the object drawn, its size)."""
        seed = frame.status.get("seed")
        if seed is not None and seed != self.seed:
            self.env.reset(seed=int(seed))
            self.seed = seed
        self.frame = frame
        d = self.data
        d.qpos[:] = frame.qpos
        d.mocap_pos[:] = frame.mocap_pos
        d.mocap_quat[:] = frame.mocap_quat
        d.ctrl[:] = frame.ctrl
        if frame.task.size:
            self.env.show_state(frame.task)  # what the scene shows of the task's state now (HandKeys' lit key)
        mujoco.mj_forward(self.model, d)

    def decorate(self, scn: mujoco.MjvScene, opt: mujoco.MjvOption) -> None:
        """Add the ghost, the human hand and the tracked wrist to ``scn`` (already holding the scene)."""
        if self.frame is None:
            return
        if self.show_ghost and self.frame.task.size:
            self._ghost(scn, opt)
        if self.robot_shown:
            _label(scn, self.data.mocap_pos[self.env._mocap] + LABEL_LIFT, "robot")
        if self.show_hand and self.frame.hand:
            self._human_hand(scn)
            _label(scn, self.hand_label_at, "your hand (glove)")
        wrist = self.frame.status.get("wrist")
        if wrist:
            self._wrist(scn, wrist)

    def _wrist(self, scn, wrist: dict) -> None:
        """The workspace's box; where the palm target is pressed against it (the side's outline and a patch where it
        presses); and the tracked palm: a plate like the marker on the back of the hand, above the palm's origin (so
        that the robot's hand does not hide it), coloured by the tracking, an arrow to the fingers."""
        lo, hi = self.env.base_bounds
        edge = wrist.get("edge") or []
        _box(scn, lo, hi, BOUNDS_RGBA, LINE_RADIUS)
        pos, q = self.frame.wrist[:3], self.frame.wrist[3:]
        held = np.clip(pos, lo, hi)  # where the action's base position puts the palm
        for side in edge:
            i, at = "xyz".index(side[0]), (hi if side[1] == "+" else lo)
            face_lo, face_hi = lo.copy(), hi.copy()
            face_lo[i] = face_hi[i] = at[i]
            _box(scn, face_lo, face_hi, EDGE_RGBA, 2 * LINE_RADIUS)
            patch_lo, patch_hi = np.maximum(held - PATCH_M, face_lo), np.minimum(held + PATCH_M, face_hi)
            half = (patch_hi - patch_lo) / 2
            half[i] = 0.001
            _geom(scn, mujoco.mjtGeom.mjGEOM_BOX, half, (patch_lo + patch_hi) / 2, np.eye(3), FACE_RGBA)
        if wrist.get("state") not in WRIST_RGBA:  # waiting: no pose yet
            return
        rgba = WRIST_RGBA[wrist["state"]]
        axes = np.zeros(9)
        mujoco.mju_quat2Mat(axes, q)
        axes = axes.reshape(3, 3)
        plate = pos + MARKER_LIFT_M * axes[:, 2]  # the palm frame's z points out of the back of the hand
        _geom(scn, mujoco.mjtGeom.mjGEOM_BOX, [MARKER_M / 2, MARKER_M / 2, 0.002], plate, axes, rgba)
        _capsule(scn, pos, plate, LINE_RADIUS, rgba)
        _geom(scn, mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, 2 * LINE_RADIUS), pos, np.eye(3), rgba)
        tip = plate + ARROW_M * axes[:, 0]
        arrow = _geom(scn, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.eye(3), rgba)
        if arrow is not None:
            mujoco.mjv_connector(arrow, mujoco.mjtGeom.mjGEOM_ARROW, 2 * LINE_RADIUS, plate, tip)
        if edge:  # from where the wrist is to where the robot's palm is held
            _capsule(scn, pos, held, LINE_RADIUS, EDGE_RGBA)
        if wrist["state"] == "lost":  # above the plate, and so above the robot's label when the palm is held there
            _label(scn, plate + LABEL_LIFT, f"{seen(wrist.get('source'))} lost: hold still")

    def _ghost(self, scn, opt) -> None:
        g = self.ghost
        g.qpos[:] = self.env.goal_qpos(self.data.qpos, self.frame.task)
        g.mocap_pos[:], g.mocap_quat[:] = self.data.mocap_pos, self.data.mocap_quat
        mujoco.mj_kinematics(self.model, g)
        first = scn.ngeom
        mujoco.mjv_addGeoms(self.model, g, opt, mujoco.MjvPerturb(), mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
        for i in range(first, scn.ngeom):  # the robot's geoms, recoloured; the object's, hidden
            geom = scn.geoms[i]
            robot = geom.objtype == mujoco.mjtObj.mjOBJ_GEOM and geom.objid in self.robot_geoms
            geom.rgba[:] = GHOST_RGBA if robot else 0.0
            geom.segid = -1

    def _human_hand(self, scn) -> None:
        f = self.frame
        _, pos, tips = forward(f.angles, f.palm, self.size)
        wrist = self.hand_at
        pos, tips = pos + wrist, tips + wrist
        bad = ~f.valid
        bones = []  # (from, to, measured)
        for k, finger in enumerate(FINGERS):
            chain = FINGER_SEGMENTS[finger]
            bones.append((wrist, pos[chain[0]], True))  # the palm: wrist to each chain's base
            points = [pos[s] for s in chain] + [tips[k]]
            joints = _finger_joints(finger)
            for j in range(3):
                bones.append((points[j], points[j + 1], not bad[joints[j]].any()))
        bones.append((pos[FINGER_SEGMENTS["index"][0]], pos[FINGER_SEGMENTS["pinky"][0]], True))  # knuckles
        for a, b, ok in bones:
            _capsule(scn, a, b, BONE_RADIUS, SKIN_RGBA if ok else INVALID_RGBA)


def _geom(scn: mujoco.MjvScene, kind, size, pos, mat, rgba):
    """A geom added to ``scn`` (None when it is full), outside MuJoCo's selection (segid -1)."""
    if scn.ngeom >= scn.maxgeom:
        return None
    geom = scn.geoms[scn.ngeom]
    mujoco.mjv_initGeom(geom, kind, np.asarray(size, float), np.asarray(pos, float), np.asarray(mat, float).reshape(-1),
                        np.asarray(rgba, np.float32))  # fmt: skip
    geom.segid = -1
    scn.ngeom += 1
    return geom


def _capsule(scn: mujoco.MjvScene, a, b, radius: float, rgba) -> None:
    geom = _geom(scn, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), np.eye(3), rgba)
    if geom is not None:
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, radius, np.asarray(a, float), np.asarray(b, float))


def _box(scn: mujoco.MjvScene, lo, hi, rgba, radius: float) -> None:
    """The outline of the box from corner ``lo`` to ``hi`` (a face when they share a coordinate)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    for corner in sorted(set(itertools.product(*zip(lo, hi)))):
        for i in range(3):  # the edges from this corner up each axis the box spans
            if corner[i] == lo[i] < hi[i]:
                end = list(corner)
                end[i] = hi[i]
                _capsule(scn, corner, end, radius, rgba)


def _label(scn: mujoco.MjvScene, at, text: str) -> None:
    """A text label at ``at`` (world, m): an invisible point that MuJoCo's renderer labels."""
    geom = _geom(scn, mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, 1e-3), at, np.eye(3), np.zeros(4, np.float32))
    if geom is not None:
        geom.label = text


def _finger_joints(finger: str) -> list[list[int]]:
    """The joint-angle indices each bone of a finger depends on (thumb: CMC, MCP, IP; fingers: MCP, PIP, DIP)."""
    if finger == "thumb":
        names = [["thumb_cmc_flex", "thumb_cmc_abd"], ["thumb_mcp"], ["thumb_ip"]]
    else:
        names = [[f"{finger}_mcp_flex", f"{finger}_mcp_abd"], [f"{finger}_pip"], [f"{finger}_dip"]]
    return [[JOINTS.index(n) for n in group] for group in names]


def layout_of(env) -> Layout:
    """The ViewFrame layout of an (unwrapped) gloverec task."""
    m = env.model
    return Layout(m.nq, m.nmocap, m.nu, len(env.environment_state_names))


def frame_of(env, status: dict | None = None, pose=None, wrist=None) -> ViewFrame:
    """A ViewFrame of an (unwrapped) gloverec task as it is now, with the glove's HandPose and the tracked wrist's
    FusedWrist if any."""
    d = env.data
    task = env._environment_state()
    frame = ViewFrame(d.qpos.copy(), d.mocap_pos.copy(), d.mocap_quat.copy(), d.ctrl.copy(), np.asarray(task, float),
                      status=status or {})  # fmt: skip
    if pose is not None:
        frame.angles, frame.palm, frame.valid, frame.hand = pose.angles, pose.palm, pose.valid, True
    if wrist is not None:
        frame.wrist = np.concatenate((wrist.position, wrist.quat)).astype(float)
    return frame


def free_camera(stage: Stage) -> mujoco.MjvCamera:
    """A camera that frames the robot and the human hand beside it; with a free wrist, the workspace's bounds too."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (stage.workspace + stage.hand_at) / 2
    cam.distance, cam.azimuth, cam.elevation = stage.env.view_distance_m, 200.0, -28.0
    if stage.env.config.base_position:
        lo, hi = stage.env.base_bounds
        hi = np.maximum(hi, stage.hand_at)
        cam.lookat[:] = (lo + hi) / 2
        radius = np.linalg.norm(hi - lo) / 2
        cam.distance = max(cam.distance, FIT * radius / np.sin(np.radians(stage.model.vis.global_.fovy / 2)))
    return cam
