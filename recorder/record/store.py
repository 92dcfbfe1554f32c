"""Crash-safe LeRobot datasets: every saved episode survives SIGKILL or power loss, at any moment.

LeRobot (0.4.4, and 0.6 still: bench/kill_anchor.py) keeps its parquet writers open across episodes and writes their
footers only in ``finalize()``, so a crash can leave a dataset that no longer loads. Here lerobot writes into a
private working copy, configured so that every episode gets its own data, episode-metadata and video files; after
each episode the writers are closed (footers written) and the working copy is *published* as an immutable snapshot,
and the dataset root is switched to it with one atomic rename:

    ROOT                                   -> .ROOT.gloverec/snapshots/000012   (a symlink)
    .ROOT.gloverec/work/                   lerobot's working copy (may hold the episode in progress)
    .ROOT.gloverec/snapshots/000012/       a complete dataset: LeRobotDataset(repo_id, root=ROOT) loads it

A snapshot hard-links the per-episode files (never modified once closed) and copies the small files lerobot
rewrites in place (info.json, stats.json, tasks.parquet, our episode sidecar). Everything is fsynced before
the switch. At any instant ROOT is a complete dataset; only the episode in progress can be lost. ``resume``
rebuilds the working copy from the last snapshot, discarding whatever the interrupted session left.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import time
from pathlib import Path

from recorder import GloverecError
from recorder.dataset_check import check_dataset
from recorder.record.sidecar import append_sidecar

STATE_SUFFIX = ".gloverec"
IMMUTABLE = ("data/", "meta/episodes/", "videos/", "logs/")  # never rewritten once closed (session logs: only
# appended, so a snapshot's hard link sees the ranges of its episodes and, later, more). The live session log is
# not fsynced at each publish (an fsync of a file being written stalls the glove reader's writes to it for tens
# of milliseconds); the logger fsyncs it when the session ends, and a log cut short by power loss still reads.
TRANSIENT = ("images/",)  # lerobot's temporary PNGs for video encoding
KEEP_SNAPSHOTS = 2
LOCK_WAIT_S = 10.0  # how long a session waits for another one (e.g. the writer of a killed one) to finish
IMAGE_THREADS = 1  # LeRobot's PNG writer threads per camera beside the recording loop (write_images_beside)
TINY_MB = 1e-6  # lerobot file-size limit in the working copy: forces one file per episode


def state_dir(root: Path) -> Path:
    return root.parent / f".{root.name}{STATE_SUFFIX}"


def check_root(root: str | Path, resume: bool) -> None:
    """What the store refuses, checked before LeRobot loads (seconds): ``root`` there without ``resume``, a folder
    that is not a gloverec recording, a damaged one to resume. One-line GloverecError."""
    path = Path(root).absolute()
    exists = path.exists() or path.is_symlink()
    if exists and not resume:
        raise GloverecError(f"{root} already exists: pass --resume to add episodes, or choose another --root")
    if exists and not (path.is_symlink() and state_dir(path).is_dir()):
        raise GloverecError(f"{root} is not a gloverec recording (no {state_dir(path).name}/): cannot resume it")
    if exists and path.resolve().is_dir():
        check_dataset(path)


def lerobot_save_speedups(features: dict):
    """recorder/record/episode_stats.py's, which imports LeRobot: loaded when the first episode is saved."""
    from recorder.record.episode_stats import lerobot_save_speedups as speedups

    return speedups(features)


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


def _clone(src: Path, dst: Path, published_info: bool, durable: set | None = None) -> None:
    """Copy a dataset tree: hard links for immutable per-episode files, real copies for the rest; everything
    fsynced except the linked files named in ``durable`` (synced by an earlier clone; new ones are added)."""
    from lerobot.datasets.utils import DEFAULT_DATA_FILE_SIZE_IN_MB, DEFAULT_VIDEO_FILE_SIZE_IN_MB

    durable = set() if durable is None else durable
    dst.mkdir(parents=True)
    for rel, p in _files(src):
        out = dst / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        if rel.startswith(IMMUTABLE):
            os.link(p, out)
        elif published_info and rel == "meta/info.json":
            info = json.loads(p.read_text())  # the working copy's tiny file limits are not for readers
            info["data_files_size_in_mb"] = DEFAULT_DATA_FILE_SIZE_IN_MB
            info["video_files_size_in_mb"] = DEFAULT_VIDEO_FILE_SIZE_IN_MB
            out.write_text(json.dumps(info, indent=4))
        else:
            shutil.copyfile(p, out)
        if rel not in durable and not rel.startswith("logs/"):
            _fsync(out)
            if rel.startswith(IMMUTABLE):
                durable.add(rel)
    for d in sorted({*dst.rglob("*")} | {dst}, key=lambda q: -len(q.parts)):
        if d.is_dir():
            _fsync(d)


def _lock(path: Path, root) -> int:
    """One session at a time per dataset: an flock held while the store is open. A writer process forked
    from the session inherits it, so a session killed while its writer still saves keeps the dataset locked
    until the writer is done; the kernel releases it however the processes end."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    end = time.monotonic() + LOCK_WAIT_S
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            if _same_file(fd, path):
                return fd
            os.close(fd)  # the session it waited for removed the state directory (it saved nothing): lock anew
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except BlockingIOError:
            if time.monotonic() > end:
                os.close(fd)
                raise GloverecError(f"{root} is in use by another gloverec session") from None
            time.sleep(0.05)


def _same_file(fd: int, path: Path) -> bool:
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except FileNotFoundError:
        return False


class EpisodeStore:
    """Owns ROOT and its state directory. ``dataset`` is the lerobot LeRobotDataset being written."""

    def __init__(
        self,
        root: str | Path,
        repo_id: str,
        fps: int,
        features: dict,
        robot_type: str,
        resume: bool = False,
        use_videos: bool = True,
    ):
        import datasets  # with LeRobot: loaded when a store opens, after the checks (check_root)

        datasets.disable_progress_bars()  # one "Map" bar per episode says nothing to a person recording
        self.root = Path(root).absolute()
        self.state = state_dir(self.root)
        self.work = self.state / "work"
        self.snapshots = self.state / "snapshots"
        self._durable: set[str] = set()  # linked files already fsynced (by an earlier publish)
        exists = self.root.exists() or self.root.is_symlink()
        if exists and not resume:
            raise GloverecError(f"{root} already exists: pass --resume to add episodes, or choose another --root")
        if exists and not self._ours():
            raise GloverecError(f"{root} is not a gloverec recording (no {self.state.name}/): cannot resume it")
        self._fresh = not exists  # ROOT is this session's to make: nothing is there before it publishes
        self.state.mkdir(parents=True, exist_ok=True)
        self._lock = _lock(self.state / "lock", root)
        try:
            self._open(repo_id, fps, features, robot_type, resume, use_videos)
        except BaseException:
            self._unlock(discard_empty=True)
            raise

    def _open(self, repo_id, fps, features, robot_type, resume, use_videos) -> None:
        from lerobot.datasets.lerobot_dataset import LeRobotDataset  # torch and LeRobot (seconds): not at start-up

        from recorder.video_backend import video_backend

        if not resume and (self.root.exists() or self.root.is_symlink()):  # appeared while we waited
            raise GloverecError(f"{self.root} already exists: pass --resume to add episodes, or choose another --root")
        if resume and self._latest() is not None:
            check_dataset(self.root)  # a damaged recording: one line, before lerobot reads it or anything changes
            shutil.rmtree(self.work, ignore_errors=True)  # what the interrupted session left
            _clone(self._latest(), self.work, published_info=False)
            self.dataset = LeRobotDataset.resume(repo_id, root=self.work, video_backend=video_backend())
            self._check_compatible(fps, features, robot_type)
        else:
            shutil.rmtree(self.work, ignore_errors=True)
            self.snapshots.mkdir(parents=True, exist_ok=True)
            self.dataset = LeRobotDataset.create(
                repo_id,
                fps,
                features,
                root=self.work,
                robot_type=robot_type,
                use_videos=use_videos,
                metadata_buffer_size=1,
                video_backend=video_backend(),
            )
        self.dataset.meta.update_chunk_settings(data_files_size_in_mb=TINY_MB, video_files_size_in_mb=TINY_MB)
        self.writer = self.dataset.writer  # lerobot's DatasetWriter: the episode buffer and the parquet writer

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
            raise GloverecError(
                f"cannot resume: the dataset was recorded with robot {meta.robot_type!r}, not {robot_type!r}"
            )
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
    @property
    def next_index(self) -> int:
        """The index of the episode being filled (ahead of ``num_episodes`` while a writer process saves)."""
        buffer = self.writer.episode_buffer
        return self.num_episodes if buffer is None else int(buffer["episode_index"])

    def add_frame(self, frame: dict) -> None:
        self.dataset.add_frame(frame)

    def write_images_beside(self) -> None:
        """Camera frames written to their PNG files by LeRobot's image writer threads (IMAGE_THREADS per camera),
        beside the loop instead of in ``add_frame`` (the PNG compression took 1.3 ms of a 128 px camera frame in the
        loop). Started in the recording process once the writer process is forked (a fork has no threads: its store
        writes nothing but whole episodes); ``take_episode`` waits for the episode's files."""
        cameras = len(self.dataset.meta.camera_keys)
        if cameras and self.writer.image_writer is None:
            self.writer.start_image_writer(num_processes=0, num_threads=IMAGE_THREADS * cameras)

    def discard_episode(self) -> None:
        """Drop the frames of the episode in progress (re-record, or a glove that vanished)."""
        index = self.next_index
        self.dataset.clear_episode_buffer()  # and the frames of its cameras
        self.writer.episode_buffer = self.writer._create_episode_buffer(episode_index=index)

    def take_episode(self) -> dict:
        """Hand over the episode in progress (to ``save_episode`` in a writer process) and start the next."""
        self.writer._wait_image_writer()  # the episode's camera frames are all in their files
        episode = self.writer.episode_buffer
        self.writer.episode_buffer = self.writer._create_episode_buffer(episode_index=int(episode["episode_index"]) + 1)
        return episode

    def save_episode(self, sidecar: dict, episode: dict | None = None) -> int:
        """Write the episode in progress (or ``episode``, from ``take_episode``) and publish the dataset with
        it. Returns its index."""
        ds = self.dataset
        index = ds.meta.total_episodes
        with lerobot_save_speedups(ds.features):
            ds.save_episode(episode_data=episode)
        self.writer.close_writer()  # footers: the episode's parquet files are complete and never reopened
        ds.meta._close_writer()
        append_sidecar(self.work, index, sidecar)
        self.publish()
        return index

    def publish(self) -> Path:
        """Snapshot the working copy and switch ROOT to it atomically."""
        n = 1 + max((int(p.name) for p in self.snapshots.iterdir() if p.name.isdigit()), default=-1)
        final = self.snapshots / f"{n:06d}"
        tmp = self.snapshots / f".{n:06d}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        _clone(self.work, tmp, published_info=True, durable=self._durable)
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

    def close(self, discard_empty: bool = True) -> None:
        """End the session: drop an unsaved episode; the published snapshot is the dataset. ``discard_empty``:
        remove the state directory of a new dataset in which nothing was published (pass False while a writer
        process forked from here may still publish)."""
        if self.writer.episode_buffer and self.writer.episode_buffer.get("size"):
            self.discard_episode()
        self.writer.stop_image_writer()
        self.writer.close_writer()
        self.dataset.meta._close_writer()
        self._unlock(discard_empty)

    def _unlock(self, discard_empty: bool) -> None:
        if self._lock is None:
            return
        snapshots = self.snapshots.iterdir() if self.snapshots.is_dir() else ()
        published = self._latest() is not None or any(p.name.isdigit() for p in snapshots)
        if discard_empty and self._fresh and not published:
            # a session that saved nothing (a glove that did not open, a stop before the first save) leaves no
            # ROOT; its hidden .ROOT.gloverec/ would only hold an empty working copy (and the session log of no
            # episode). Removed while locked: a session waiting for the lock sees it gone and makes its own.
            shutil.rmtree(self.state, ignore_errors=True)
        os.close(self._lock)  # a writer process forked from here holds it until it exits too
        self._lock = None
