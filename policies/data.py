"""Datasets for training: where a dataset is (local hub or a recording folder), its train/validation split by
episode, and an in-memory copy of the frames a policy trains on.

The copy is made once through LeRobotDataset with the policy's ``delta_timestamps`` (action chunks, with
``action_is_pad`` past an episode's end), so batches are exactly what lerobot-train would feed the policy,
without the per-item cost at every step. Images are kept as uint8, in memory or, for datasets too big for it, on
disk (policies/diskcache.py; ``decoded_bytes`` is what decides).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import torch
from lerobot.datasets.compute_stats import get_feature_stats
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
from tqdm import tqdm

from policies import diskcache
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
    take 423 MB per 10 k frames (128 x 128: 983 MB), decoded once at about 8 ms a frame. ``store`` "disk" keeps
    the same columns in files beside the dataset instead (policies/diskcache.py), built on the first run and read a
    batch at a time: the same batches, in a flat amount of memory. ``driver`` says who drove
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
        store: str = "memory",
    ):

        self.episodes = list(episodes)
        self.data: dict[str, torch.Tensor | diskcache.DiskColumn] = {}
        self.driver = torch.zeros(0, dtype=torch.uint8)
        self.tasks: list[str] = []  # each frame's instruction, when "task" is among the keys
        if not episodes:
            return
        if action_from != "action" and delta_timestamps and "action" in delta_timestamps:
            delta_timestamps = {**delta_timestamps, action_from: delta_timestamps["action"]}
        folder = None
        if store == "disk":
            what = {"episodes": self.episodes, "keys": keys, "delta": delta_timestamps, "action_from": action_from}
            folder = diskcache.folder_for(ref.root, what)
            found = diskcache.read(folder)
            if found is not None:  # built before, complete: nothing decoded
                self._adopt(*found)
                return
        ds = LeRobotDataset(
            ref.repo_id,
            root=ref.root,
            episodes=self.episodes,
            delta_timestamps=delta_timestamps,
            video_backend=video_backend() if _has_videos(ref.root) else "pyav",  # no video: none is loaded
        )
        keys = [action_from if k == "action" else k for k in keys]
        wanted = [k for k in (*keys, "action_is_pad") if k in ds.features or k == "action_is_pad"]
        writer = diskcache.DiskWriter(folder) if folder is not None else InMemory(len(ds))
        takeover = "intervention" in ds.features
        driver = []
        try:  # row by row into their place: no list of rows stacked at the end, which would double the peak
            for i in tqdm(range(len(ds)), desc=f"loading {len(episodes)} episode(s)", unit="frame",
                          disable=not progress, leave=False):  # fmt: skip
                item = ds[i]
                for k in wanted:
                    if k in item:
                        v = item[k]
                        writer.add("action" if k == action_from else k, self._uint8(v) if self._is_image(k, v) else v)
                driver.append((WEARER if bool(item["intervention"]) else POLICY) if takeover else PLAIN)
                if "task" in keys:
                    self.tasks.append(item["task"])
        except BaseException:
            writer.abandon()
            raise
        names = {t: i for i, t in enumerate(sorted(set(self.tasks)))}
        extra = {"driver": driver, "task_names": list(names), "tasks": [names[t] for t in self.tasks]}
        self._adopt(writer.finish(extra), extra)

    def _adopt(self, columns: dict, extra: dict) -> None:
        """The columns (tensors, or a cache on disk's), who drove each frame and its instruction (small: in memory)."""
        self.data = columns
        self.driver = torch.tensor(extra["driver"], dtype=torch.uint8)
        self.tasks = [extra["task_names"][i] for i in extra["tasks"]]

    @classmethod
    def join(cls, caches: list[FrameCache]) -> FrameCache:
        """The frames of several datasets' caches as one (their features checked alike by the caller)."""
        out = cls.__new__(cls)
        full = [c for c in caches if c.data]
        out.episodes = [e for c in caches for e in c.episodes]
        out.data = {k: _cat([c.data[k] for c in full]) for k in (full[0].data if full else {})}
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
    def _uint8(image: torch.Tensor) -> torch.Tensor:
        return (image * 255).round().to(torch.uint8)

    @staticmethod
    def _is_image(key: str, value) -> bool:
        return key.startswith("observation.images.") and torch.is_floating_point(value)

    def __len__(self) -> int:
        return len(next(iter(self.data.values()))) if self.data else 0

    def batch(self, indices: torch.Tensor) -> dict[str, torch.Tensor]:
        out = {}
        for k, v in self.data.items():
            x = diskcache.take(v, indices)
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
            if k == "action" and len(self.data[k].shape) == 3:
                x = diskcache.scan(self.data[k], lambda r: r[:, 0])  # the frame's own action: each one exactly once
            elif len(self.data[k].shape) == 3:
                x = diskcache.scan(self.data[k], lambda r: r[:, -1])  # a history window: the frame's own observation
            else:
                x = diskcache.scan(self.data[k], lambda r: r)
            s = get_feature_stats(x.numpy().astype(np.float64), axis=0, keepdims=False)
            s["std"] = np.maximum(s["std"], MIN_STD)
            out[k] = s
        return out


class InMemory:
    """FrameCache's columns in memory, filled a row at a time (the interface of diskcache.DiskWriter): each column a
    tensor of all the rows, made at its first row."""

    def __init__(self, rows: int):
        self.rows = rows
        self.columns: dict[str, torch.Tensor] = {}
        self.filled: dict[str, int] = {}

    def add(self, key: str, value: torch.Tensor) -> None:
        if key not in self.columns:
            self.columns[key] = torch.empty((self.rows, *value.shape), dtype=value.dtype)
            self.filled[key] = 0
        self.columns[key][self.filled[key]] = value
        self.filled[key] += 1

    def finish(self, extra: dict) -> dict[str, torch.Tensor]:
        return {k: v[: self.filled[k]] for k, v in self.columns.items()}

    def abandon(self) -> None:
        self.columns.clear()


def decoded_bytes(meta, episodes: list[int], keys: list[str], delta_timestamps: dict | None) -> int:
    """About how many bytes FrameCache takes for ``episodes``: each key's feature (images as uint8, the rest as
    float32) times its window (delta timestamps), plus the action's padding flags."""
    delta = delta_timestamps or {}
    per_frame = sum(
        math.prod(meta.features[k]["shape"]) * (1 if meta.features[k]["dtype"] in ("video", "image") else 4)
        * len(delta.get(k, [0]))
        for k in keys if k in meta.features
    )  # fmt: skip
    per_frame += len(delta.get("action", []))
    return per_frame * sum(int(meta.episodes[e]["length"]) for e in episodes)


def _cat(columns: list):
    return torch.cat(columns) if torch.is_tensor(columns[0]) else diskcache.DiskColumn.join(columns)


def _has_videos(root: Path) -> bool:
    return any(f.get("dtype") == "video" for f in dataset_info(root).get("features", {}).values())


def dataset_info(root: Path) -> dict:
    try:
        return json.loads((Path(root) / "meta" / "info.json").read_text())
    except (OSError, ValueError):
        return {}
