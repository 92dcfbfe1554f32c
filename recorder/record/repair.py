"""Rescuing the intact episodes of a damaged dataset (`gloverec repair`, its command in recorder/review/cli.py).

One damaged file (a data parquet cut short, a video gone) stops a whole dataset: LeRobot opens every file of
``data/`` and ``meta/episodes/`` when it loads one, and every gloverec command refuses it in one line
(recorder/dataset_check.py), `gloverec edit` included. Here each episode is read on its own, from the files its
row of the episode metadata points to; an episode is dropped, with the reason, when that row is lost, when its
data file is missing, unreadable or does not hold its frames in order, when one of its videos is missing or does
not decode, or (from a hub) when one of its files differs from the version's manifest. The others are written
again, in order and re-indexed from 0, by the writer of `gloverec edit` (recorder/record/edit.py: LeRobot's
``LeRobotDataset.create`` and ``save_episode``, statistics recomputed), so plain ``LeRobotDataset`` loads the
result; their gloverec records follow them (``repaired_from``: the source's index). The source is never changed.

The reading is ours (pyarrow, and LeRobot's ``decode_video_frames`` for one episode's frames): LeRobot has no
reader for part of a dataset (``LeRobotDataset(episodes=...)`` still opens every data and metadata file), so
nothing of it reads past a damaged file.
"""

from __future__ import annotations

import functools
import io
import sys
import time
from collections import Counter
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from recorder import GloverecError, one_line
from recorder.dataset_check import EPISODES_DIR, TASKS, read_info
from recorder.record.edit import DatasetSpec, Take, write_episodes, write_meta
from recorder.record.sidecar import episode_key, read_sidecar
from recorder.video_backend import video_backend

TOLERANCE_S = 1e-4  # LeRobotDataset's default: how far a decoded frame may be from its timestamp
_LOCATES = ("episode_index", "length", "data/chunk_index", "data/file_index")


class _Unusable(Exception):
    """Why a file cannot be read (the message)."""


@dataclass
class Survey:
    """What the cheap checks found: the episodes that may be intact (their metadata rows) and the dropped ones."""

    info: dict
    tasks: dict[int, str]
    intact: dict[int, dict] = field(default_factory=dict)
    dropped: dict[int, str] = field(default_factory=dict)

    def data_file(self, row: dict) -> str:
        return self.info["data_path"].format(chunk_index=row["data/chunk_index"], file_index=row["data/file_index"])

    def video_file(self, row: dict, key: str) -> str:
        c, f = row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"]
        return self.info["video_path"].format(video_key=key, chunk_index=c, file_index=f)

    @property
    def videos(self) -> list[str]:
        return [k for k, v in self.info["features"].items() if v.get("dtype") == "video"]


def survey(root: Path, suspect: Collection[str] = ()) -> Survey:
    """Each episode's metadata row, data file and video files checked without decoding anything; ``suspect``: files
    known to be damaged (those that differ from a hub version's manifest)."""
    info = read_info(root)  # without it nothing says where an episode is: one line
    try:
        tasks = _parquet(root, TASKS, suspect).to_pandas()
    except _Unusable as exc:  # its texts are each frame's task: a rewrite cannot go without them
        raise GloverecError(f"{root} cannot be repaired: {exc}") from None
    found = Survey(info, {int(i): t for t, i in zip(tasks.index, tasks["task_index"])})
    rows, lost = {}, []
    for path in sorted((root / EPISODES_DIR).glob("*/*.parquet")):
        try:
            table = _parquet(root, path.relative_to(root).as_posix(), suspect)
            missing = [c for c in _LOCATES if c not in table.column_names]
            if missing:
                raise _Unusable(f"{path.relative_to(root)} has no column {missing[0]!r}")
        except _Unusable as exc:
            lost.append(str(exc))
            continue
        rows.update((int(row["episode_index"]), row) for row in table.to_pylist())
    for e in sorted(set(range(info["total_episodes"])) | set(rows)):
        if e not in rows:
            found.dropped[e] = f"its row of {EPISODES_DIR} is lost ({lost[0] if lost else 'no file lists it'})"
    by_file: dict[str, list[int]] = {}
    for e, row in sorted(rows.items()):
        by_file.setdefault(found.data_file(row), []).append(e)
    for rel, episodes in by_file.items():
        try:
            counts = Counter(_parquet(root, rel, suspect, columns=["episode_index"])["episode_index"].to_pylist())
        except _Unusable as exc:
            found.dropped.update((e, str(exc)) for e in episodes)
            continue
        for e in episodes:
            if counts[e] != rows[e]["length"]:
                found.dropped[e] = f"{rel} holds {counts[e]} of its {rows[e]['length']} frames"
                continue
            try:
                for key in found.videos:
                    _usable(root, found.video_file(rows[e], key), suspect)
            except _Unusable as exc:
                found.dropped[e] = str(exc)
                continue
            found.intact[e] = rows[e]
    return found


def repair_dataset(src: Path, out: Path, repo_id: str, suspect: Collection[str] = (), progress: bool = True) -> dict:
    """Write the intact episodes of the dataset at ``src`` into the new folder ``out``; a summary, with why each
    dropped episode was dropped. A dataset with nothing intact is a one-line error."""
    t0 = time.perf_counter()
    found = survey(src, suspect)  # no refusal of a dataset that checks out: a video cut short only shows decoding
    if not found.intact:
        raise _nothing_intact(src, found)
    keys = {e: episode_key(row) for e, row in found.intact.items()}
    try:
        records = {int(r["episode_index"]): r for r in read_sidecar(src, keys, among=keys)}
    except (OSError, ValueError) as exc:  # a damaged sidecar costs the records, not the episodes
        print(f"warning: cannot read the episode records of {src} ({one_line(exc)}): not carried", file=sys.stderr)
        records = {}
    spec = DatasetSpec(repo_id, found.info["fps"], found.info["features"], found.info.get("robot_type"), found.tasks)
    kept: list[int] = []
    new_records: list[dict] = []

    def takes() -> Iterator[Take]:
        for e, take in _takes(src, found):  # drops what fails to read into found.dropped
            if e in records:
                new_records.append({**records[e], "episode_index": len(kept), "repaired_from": e})
            kept.append(e)
            yield take

    total = sum(row["length"] for row in found.intact.values())
    write_episodes(out, spec, takes(), total=total, progress=progress)
    if not kept:  # every one failed to read (the caller removes the empty dataset)
        raise _nothing_intact(src, found)
    write_meta(src, out, new_records)
    return {
        "source": str(src),
        "out": str(out),
        "episodes": len(kept),
        "frames": int(sum(found.intact[e]["length"] for e in kept)),
        "source_episodes": len(kept) + len(found.dropped),
        "dropped": {str(e): why for e, why in sorted(found.dropped.items())},
        "episode_map": {str(e): j for j, e in enumerate(kept)},
        "records_carried": len(new_records),
        "wall_s": round(time.perf_counter() - t0, 2),
    }


def _nothing_intact(src: Path, found: Survey) -> GloverecError:
    e, why = min(found.dropped.items())
    return GloverecError(f"no episode of {src} is intact: nothing to rescue (episode {e}: {why})")


def _takes(root: Path, found: Survey) -> Iterator[tuple[int, Take]]:
    """(source index, its frames) of each intact episode that reads; one that does not goes to ``found.dropped``
    before anything of it is written."""
    table = functools.lru_cache(maxsize=1)(lambda rel: _parquet(root, rel, ()))  # files in order: each read once
    for e, row in list(found.intact.items()):
        rel = found.data_file(row)
        try:
            rows = table(rel).filter(pc.equal(table(rel)["episode_index"], e)).to_pydict()
            if rows["frame_index"] != list(range(row["length"])):
                raise _Unusable(f"{rel} does not hold its frames in order")
            frames = _frames(root, found, row, rows)
        except _Unusable as exc:
            found.dropped[e] = str(exc)
            del found.intact[e]
            continue
        yield e, Take(rows, frames)


def _frames(root: Path, found: Survey, row: dict, rows: dict):
    """``Take.frames`` of one episode: its videos decoded whole, its parquet images read (None: no camera)."""
    from lerobot.datasets.video_utils import decode_video_frames  # torch: not at start-up
    from PIL import Image

    cameras = {}
    for key in found.videos:
        rel = found.video_file(row, key)
        times = [row[f"videos/{key}/from_timestamp"] + t for t in rows["timestamp"]]
        try:
            video = decode_video_frames(root / rel, times, TOLERANCE_S, video_backend(), return_uint8=True)
        except Exception as exc:  # noqa: BLE001  (each decoder fails its own way: a video cut short, a lost frame)
            raise _Unusable(f"{rel} does not decode this episode's frames ({one_line(exc)})") from None
        cameras[key] = video.permute(0, 2, 3, 1).numpy()  # (N, C, H, W) -> (N, H, W, C)
    images = [k for k, v in found.info["features"].items() if v.get("dtype") == "image"]
    if not cameras and not images:
        return None

    def frame(j: int) -> dict[str, np.ndarray]:
        out = {key: video[j] for key, video in cameras.items()}
        for key in images:  # stored in the parquet file as encoded bytes
            out[key] = np.asarray(Image.open(io.BytesIO(rows[key][j]["bytes"])).convert("RGB"))
        return out

    return frame


def _usable(root: Path, rel: str, suspect: Collection[str]) -> Path:
    if rel in suspect:
        raise _Unusable(f"{rel} differs from the hub's manifest")
    if not (root / rel).is_file():
        raise _Unusable(f"{rel} is missing")
    return root / rel


def _parquet(root: Path, rel: str, suspect: Collection[str], columns: list[str] | None = None) -> pa.Table:
    path = _usable(root, rel, suspect)
    try:
        return pq.ParquetFile(path).read(columns=columns)
    except (OSError, pa.ArrowException) as exc:
        raise _Unusable(f"{rel} is not a readable parquet file ({one_line(exc)})") from None
