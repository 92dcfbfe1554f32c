"""Is a folder a sound LeRobot v3.0 dataset? Checked before anything enters the hub.

Every parquet file must open with pyarrow (a file cut before its footer does not), and the counts in
``meta/info.json`` must agree with the episode metadata and with the data: what `LeRobotDataset` needs to load it.
"""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from recorder import GloverecError, one_line

CODEBASE_VERSION = "v3.0"
INFO = "meta/info.json"
TASKS = "meta/tasks.parquet"
EPISODES_DIR = "meta/episodes"
REPAIR = "`gloverec repair` rescues its intact episodes"
_INFO_KEYS = {
    "fps": int,
    "total_episodes": int,
    "total_frames": int,
    "total_tasks": int,
    "features": dict,
    "data_path": str,
}
_EPISODE_COLUMNS = [
    "episode_index",
    "length",
    "data/chunk_index",
    "data/file_index",
    "dataset_from_index",
    "dataset_to_index",
]


class _Damaged(Exception):
    """What is wrong with the dataset, without its name (``check_dataset`` adds it)."""


class _Unsupported(_Damaged):
    """A sound dataset of a layout the hub does not take."""


def looks_like_dataset(root: Path) -> None:
    """The cheap test, before copying anything: a directory with ``meta/info.json``."""
    if not root.is_dir():
        raise GloverecError(f"{root} is not a directory")
    if not (root / INFO).is_file():
        raise GloverecError(f"{root} is not a LeRobot dataset: no {INFO}")


def check_dataset(root: Path, shown_as: str | Path | None = None) -> dict:
    """Raise GloverecError unless ``root`` holds a complete, consistent dataset; return its ``meta/info.json``.
    Messages name the folder ``shown_as`` (e.g. the folder a staging copy was made from), else ``root``."""
    info = read_info(root, shown_as)
    try:
        _check(root, info)
    except _Damaged as exc:  # past a sound info.json: what `gloverec repair` reads around
        raise GloverecError(f"{shown_as or root} is a damaged LeRobot dataset: {exc}; {REPAIR}") from None
    return info


def read_info(root: Path, shown_as: str | Path | None = None) -> dict:
    """``meta/info.json`` of the dataset at ``root``, its keys checked; one-line GloverecErrors as above."""
    looks_like_dataset(root)
    try:
        return _read_info(root)
    except _Unsupported as exc:
        raise GloverecError(f"{shown_as or root} {exc}") from None
    except _Damaged as exc:
        raise GloverecError(f"{shown_as or root} is a damaged LeRobot dataset: {exc}") from None


def _check(root: Path, info: dict) -> None:
    rows = {p.relative_to(root).as_posix(): _num_rows(p, root) for p in sorted(root.rglob("*.parquet"))}
    if TASKS not in rows:
        raise _Damaged(f"no {TASKS}")
    if rows[TASKS] != info["total_tasks"]:
        raise _Damaged(f"{TASKS} has {rows[TASKS]} tasks, {INFO} says {info['total_tasks']}")
    if info["total_episodes"] < 1:
        raise _Damaged("it has no episodes")
    episodes = _read_episodes(root, sorted(p for p in rows if p.startswith(EPISODES_DIR + "/")))
    if sorted(episodes["episode_index"]) != list(range(info["total_episodes"])):
        raise _Damaged(
            f"{EPISODES_DIR} does not list episodes 0..{info['total_episodes'] - 1} as {INFO} says "
            f"({len(episodes['episode_index'])} rows)"
        )
    if sum(episodes["length"]) != info["total_frames"]:
        raise _Damaged(
            f"the episode lengths add up to {sum(episodes['length'])} frames, {INFO} says {info['total_frames']}"
        )
    data_rows = sum(n for p, n in rows.items() if p.startswith("data/"))
    if data_rows != info["total_frames"]:
        raise _Damaged(f"data/ holds {data_rows} frames, {INFO} says {info['total_frames']}")
    for needed in sorted(_referenced_files(info, episodes)):
        if not (root / needed).is_file():
            raise _Damaged(f"{needed} is missing (an episode points to it)")


def _read_info(root: Path) -> dict:
    try:
        info = json.loads((root / INFO).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _Damaged(f"cannot read {INFO} ({one_line(exc)})") from None
    if not isinstance(info, dict):
        raise _Damaged(f"{INFO} is not a JSON object")
    if info.get("codebase_version") != CODEBASE_VERSION:
        raise _Unsupported(
            f"is a LeRobot {info.get('codebase_version')!r} dataset; the hub takes {CODEBASE_VERSION} "
            "(convert it with lerobot's conversion script)"
        )
    for key, kind in _INFO_KEYS.items():
        if not isinstance(info.get(key), kind) or isinstance(info.get(key), bool):
            raise _Damaged(f"{INFO} has no valid {key!r}")
    return info


def _num_rows(path: Path, root: Path) -> int:
    try:
        return pq.ParquetFile(path).metadata.num_rows
    except (OSError, pa.ArrowException) as exc:
        raise _Damaged(f"{path.relative_to(root)} is not a readable parquet file ({one_line(exc)})") from None


def _read_episodes(root: Path, files: list[str]) -> dict[str, list]:
    """The episode metadata columns that locate each episode's frames and files, from every file in order."""
    if not files:
        raise _Damaged(f"no {EPISODES_DIR}/*/*.parquet")
    columns: dict[str, list] = {}
    for rel in files:
        try:
            names = set(pq.ParquetFile(root / rel).schema_arrow.names)
            missing = [c for c in _EPISODE_COLUMNS if c not in names]
            if missing:
                raise _Damaged(f"{rel} has no column {missing[0]!r}")
            videos = sorted(n for n in names if n.startswith("videos/") and n.endswith("_index"))
            table = pq.read_table(root / rel, columns=_EPISODE_COLUMNS + videos)
        except (OSError, pa.ArrowException) as exc:
            raise _Damaged(f"cannot read {rel} ({one_line(exc)})") from None
        for name in table.column_names:
            columns.setdefault(name, []).extend(table.column(name).to_pylist())
    for name, values in columns.items():
        if len(values) != len(columns["episode_index"]):
            raise _Damaged(f"column {name!r} is missing from some of {EPISODES_DIR}")
    spans = zip(
        columns["episode_index"],
        columns["dataset_from_index"],
        columns["dataset_to_index"],
        columns["length"],
        strict=True,
    )
    for episode, start, stop, length in spans:
        if stop - start != length:
            raise _Damaged(f"episode {episode} spans frames {start}..{stop} but has length {length}")
    return columns


def _referenced_files(info: dict, episodes: dict[str, list]) -> set[str]:
    """The data and video files that the episode metadata points to."""
    needed = {
        info["data_path"].format(chunk_index=c, file_index=f)
        for c, f in zip(episodes["data/chunk_index"], episodes["data/file_index"], strict=True)
    }
    video_path = info.get("video_path")
    for key, feature in info["features"].items():
        if isinstance(feature, dict) and feature.get("dtype") == "video" and video_path:
            chunks = episodes.get(f"videos/{key}/chunk_index")
            files = episodes.get(f"videos/{key}/file_index")
            if chunks is None or files is None:
                raise _Damaged(f"the episode metadata does not locate the videos of {key!r}")
            needed |= {
                video_path.format(video_key=key, chunk_index=c, file_index=f)
                for c, f in zip(chunks, files, strict=True)
            }
    return needed
