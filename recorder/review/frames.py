"""The player's pictures, one JPEG per request: an episode's camera frames decoded from its video (PyAV, the
episode's segment once, a few episodes kept), or, for a dataset without cameras, the scene rendered with MuJoCo
frame by frame as the page asks (never the whole episode first).

A render replays the episode's recorded actions through its task from the episode's seed (as `gloverec replay`
does; MuJoCo is deterministic, so the scene, object included, is the recorded one): the env steps forward to the
frame asked for, and back to the reset when the page seeks backwards. Recorded states alone cannot set the whole
scene (they hold the hand's joints and palm, and the object only as each task describes it), so an episode
without a seed (trimmed at its start, or recorded by another tool) shows the hand posed from its recorded joint
positions and palm, in its task's scene at seed 0 (the object where that reset puts it, not moved).

Every MuJoCo and decoder call runs on one worker thread: the GL context belongs to the thread that made it."""

from __future__ import annotations

import io
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from PIL import Image

from recorder.review.session import Session

SIZE = (360, 480)  # the player's render, height x width
THUMB = (96, 128)
KEPT = 4  # episodes whose decoded camera frames are kept


class Frames:
    def __init__(self, session: Session):
        self.session = session
        self.worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="review-frames")
        self.decoded: OrderedDict[int, list[np.ndarray]] = OrderedDict()
        self.stage = None
        self.renderers: dict = {}
        self.at: tuple[int, int] | None = None  # (episode, frame) the replaying env is at
        self.replay = True  # the env takes the recorded actions (False: its options differ from the dataset's)

    def warm(self) -> None:
        """Start building the scene now (MuJoCo's model, the renderer), while the browser loads the page."""
        s = self.session
        if not s.cameras and s.episodes:
            self.worker.submit(self._frame, min(s.episodes), 0, False)

    def frame(self, e: int, k: int) -> bytes:
        """Frame ``k`` of episode ``e`` as a JPEG."""
        return self.worker.submit(self._frame, e, k, False).result()

    def thumb(self, e: int) -> bytes:
        """Episode ``e``'s first frame, small."""
        return self.worker.submit(self._frame, e, 0, True).result()

    def close(self) -> None:
        self.worker.submit(self._close).result()
        self.worker.shutdown()

    def reset(self) -> None:
        """Forget what was decoded and where the env is (the session opened another version)."""
        self.worker.submit(lambda: (self.decoded.clear(), setattr(self, "at", None))).result()

    # ------------------------------------------------------------ on the worker thread

    def _frame(self, e: int, k: int, small: bool) -> bytes:
        s = self.session
        k = min(max(0, k), s.lengths[e] - 1) if e in s.lengths else k
        s._known(e)
        if s.cameras:
            image = self._decode(e)[k] if not small else self._decode_first(e)
        else:
            image = self._render(e, k, THUMB if small else SIZE)
        if small and image.shape[:2] != THUMB:
            pil = Image.fromarray(image)
            pil.thumbnail(THUMB[::-1])
            image = np.asarray(pil)
        buf = io.BytesIO()
        Image.fromarray(image).save(buf, "JPEG", quality=85)
        return buf.getvalue()

    def _video(self, e: int, key: str):
        s, meta = self.session, self.session.episodes[e]
        path = s.src / s.info["video_path"].format(video_key=key, chunk_index=int(meta[f"videos/{key}/chunk_index"]),
                                                   file_index=int(meta[f"videos/{key}/file_index"]))  # fmt: skip
        return path, float(meta[f"videos/{key}/from_timestamp"])

    def _segment(self, e: int, key: str, count: int) -> list[np.ndarray]:
        """The first ``count`` frames of episode ``e`` in camera ``key``'s video."""
        import av  # the video decoder: loaded for the first camera frame, after the page is up

        path, start = self._video(e, key)
        frames = []
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            container.seek(int(start / stream.time_base), stream=stream, backward=True)
            half = 0.5 / self.session.fps
            for f in container.decode(stream):
                if f.time is not None and f.time < start - half:
                    continue
                frames.append(f.to_ndarray(format="rgb24"))
                if len(frames) == count:
                    break
        return frames

    def _decode(self, e: int) -> list[np.ndarray]:
        """Every frame of episode ``e``, the cameras side by side."""
        if e in self.decoded:
            self.decoded.move_to_end(e)
            return self.decoded[e]
        n = self.session.lengths[e]
        cams = [self._segment(e, key, n) for key in self.session.cameras]
        n = min(len(c) for c in cams)
        frames = [np.hstack([c[i] for c in cams]) for i in range(n)]
        if not frames:
            raise RuntimeError(f"episode {e}: its video has no frames")
        frames += [frames[-1]] * (self.session.lengths[e] - n)  # a short video: its last frame held
        self.decoded[e] = frames
        while len(self.decoded) > KEPT:
            self.decoded.popitem(last=False)
        return frames

    def _decode_first(self, e: int) -> np.ndarray:
        if e in self.decoded:
            return self.decoded[e][0]
        return np.hstack([self._segment(e, key, 1)[0] for key in self.session.cameras])

    def _render(self, e: int, k: int, size: tuple[int, int]) -> np.ndarray:
        import mujoco  # MuJoCo and the scene: loaded for the first drawn frame, after the page is up

        from recorder.view.scene import frame_of

        stage = self._stage(e)
        env, rows = stage.env, self.session.rows(e)
        seed = self.session.records.get(e, {}).get("seed")
        if self.replay and seed is not None and "action" in rows:
            if self.at is None or self.at[0] != e or self.at[1] > k:
                env.reset(seed=int(seed))
                self.at = (e, 0)
            for j in range(self.at[1], k):
                env.step(rows["action"][j])
            self.at = (e, k)
        else:
            self._pose(env, e, rows["observation.state"][k])
        if size not in self.renderers:
            self.renderers[size] = mujoco.Renderer(stage.model, *size)
        renderer, camera = self.renderers[size], self.camera
        stage.frame = frame_of(env)  # for the task's extras: HandPose's target gesture as a ghost
        renderer.update_scene(stage.data, camera=camera, scene_option=self.option)
        stage.decorate(renderer.scene, self.option)
        return renderer.render()

    def _pose(self, env, e: int, state: np.ndarray) -> None:
        """The hand as recorded in ``state`` (joint positions, then velocities, then the palm's pose)."""
        import mujoco  # as in _render

        if self.at != (e, -1):
            env.reset(seed=0)
            self.at = (e, -1)
        nj = len(env.joint_names)
        names = self.session.features["observation.state"]["names"]
        palm = names.index("palm.x") if "palm.x" in names else None
        env.data.qpos[env._jq] = state[:nj]
        if palm is not None:
            env._place_base(state[palm : palm + 3], state[palm + 3 : palm + 7])
        mujoco.mj_forward(env.model, env.data)

    def _stage(self, e: int):
        """The task's scene (recorder/view/scene.py's Stage) with the dataset's robot, rate and layout."""
        if self.stage is not None:
            return self.stage
        import mujoco  # as in _render

        from envs.tasks.base import BASE_POSITION, BASE_ROTATION
        from recorder.view.scene import Stage

        s, rec = self.session, self.session.records.get(e, {})
        task, robot = rec.get("env_task"), rec.get("robot") or s.info.get("robot_type")
        if not task or not robot:
            raise RuntimeError("the dataset's episode records do not name its task and robot: nothing to render")
        actions = s.features.get("action", {}).get("names") or []
        states = s.features.get("observation.state", {}).get("names") or []
        options = {
            "control_hz": s.fps,
            "base_rotation": set(BASE_ROTATION) <= set(actions),
            "base_position": set(BASE_POSITION) <= set(actions),
            "state_velocities": any(n.endswith(".vel") for n in states),
            "state_includes_task": "observation.environment_state" not in s.features,
        }
        try:
            self.stage = Stage(task, robot, options)
        except Exception:  # noqa: BLE001  (a task that refuses one of them: its defaults, the hand posed from states)
            self.stage, self.replay = Stage(task, robot, {"control_hz": s.fps}), False
        self.stage.show_hand = self.stage.robot_shown = False  # no glove data here; no "robot" label
        self.option, self.camera = mujoco.MjvOption(), self._camera(self.stage)  # framed at the reset
        return self.stage

    @staticmethod
    def _camera(stage):
        """The live view's camera, turned to the robot and its task (no human hand is drawn beside it here)."""
        from recorder.view.scene import free_camera  # as in _render

        cam = free_camera(stage)
        env = stage.env
        if not env.config.base_position:
            cam.lookat[:] = (stage.workspace + env.data.mocap_pos[env._mocap]) / 2
            cam.distance, cam.elevation = 0.6 * env.view_distance_m, -25.0
        return cam

    def _close(self) -> None:
        for renderer in self.renderers.values():
            renderer.close()
        self.renderers.clear()
        if self.stage is not None:
            self.stage.env.close()
