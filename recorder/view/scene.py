"""The scene a live view draws: the task as simulated (robot hand, object, table) from a ViewFrame, plus what
only the view shows: HandPose's target gesture as a translucent ghost of the robot, and the human hand as the
glove measures it (the 16-segment hand model through forward kinematics), beside the robot. The extras are added
to an MjvScene after MuJoCo fills it, so they are never part of the physics, the cameras or the dataset."""

from __future__ import annotations

import mujoco
import numpy as np

import envs
from recorder.hand.kinematics import JOINTS, HandSize, forward
from recorder.hand.skeleton import FINGER_SEGMENTS, FINGERS
from recorder.view.state import Layout, ViewFrame

GHOST_RGBA = np.array([0.35, 0.8, 1.0, 0.3], np.float32)
SKIN_RGBA = np.array([0.93, 0.72, 0.58, 1.0], np.float32)
INVALID_RGBA = np.array([0.9, 0.2, 0.2, 1.0], np.float32)  # a joint the glove did not measure in this sample
HAND_OFFSET = np.array([0.0, 0.22, 0.0])  # where the human hand's wrist is drawn, from the workspace centre (m)
BONE_RADIUS = 0.006
LABEL_LIFT = np.array([0.0, 0.0, 0.09])  # a hand's label floats this far above its wrist (m)


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
        """Add the ghost and the human hand to ``scn`` (already holding the scene)."""
        if self.frame is None:
            return
        if self.show_ghost and self.frame.task.size:
            self._ghost(scn, opt)
        if self.robot_shown:
            _label(scn, self.data.mocap_pos[self.env._mocap] + LABEL_LIFT, "robot")
        if self.show_hand and self.frame.hand:
            self._human_hand(scn)
            _label(scn, self.workspace + HAND_OFFSET + LABEL_LIFT, "your hand (glove)")

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
        wrist = self.workspace + HAND_OFFSET
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
            if scn.ngeom >= scn.maxgeom:
                return
            geom = scn.geoms[scn.ngeom]
            mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), np.eye(3).reshape(-1),
                                SKIN_RGBA if ok else INVALID_RGBA)  # fmt: skip
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, BONE_RADIUS, a, b)
            geom.segid = -1
            scn.ngeom += 1


def _label(scn: mujoco.MjvScene, at, text: str) -> None:
    """A text label at ``at`` (world, m): an invisible point that MuJoCo's renderer labels."""
    if scn.ngeom >= scn.maxgeom:
        return
    geom = scn.geoms[scn.ngeom]
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, 1e-3), np.asarray(at, float),
                        np.eye(3).reshape(-1), np.zeros(4, np.float32))  # fmt: skip
    geom.label = text
    geom.segid = -1
    scn.ngeom += 1


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


def frame_of(env, status: dict | None = None, pose=None) -> ViewFrame:
    """A ViewFrame of an (unwrapped) gloverec task as it is now, with the glove's HandPose if any."""
    d = env.data
    task = env._environment_state()
    frame = ViewFrame(d.qpos.copy(), d.mocap_pos.copy(), d.mocap_quat.copy(), d.ctrl.copy(), np.asarray(task, float),
                      status=status or {})  # fmt: skip
    if pose is not None:
        frame.angles, frame.palm, frame.valid, frame.hand = pose.angles, pose.palm, pose.valid, True
    return frame


def free_camera(stage: Stage) -> mujoco.MjvCamera:
    """A camera that frames the robot and the human hand beside it."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = stage.workspace + 0.5 * HAND_OFFSET
    cam.distance, cam.azimuth, cam.elevation = stage.env.view_distance_m, 200.0, -28.0
    return cam
