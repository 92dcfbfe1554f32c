"""The dataset's features: what the environment observes, the action it applied, the human hand before
retargeting, per-frame quality and the real clocks. Names come from the environment, so every column of a
recorded dataset says what it is."""

from __future__ import annotations

from recorder.hand.kinematics import JOINTS

GLOVE_NAMES = [*(f"{j}.rad" for j in JOINTS), "palm.qw", "palm.qx", "palm.qy", "palm.qz"]
QUALITY = {
    "quality.latency_ms": "glove sample -> applied action, real time only (-1: not measured, fast mode)",
    "quality.glove_age_ms": "how far the newest glove sample lagged the frame time (0: interpolated)",
    "quality.retarget_error_mm": "mean robot vs scaled human fingertip distance",
    "quality.fusion": "host fusion's disturbance estimate (0: glove-side fusion or none)",
}
TIMES = {
    "time.host_s": "host monotonic clock at the frame's tick",
    "time.device_s": "glove device clock at the frame time (unwrapped; -1 for legacy JSON gloves)",
}


def _vec(names, dtype="float32") -> dict:
    return {"dtype": dtype, "shape": (len(names),), "names": list(names)}


def dataset_features(env, use_videos: bool) -> dict:
    """LeRobot feature specs for an (unwrapped) gloverec HandEnv."""
    feats = {
        "observation.state": _vec(env.state_names),
        "observation.environment_state": _vec(env.environment_state_names),
        "action": _vec(env.action_names),
        "observation.glove": _vec(GLOVE_NAMES),
    }
    h, w = env.config.image_size
    for cam in env.config.cameras:
        feats[f"observation.images.{cam}"] = {
            "dtype": "video" if use_videos else "image",
            "shape": (h, w, 3),
            "names": ["height", "width", "channels"],
        }
    for key in QUALITY:
        feats[key] = _vec([key.split(".", 1)[1]])
    for key in TIMES:
        feats[key] = _vec([key.split(".", 1)[1]], "float64")
    return feats
