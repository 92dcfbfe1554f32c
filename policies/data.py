"""Datasets for training: where a dataset is (local hub or a recording folder), its train/validation split by
episode, and an in-memory copy of the frames a policy trains on.

The copy is made once through LeRobotDataset with the policy's ``delta_timestamps`` (action chunks, with
``action_is_pad`` past an episode's end), so batches are exactly what lerobot-train would feed the policy,
without the per-item cost at every step. Images are kept as uint8. Datasets too big for memory belong to
``lerobot-train --policy.type=gloverec_bc`` (docs/policies.md).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch
from lerobot.datasets.compute_stats import get_feature_stats
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
from tqdm import tqdm

from policies.dataref import DatasetRef, recorded_with, resolve, sidecar  # noqa: F401  (this module's API too)
from recorder import GloverecError
from recorder.video_backend import video_backend

PLAIN, WEARER, POLICY = 0, 1, 2  # who drove a frame (FrameCache.driver)
MIN_STD = 1e-3  # floor of the normalisation std: features (nearly) constant in the demonstrations stay O(1)


def load_meta(ref: DatasetRef):

    try:
        return LeRobotDatasetMetadata(ref.repo_id, root=ref.root)
    except Exception as exc:  # noqa: BLE001  (lerobot raises many kinds; the user needs one line)
        raise GloverecError(f"cannot read the dataset {ref.repo_id} at {ref.root}: {exc}") from None


def split_episodes(meta, root: Path, val_fraction: float, seed: int, successful_only: bool) -> tuple[list, list]:
    """(train, validation) episode indices: a seeded shuffle, the last ``val_fraction`` for validation
    (at least one when there are two or more episodes). ``successful_only`` keeps the episodes our sidecar
    marks successful (all of them when the dataset has no sidecar, or is a takeover recording: the wearer's frames
    are the expert's labels even where the episode failed after the policy's mistakes, as in HG-DAgger)."""
    episodes = list(range(meta.total_episodes))
    side = sidecar(root)
    if successful_only and side and "intervention" not in meta.features:
        episodes = [e for e in episodes if side.get(e, {}).get("success", True)]
        if not episodes:
            raise GloverecError(
                f"{root} has no successful episodes to train on (the recorder marked all {meta.total_episodes} "
                "unsuccessful): --all-episodes trains on them anyway"
            )
    if not episodes:
        raise GloverecError(f"{root} has no episodes to train on")
    rng = np.random.default_rng(seed)
    order = [int(e) for e in rng.permutation(episodes)]
    n_val = 0 if len(order) < 2 or val_fraction <= 0 else max(1, int(round(val_fraction * len(order))))
    n_val = min(n_val, len(order) - 1)
    return sorted(order[: len(order) - n_val]), sorted(order[len(order) - n_val :])


class FrameCache:
    """Every frame of some episodes as stacked tensors: the policy's inputs, ``action`` (chunks) and
    ``action_is_pad`` (and ``task``, each frame's instruction, when asked for). ``batch(indices)`` gives a training
    batch; images come back as float in [0, 1]. Images are kept decoded as uint8 in memory: 2 cameras at 84 x 84
    take 423 MB per 10 k frames (128 x 128: 983 MB), decoded once at about 8 ms a frame. ``driver`` says who drove
    each frame: PLAIN (a demonstration), WEARER or POLICY (a takeover recording's ``intervention`` flag,
    recorder/record/takeover.py). ``action_from``: the feature whose chunks stand as ``action`` (a DART recording's
    intended action, with the same delta timestamps and padding as the action's)."""

    def __init__(
        self,
        ref: DatasetRef,
        episodes: list[int],
        keys: list[str],
        delta_timestamps: dict | None,
        progress: bool = True,
        action_from: str = "action",
    ):

        self.episodes = list(episodes)
        self.data: dict[str, torch.Tensor] = {}
        self.driver = torch.zeros(0, dtype=torch.uint8)
        self.tasks: list[str] = []  # each frame's instruction, when "task" is among the keys
        if not episodes:
            return
        if action_from != "action" and delta_timestamps and "action" in delta_timestamps:
            delta_timestamps = {**delta_timestamps, action_from: delta_timestamps["action"]}
        ds = LeRobotDataset(
            ref.repo_id,
            root=ref.root,
            episodes=self.episodes,
            delta_timestamps=delta_timestamps,
            video_backend=video_backend() if _has_videos(ref.root) else "pyav",  # no video: none is loaded
        )
        keys = [action_from if k == "action" else k for k in keys]
        wanted = [k for k in (*keys, "action_is_pad") if k in ds.features or k == "action_is_pad"]
        columns: dict[str, list] = {k: [] for k in wanted}
        takeover = "intervention" in ds.features
        driver = []
        for i in tqdm(
            range(len(ds)), desc=f"loading {len(episodes)} episode(s)", unit="frame", disable=not progress, leave=False
        ):
            item = ds[i]
            for k in wanted:
                if k in item:
                    v = item[k]
                    columns[k].append((v * 255).round().to(torch.uint8) if self._is_image(k, v) else v)
            driver.append((WEARER if bool(item["intervention"]) else POLICY) if takeover else PLAIN)
            if "task" in keys:
                self.tasks.append(item["task"])
        self.data = {("action" if k == action_from else k): torch.stack(v) for k, v in columns.items() if v}
        self.driver = torch.tensor(driver, dtype=torch.uint8)

    @classmethod
    def join(cls, caches: list[FrameCache]) -> FrameCache:
        """The frames of several datasets' caches as one (their features checked alike by the caller)."""
        out = cls.__new__(cls)
        full = [c for c in caches if c.data]
        out.episodes = [e for c in caches for e in c.episodes]
        out.data = {k: torch.cat([c.data[k] for c in full]) for k in (full[0].data if full else {})}
        out.driver = torch.cat([c.driver for c in caches]) if caches else torch.zeros(0, dtype=torch.uint8)
        out.tasks = [t for c in caches for t in c.tasks]
        return out

    def weights(self, intervention_weight: float, policy_frames: bool) -> torch.Tensor | None:
        """How often to draw each frame, relative to a demonstration's (None: all alike): the wearer's frames of a
        takeover recording ``intervention_weight``, the policy's 1 with ``policy_frames`` else 0 (HG-DAgger learns
        from the expert's labels only: the policy's own frames would teach it its mistakes)."""
        if not bool((self.driver != PLAIN).any()) or (intervention_weight == 1.0 and policy_frames):
            return None
        w = torch.ones(len(self.driver), dtype=torch.float64)
        w[self.driver == WEARER] = intervention_weight
        w[self.driver == POLICY] = 1.0 if policy_frames else 0.0
        if not bool((w > 0).any()):
            raise GloverecError("no frames to train on: every frame was driven by the policy (pass --policy-frames)")
        return w

    @staticmethod
    def _is_image(key: str, value) -> bool:
        return key.startswith("observation.images.") and torch.is_floating_point(value)

    def __len__(self) -> int:
        return len(next(iter(self.data.values()))) if self.data else 0

    def batch(self, indices: torch.Tensor) -> dict[str, torch.Tensor]:
        out = {}
        for k, v in self.data.items():
            x = v[indices]
            out[k] = x.float() / 255 if x.dtype == torch.uint8 else x
        if self.tasks:
            out["task"] = [self.tasks[i] for i in indices.tolist()]
        return out

    def stats(self, keys: list[str], base: dict) -> dict[str, dict[str, np.ndarray]]:
        """Normalisation statistics of these frames (lerobot's get_feature_stats) for vector features; image
        statistics from ``base`` (the dataset's). Stds are floored at MIN_STD."""

        out = {k: dict(v) for k, v in base.items()}
        for k in keys:
            if k not in self.data or k.startswith("observation.images."):
                continue
            x = self.data[k]
            if k == "action" and x.dim() == 3:
                x = x[:, 0]  # the frame's own action: every recorded action exactly once
            elif x.dim() == 3:
                x = x[:, -1]  # a history window: the frame's own observation, every one exactly once
            s = get_feature_stats(x.numpy().astype(np.float64), axis=0, keepdims=False)
            s["std"] = np.maximum(s["std"], MIN_STD)
            out[k] = s
        return out


def _has_videos(root: Path) -> bool:
    return any(f.get("dtype") == "video" for f in dataset_info(root).get("features", {}).values())


def dataset_info(root: Path) -> dict:
    try:
        return json.loads((Path(root) / "meta" / "info.json").read_text())
    except (OSError, ValueError):
        return {}
