"""Curating a recorded dataset (`gloverec edit`, its command in recorder/review/cli.py): delete episodes, trim an
episode's start or end, relabel an episode's success. The source is never changed: the result is a new dataset
folder (the command publishes it as a hub's next version when the source is in a hub).

The kept episodes are written again through LeRobot's own writer (``write_episodes``, which `gloverec repair` writes
with too: ``LeRobotDataset.create``, ``save_episode``; a vector-only episode handed over whole, camera frames one by
one through ``add_frame`` and its video encoder):
re-indexed from 0, timestamps from 0 in a trimmed episode, statistics recomputed; plain ``LeRobotDataset`` loads
the result. (LeRobot's dataset_tools delete episodes but cannot trim inside one: one writer for both keeps them
consistent.) gloverec's episode records (meta/gloverec/episodes.jsonl: seed, success, glove figures) follow their
episodes; an episode trimmed at its start loses its seed (a replay starts at the reset, which that episode no longer
does); the other files of meta/gloverec/ are copied.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from recorder import GloverecError
from recorder.record.sidecar import SIDECAR, read_sidecar
from recorder.video_backend import video_backend

_TRIM = re.compile(r"^(\d+):(\d+(?:\.\d*)?)?-(\d+(?:\.\d*)?|end)?$")
_SUCCESS = {"yes": True, "true": True, "1": True, "no": False, "false": False, "0": False}
_LEROBOT_OWN = ("timestamp", "frame_index", "episode_index", "index", "task_index")


@dataclass
class Edits:
    """What to change, by the source's episode indices."""

    delete: set[int] = field(default_factory=set)
    trim: dict[int, tuple[float, float | None]] = field(default_factory=dict)  # (start s, end s or None: the end)
    success: dict[int, bool] = field(default_factory=dict)

    @classmethod
    def parse(cls, delete: str | None, trims: list[str], successes: list[str]) -> Edits:
        edits = cls()
        for part in (delete or "").split(","):
            part = part.strip()
            if not part:
                continue
            m = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
            if m is None:
                raise GloverecError(f"bad --delete {delete!r}: expected episode indices such as 3,7 or 10-14")
            first, last = int(m[1]), int(m[2] or m[1])
            if last < first:
                raise GloverecError(f"bad --delete range {part!r}: the end comes before the start")
            edits.delete.update(range(first, last + 1))
        for text in trims:
            m = _TRIM.match(text.replace(" ", ""))
            if m is None:
                raise GloverecError(
                    f"bad --trim {text!r}: expected EPISODE:START-END in seconds, e.g. 2:0.5-end or 4:0-6.2"
                )
            start = float(m[2] or 0.0)
            end = None if m[3] in (None, "end") else float(m[3])
            if end is not None and end <= start:
                raise GloverecError(f"--trim {text}: trims episode {m[1]} to nothing (the end is not after the start)")
            edits.trim[int(m[1])] = (start, end)
        for text in successes:
            episode, _, verdict = text.partition(":")
            if not episode.isdigit() or verdict.lower() not in _SUCCESS:
                raise GloverecError(f"bad --success {text!r}: expected EPISODE:yes or EPISODE:no")
            edits.success[int(episode)] = _SUCCESS[verdict.lower()]
        both = sorted(edits.delete & (set(edits.trim) | set(edits.success)))
        if both:
            raise GloverecError(f"episode {both[0]} is both deleted and trimmed or relabelled: which is it?")
        return edits

    def __bool__(self) -> bool:
        return bool(self.delete or self.trim or self.success)

    def describe(self) -> str:
        parts = []
        if self.delete:
            parts.append(f"deleted {', '.join(map(str, sorted(self.delete)))}")
        for e, (a, b) in sorted(self.trim.items()):
            parts.append(f"trimmed {e} to {a:g}-{'end' if b is None else f'{b:g}'} s")
        for e, ok in sorted(self.success.items()):
            parts.append(f"{e} relabelled {'successful' if ok else 'failed'}")
        return "; ".join(parts)


def frame_ranges(lengths: dict[int, int], fps: float, edits: Edits) -> dict[int, range]:
    """Each kept source episode's frames (0-based within the episode), in order; checked against the dataset."""
    named = sorted(edits.delete | set(edits.trim) | set(edits.success))
    unknown = [e for e in named if e not in lengths]
    if unknown:
        raise GloverecError(
            f"no episode {unknown[0]}: the dataset has episodes 0-{max(lengths)}" if lengths else "the dataset is empty"
        )
    kept = {e: range(n) for e, n in sorted(lengths.items()) if e not in edits.delete}
    if not kept:
        raise GloverecError(f"--delete would remove every episode ({len(lengths)}): nothing would be left")
    for e, (start, end) in edits.trim.items():
        n = lengths[e]
        first = math.ceil(start * fps - 1e-6)
        stop = n if end is None else min(n, math.floor(end * fps + 1e-6) + 1)
        if first >= stop:
            raise GloverecError(f"--trim {e}: episode {e} is {n / fps:.2f} s long; {start:g} s onwards leaves nothing")
        kept[e] = range(first, stop)
    return kept


@dataclass(frozen=True)
class DatasetSpec:
    """What the rewritten dataset is: its id, rate, features (lerobot's own columns included), robot and tasks."""

    repo_id: str
    fps: int
    features: dict
    robot_type: str | None
    tasks: dict[int, str]  # task_index -> the task's text

    @property
    def stored(self) -> dict:
        """The features a writer is given (lerobot adds its own columns)."""
        return {k: v for k, v in self.features.items() if k not in _LEROBOT_OWN}

    @property
    def cameras(self) -> list[str]:
        return [k for k, v in self.stored.items() if v["dtype"] in ("video", "image")]


@dataclass
class Take:
    """One episode to write: its stored columns (the parquet files' values, ``task_index`` included) and, with
    cameras, ``frames(j)``: each camera's j-th frame, (H, W, C) uint8."""

    rows: dict[str, list]
    frames: Callable[[int], dict[str, np.ndarray]] | None = None

    def __len__(self) -> int:
        return len(self.rows["task_index"])


def write_episodes(out: Path, spec: DatasetSpec, takes: Iterable[Take], total: int, progress: bool = True) -> int:
    """Write ``takes`` in order as the episodes 0.. of a new dataset at ``out`` through LeRobot's own writer
    (``LeRobotDataset.create``, ``save_episode``); the number written. ``total``: their frames, for the bar."""
    import datasets
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # lerobot: not at start-up
    from tqdm import tqdm

    from recorder.record.episode_stats import lerobot_save_speedups  # lerobot's writer, patched while saving

    datasets.disable_progress_bars()  # a "Map" bar per episode
    os.environ.setdefault("SVT_LOG", "1")  # the AV1 encoder's banner on every episode: errors only
    features, cameras = spec.stored, spec.cameras
    videos = any(v["dtype"] == "video" for v in features.values())
    target = LeRobotDataset.create(spec.repo_id, spec.fps, features, root=out, robot_type=spec.robot_type,
                                   use_videos=videos, video_backend=video_backend())  # fmt: skip
    bar = tqdm(total=total, desc="writing", unit="frame", disable=not progress, file=sys.stderr)
    written = 0
    try:
        with lerobot_save_speedups(spec.features):  # exact episode stats, no embed_images where there are no images
            for take in takes:
                rows, n = take.rows, len(take)
                tasks = [spec.tasks[int(t)] for t in rows["task_index"]]
                if cameras:  # camera frames go through LeRobot's image writer and video encoder, frame by frame
                    for j in range(n):
                        frame = {key: _value(rows[key][j], features[key]) for key in features if key not in cameras}
                        target.add_frame({**frame, **take.frames(j), "task": tasks[j]})
                        bar.update()
                    target.save_episode()
                else:  # vectors only: the whole episode at once (LeRobot's save_episode takes a built episode)
                    episode = {key: [_value(v, features[key]) for v in rows[key]] for key in features}
                    episode.update(size=n, task=tasks, episode_index=written, index=[], task_index=[])
                    episode.update(frame_index=np.arange(n), timestamp=np.arange(n) / spec.fps)
                    target.save_episode(episode_data=episode)
                    bar.update(n)
                written += 1
    finally:
        bar.close()
        target.finalize()
    return written


def edit_dataset(src: Path, out: Path, repo_id: str, edits: Edits, progress: bool = True) -> dict:
    """Write the edited copy of the dataset at ``src`` into the new folder ``out``; a summary."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # lerobot: not at start-up

    t0 = time.perf_counter()
    source = LeRobotDataset(repo_id, root=src, video_backend=video_backend())
    meta = source.meta
    episodes = meta.episodes
    lengths = {int(e): int(n) for e, n in zip(episodes["episode_index"], episodes["length"])}
    starts = {int(e): int(i) for e, i in zip(episodes["episode_index"], episodes["dataset_from_index"])}
    kept = frame_ranges(lengths, meta.fps, edits)
    records = {int(r["episode_index"]): r for r in read_sidecar(src)}
    tasks = {int(i): t for t, i in zip(meta.tasks.index, meta.tasks["task_index"])}
    spec = DatasetSpec(repo_id, meta.fps, meta.features, meta.robot_type, tasks)
    data = source.hf_dataset.with_format(None)  # the stored columns, no video decoding
    new_records = []

    def camera_frames(index: int) -> dict[str, np.ndarray]:
        item = source[index]  # decodes the camera frames: (C, H, W) float in [0, 1]
        return {key: (item[key].permute(1, 2, 0).numpy() * 255.0).round().astype(np.uint8) for key in spec.cameras}

    def takes():
        for new_index, (e, frames) in enumerate(kept.items()):
            first = starts[e] + frames.start
            rows = data[first : starts[e] + frames.stop]  # columns of the kept frames
            if e in records:
                new_records.append(_record(records[e], new_index, len(frames), rows, e, edits))
            yield Take(rows, (lambda j, first=first: camera_frames(first + j)) if spec.cameras else None)

    write_episodes(out, spec, takes(), total=sum(len(r) for r in kept.values()), progress=progress)
    write_meta(src, out, new_records)
    return {
        "source": str(src),
        "out": str(out),
        "episodes": len(kept),
        "frames": int(sum(len(r) for r in kept.values())),
        "source_episodes": len(lengths),
        "edits": edits.describe(),
        "episode_map": {str(e): j for j, e in enumerate(kept)},
        "records_carried": len(new_records),
        "wall_s": round(time.perf_counter() - t0, 2),
    }


def _value(value, feature: dict):
    if feature["dtype"] == "string":
        return value
    array = np.asarray(value, dtype=feature["dtype"])
    return array.reshape(feature["shape"])


def _record(record: dict, index: int, frames: int, rows: dict, source_index: int, edits: Edits) -> dict:
    """``record`` for the new episode ``index`` made of ``rows`` (the kept frames' columns) of ``source_index``."""
    out = {**record, "episode_index": index, "frames": frames}
    if "time.device_s" in rows:  # the key read_sidecar matches records by: the first kept frame's device time
        out["start_device_time_s"] = float(np.asarray(rows["time.device_s"][0]).reshape(-1)[0])
    if source_index in edits.trim:
        start, end = edits.trim[source_index]
        out["trimmed_s"] = [start, end]
        if start > 0:
            out.pop("seed", None)  # a replay starts at the reset; this episode no longer does
    if source_index in edits.success:
        out["success"] = edits.success[source_index]
    out["edited_from"] = source_index
    return out


def write_meta(src: Path, out: Path, records: list[dict]) -> None:
    """meta/gloverec/ of a rewritten dataset: the episode records re-indexed, the other files copied."""
    mine, theirs = out / SIDECAR, src / SIDECAR
    if theirs.parent.is_dir():
        for f in theirs.parent.iterdir():
            if f.is_file() and f.name != theirs.name:
                mine.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(f, mine.parent / f.name)
    if records:
        mine.parent.mkdir(parents=True, exist_ok=True)
        mine.write_text("".join(json.dumps(r) + "\n" for r in records))
