"""Crash-safe LeRobot datasets: every saved episode survives SIGKILL or power loss, at any moment.

LeRobot 0.4.4 keeps its parquet writers open across episodes and writes their footers only in
``finalize()``, so a crash can leave a dataset that no longer loads. Here lerobot writes into a private
working copy, configured so that every episode gets its own data, episode-metadata and video files; after
each episode the writers are closed (footers written) and the working copy is *published* as an immutable
snapshot, and the dataset root is switched to it with one atomic rename:

    ROOT                                   -> .ROOT.gloverec/snapshots/000012   (a symlink)
    .ROOT.gloverec/work/                   lerobot's working copy (may hold the episode in progress)
    .ROOT.gloverec/snapshots/000012/       a complete dataset: LeRobotDataset(repo_id, root=ROOT) loads it

A snapshot hard-links the per-episode files (never modified once closed) and copies the small files lerobot
rewrites in place (info.json, stats.json, tasks.parquet, our episode sidecar). Everything is fsynced before
the switch. At any instant ROOT is a complete dataset; only the episode in progress can be lost. ``resume``
rebuilds the working copy from the last snapshot, discarding whatever the interrupted session left.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from recorder import GloverecError

STATE_SUFFIX = ".gloverec"
SIDECAR = "meta/gloverec/episodes.jsonl"   # our per-episode metadata, one JSON object per line
IMMUTABLE = ("data/", "meta/episodes/", "videos/")   # files there never change once their episode is closed
TRANSIENT = ("images/",)                   # lerobot's temporary PNGs for video encoding
KEEP_SNAPSHOTS = 2
TINY_MB = 1e-6   # lerobot file-size limit in the working copy: forces one file per episode


def state_dir(root: Path) -> Path:
    return root.parent / f".{root.name}{STATE_SUFFIX}"


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _files(base: Path):
    for p in sorted(base.rglob("*")):
        rel = p.relative_to(base).as_posix()
        if p.is_file() and not rel.startswith(TRANSIENT):
            yield rel, p


def _clone(src: Path, dst: Path, published_info: bool) -> None:
    """Copy a dataset tree: hard links for immutable per-episode files, real copies for the rest."""
    dst.mkdir(parents=True)
    for rel, p in _files(src):
        out = dst / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        if rel.startswith(IMMUTABLE):
            os.link(p, out)
        elif published_info and rel == "meta/info.json":
            from lerobot.datasets.utils import DEFAULT_DATA_FILE_SIZE_IN_MB, DEFAULT_VIDEO_FILE_SIZE_IN_MB

            info = json.loads(p.read_text())   # the working copy's tiny file limits are not for readers
            info["data_files_size_in_mb"] = DEFAULT_DATA_FILE_SIZE_IN_MB
            info["video_files_size_in_mb"] = DEFAULT_VIDEO_FILE_SIZE_IN_MB
            out.write_text(json.dumps(info, indent=4))
        else:
            shutil.copyfile(p, out)
        if not rel.startswith(IMMUTABLE):
            _fsync(out)
    for d in sorted({*dst.rglob("*")} | {dst}, key=lambda q: -len(q.parts)):
        if d.is_dir():
            _fsync(d)


class EpisodeStore:
    """Owns ROOT and its state directory. ``dataset`` is the lerobot LeRobotDataset being written."""

    def __init__(self, root: str | Path, repo_id: str, fps: int, features: dict, robot_type: str,
                 resume: bool = False, use_videos: bool = True):
        import datasets
        from lerobot.datasets.lerobot_dataset import LeRobotDataset

        datasets.disable_progress_bars()  # one "Map" bar per episode says nothing to a person recording
        self.root = Path(root).absolute()
        self.state = state_dir(self.root)
        self.work = self.state / "work"
        self.snapshots = self.state / "snapshots"
        exists = self.root.exists() or self.root.is_symlink()
        if exists and not resume:
            raise GloverecError(f"{root} already exists: pass --resume to add episodes, or choose another --root")
        if exists and not self._ours():
            raise GloverecError(f"{root} is not a gloverec recording (no {self.state.name}/): cannot resume it")
        if resume and self._latest() is not None:
            shutil.rmtree(self.work, ignore_errors=True)          # what the interrupted session left
            _clone(self._latest(), self.work, published_info=False)
            self.dataset = LeRobotDataset(repo_id, root=self.work)
            self._check_compatible(fps, features, robot_type)
        else:
            shutil.rmtree(self.work, ignore_errors=True)
            self.snapshots.mkdir(parents=True, exist_ok=True)
            self.dataset = LeRobotDataset.create(repo_id, fps, features, root=self.work, robot_type=robot_type,
                                                 use_videos=use_videos, metadata_buffer_size=1)
        self.dataset.meta.update_chunk_settings(data_files_size_in_mb=TINY_MB, video_files_size_in_mb=TINY_MB)

    # ------------------------------------------------------------------ state
    def _ours(self) -> bool:
        return self.root.is_symlink() and self.state.is_dir()

    def _latest(self) -> Path | None:
        if not self.root.is_symlink():
            return None
        target = (self.root.parent / os.readlink(self.root)).resolve()
        return target if target.is_dir() else None

    def _check_compatible(self, fps: int, features: dict, robot_type: str) -> None:
        meta = self.dataset.meta
        if meta.fps != fps:
            raise GloverecError(f"cannot resume: the dataset is {meta.fps} fps, not {fps}")
        if meta.robot_type != robot_type:
            raise GloverecError(f"cannot resume: the dataset was recorded with robot {meta.robot_type!r}, "
                                f"not {robot_type!r}")
        mine = {k: (v["dtype"], tuple(v["shape"])) for k, v in features.items()}
        theirs = {k: (v["dtype"], tuple(v["shape"])) for k, v in meta.features.items() if k in mine}
        if mine != theirs:
            diff = sorted(k for k in mine if mine[k] != theirs.get(k))
            raise GloverecError(f"cannot resume: features differ from the dataset's ({', '.join(diff)})")

    @property
    def num_episodes(self) -> int:
        return self.dataset.meta.total_episodes

    @property
    def num_frames(self) -> int:
        return self.dataset.meta.total_frames

    # ------------------------------------------------------------------ writing
    def add_frame(self, frame: dict) -> None:
        self.dataset.add_frame(frame)

    def discard_episode(self) -> None:
        """Drop the frames of the episode in progress (re-record, or a glove that vanished)."""
        self.dataset.clear_episode_buffer()

    def save_episode(self, sidecar: dict) -> int:
        """Write the episode in progress and publish the dataset with it. Returns its index."""
        ds = self.dataset
        index = ds.meta.total_episodes
        ds.save_episode()
        ds._close_writer()        # footers: the episode's parquet files are complete and never reopened
        ds.meta._close_writer()
        ds._writer_closed_for_reading = True
        side = self.work / SIDECAR
        side.parent.mkdir(parents=True, exist_ok=True)
        with side.open("a") as f:
            f.write(json.dumps({"episode_index": index, **sidecar}) + "\n")
        self.publish()
        return index

    def publish(self) -> Path:
        """Snapshot the working copy and switch ROOT to it atomically."""
        n = 1 + max((int(p.name) for p in self.snapshots.iterdir() if p.name.isdigit()), default=-1)
        final = self.snapshots / f"{n:06d}"
        tmp = self.snapshots / f".{n:06d}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        _clone(self.work, tmp, published_info=True)
        os.rename(tmp, final)
        link = self.root.parent / f".{self.root.name}.link.tmp"
        if link.is_symlink():
            link.unlink()
        os.symlink(os.path.relpath(final, self.root.parent), link)
        os.replace(link, self.root)
        _fsync(self.snapshots)
        _fsync(self.root.parent)
        for old in sorted(p for p in self.snapshots.iterdir() if p.name.isdigit())[:-KEEP_SNAPSHOTS]:
            shutil.rmtree(old, ignore_errors=True)
        for stale in self.snapshots.glob(".*.tmp"):
            shutil.rmtree(stale, ignore_errors=True)
        return final

    def close(self) -> None:
        """End the session: drop an unsaved episode; the published snapshot is the dataset."""
        if self.dataset.episode_buffer and self.dataset.episode_buffer.get("size"):
            self.discard_episode()
        self.dataset._close_writer()
        self.dataset.meta._close_writer()


def read_sidecar(root: str | Path) -> list[dict]:
    """Our per-episode metadata of a dataset (empty when it has none)."""
    path = Path(root) / SIDECAR
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
