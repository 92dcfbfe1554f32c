"""The dataset's schema: what the environment observes, the action it applied, the human hand before retargeting,
per-frame quality and the real clocks. ``DatasetSchema(env)`` gives lerobot its feature specs and turns each
``Row`` the recording loop fills into a dataset frame, so every column is declared once, here, with its names
(from the environment for the robot's) and its meaning.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from recorder.hand.kinematics import JOINTS
from recorder.hand.pose import HandPose
from recorder.record.dart import EXPERT_ACTION, EXPERT_OFFSET

GLOVE_NAMES = (*(f"{j}.rad" for j in JOINTS), "palm.qw", "palm.qx", "palm.qy", "palm.qz")


@dataclass(frozen=True)
class Row:
    """One frame as the loop sees it: the observation before the step, the action the environment applied, the
    glove's pose at the frame time, and how it got there."""

    obs: dict
    action: np.ndarray
    pose: HandPose
    latency_s: float | None  # glove sample -> applied action (None: not measured, faster than real time)
    age_s: float  # how far the newest glove sample used lagged the frame time
    retarget_error_m: float
    host_s: float
    device_s: float
    task: str
    wrist: object = None  # a free wrist's FusedWrist (recorder/wrist/fusion.py); None: the task scripts the base
    takeover: object = None  # a takeover recording's Decision (recorder/record/takeover.py)
    intended: np.ndarray | None = None  # DART's or a takeover's: the wearer's action (float32, as the env applies it)


@dataclass(frozen=True)
class Feature:
    key: str
    names: tuple
    value: Callable[[Row], object]
    description: str
    dtype: str = "float32"


def _scalar(x: float | None, dtype=np.float32, missing: float = -1.0) -> np.ndarray:
    return np.array([missing if x is None else x], dtype)


def _vector(key: str) -> Callable[[Row], np.ndarray]:
    return lambda row: row.obs[key]


class DatasetSchema:
    """The features of a recording of ``env`` (an unwrapped gloverec HandEnv); ``use_videos``: cameras as video."""

    def __init__(self, env, use_videos: bool, takeover: bool = False, expert: bool = False):
        self.features = [
            Feature(
                "observation.state",
                tuple(env.state_names),
                _vector("observation.state"),
                "the robot: joint positions, velocities, palm pose (before the step)",
            ),
            Feature(
                "observation.environment_state",
                tuple(env.environment_state_names),
                _vector("observation.environment_state"),
                "the task: its goal or object",
            ),
            Feature("action", tuple(env.action_names), lambda r: r.action, "the action the environment applied"),
            Feature(
                "observation.glove",
                GLOVE_NAMES,
                lambda r: r.pose.vector(),
                "the human hand before retargeting: joint angles (rad), palm orientation",
            ),
            Feature(
                "quality.glove_valid",
                tuple(f"{j}.valid" for j in JOINTS),
                lambda r: r.pose.valid.astype(np.float32),
                "1: the joint was measured in the samples used; 0: it held its last value",
            ),
            Feature(
                "quality.latency_ms",
                ("latency_ms",),
                lambda r: _scalar(None if r.latency_s is None else r.latency_s * 1e3),
                "glove sample -> applied action, real time only (-1: not measured, fast mode)",
            ),
            Feature(
                "quality.glove_age_ms",
                ("glove_age_ms",),
                lambda r: _scalar(r.age_s * 1e3),
                "how far the newest glove sample lagged the frame time (0: interpolated)",
            ),
            Feature(
                "quality.retarget_error_mm",
                ("retarget_error_mm",),
                lambda r: _scalar(r.retarget_error_m * 1e3),
                "mean robot vs scaled human fingertip distance",
            ),
            Feature(
                "quality.fusion",
                ("fusion",),
                lambda r: _scalar(r.pose.quality),
                "host fusion's disturbance estimate (0: glove-side fusion or none)",
            ),
            Feature(
                "time.host_s",
                ("host_s",),
                lambda r: _scalar(r.host_s, np.float64),
                "host monotonic clock at the frame's tick",
                "float64",
            ),
            Feature(
                "time.device_s",
                ("device_s",),
                lambda r: _scalar(r.device_s, np.float64),
                "glove device clock at the frame time (unwrapped; -1 for legacy JSON gloves)",
                "float64",
            ),
        ]
        if env.config.base_position:
            self.features += [
                Feature(
                    "observation.wrist",
                    ("wrist.x", "wrist.y", "wrist.z", "wrist.qw", "wrist.qx", "wrist.qy", "wrist.qz"),
                    lambda r: np.concatenate((r.wrist.position, r.wrist.quat)).astype(np.float32),
                    "the wearer's palm in the robot's world, tracked and fused (before the workspace bounds)",
                ),
                Feature(
                    "quality.wrist_tracked",
                    ("wrist_tracked",),
                    lambda r: _scalar(float(r.wrist.tracked)),
                    "1: the tracker saw the wrist; 0: held (marker lost) or catching up after it",
                ),
                Feature(
                    "quality.wrist_age_ms",
                    ("wrist_age_ms",),
                    lambda r: _scalar(r.wrist.age_s * 1e3),
                    "since the tracker's newest pose was captured",
                ),
            ]
        if takeover:  # a policy ran the hand and the wearer took over (recorder/record/takeover.py)
            self.features += [
                Feature(
                    "intervention",
                    ("intervention",),
                    lambda r: np.array([r.takeover.intervention], bool),
                    "1: the wearer drove this frame (the applied action is the glove's); 0: the policy did",
                    "bool",
                ),
                Feature(
                    "policy.action",
                    tuple(env.action_names),
                    lambda r: np.asarray(r.takeover.policy_action, np.float32),
                    "the action the policy proposed for this frame (applied when intervention is 0)",
                ),
                Feature(
                    "quality.departure",
                    ("departure",),
                    lambda r: _scalar(r.takeover.departure),
                    "the wearer's action's departure from the policy's: the largest share of an element's range",
                ),
            ]
        if expert:  # DART's noise, or a policy driving: the wearer's action kept (recorder/record/dart.py: the names)
            self.features += [
                Feature(
                    EXPERT_ACTION,
                    tuple(env.action_names),
                    lambda r: r.intended,
                    "the wearer's action (before DART's noise; a takeover recording's wearer where the policy drove), "
                    "as the environment would apply it (`action` is the executed one)",
                ),
                Feature(
                    EXPERT_OFFSET,
                    tuple(env.action_names),
                    lambda r: np.float32(r.action) - r.intended,  # float32: exactly action - expert.action
                    "the executed action less the wearer's (DART's noise, or the policy's departure where it drove), "
                    "in float32: action - expert.action",
                ),
            ]
        h, w = env.config.image_size
        self.images = {f"observation.images.{cam}": (h, w, 3) for cam in env.config.cameras}
        self.use_videos = use_videos

    def lerobot_features(self) -> dict:
        """LeRobot feature specs."""
        feats = {f.key: {"dtype": f.dtype, "shape": (len(f.names),), "names": list(f.names)} for f in self.features}
        for key, shape in self.images.items():
            feats[key] = {
                "dtype": "video" if self.use_videos else "image",
                "shape": shape,
                "names": ["height", "width", "channels"],
            }
        return feats

    def descriptions(self) -> dict:
        return {f.key: f.description for f in self.features}

    def frame(self, row: Row) -> dict:
        """The dataset frame of ``row``: every feature, the camera images and the task string."""
        frame = {f.key: f.value(row) for f in self.features}
        for key in self.images:
            frame[key] = row.obs[key]
        frame["task"] = row.task
        return frame
