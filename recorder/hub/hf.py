"""``push --to-hf``: send a hub version on to the Hugging Face Hub with lerobot's own `LeRobotDataset.push_to_hub`.

Needs a network and a token (``HF_TOKEN`` or `hf auth login`); ``require_online`` says clearly why not before
anything is pushed anywhere.
"""

from __future__ import annotations

import os

from recorder import GloverecError
from recorder.video_backend import video_backend

_TRUE = {"1", "ON", "YES", "TRUE"}
# what of a version goes up: the dataset itself, not our manifest (lerobot skips images/ itself)
_ALLOW = ["meta/", "data/", "videos/"]


def require_online() -> None:
    """GloverecError unless the Hugging Face Hub can be reached in principle: not offline, and a token exists."""
    if os.environ.get("HF_HUB_OFFLINE", "").strip().upper() in _TRUE:
        raise GloverecError(
            "--to-hf: HF_HUB_OFFLINE is set, so nothing can be pushed to the Hugging Face Hub "
            "(unset it, or push without --to-hf)"
        )
    from huggingface_hub import get_token  # only for --to-hf: not at start-up

    if not get_token():
        raise GloverecError("--to-hf: no Hugging Face token (set HF_TOKEN or run `hf auth login`)")


def push_version(repo_id: str, root: os.PathLike, private: bool = False) -> str:
    """Push the dataset at ``root`` (a hub version) to the Hugging Face Hub as ``repo_id``; return its URL."""
    require_online()
    try:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset  # torch and LeRobot: not at start-up

        dataset = LeRobotDataset(repo_id, root=root, video_backend=video_backend())
        dataset.push_to_hub(private=private, allow_patterns=_ALLOW, tags=["gloverec"])
    except Exception as exc:  # network, auth and server errors come from several libraries: all end up here
        text = str(exc).strip().splitlines()
        raise GloverecError(
            f"--to-hf: the push to the Hugging Face Hub failed: {type(exc).__name__}: "
            f"{text[0] if text else 'no details'}"
        ) from None
    return f"https://huggingface.co/datasets/{repo_id}"
