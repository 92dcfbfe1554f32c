"""The frame cache on disk: FrameCache's columns (policies/data.py) written once, row by row, to flat files beside
the dataset, and read back a batch at a time. For datasets whose decoded frames do not fit in memory.

    ROOT/.cache/frames/KEY/columns.json      each column's file, dtype and row shape; written last
    ROOT/.cache/frames/KEY/<n>.bin           one column, rows back to back (images as uint8)

KEY hashes what the cache holds (episodes, features, delta timestamps, the dataset's files' sizes and times), so a
changed dataset or another policy's windows build another folder. A cache is built in ``KEY.partial-PID`` and renamed
to KEY when complete: a crash mid-write leaves only a partial folder, never served and removed by the next build.
A read-only dataset keeps its cache under $GLOVEREC_CACHE/frames (recorder/paths.py cache_dir) instead.

Rows are read with ``os.preadv`` into a fresh batch, not through a memory map: pages of a map that training has
touched count in the process's resident memory, so its peak would grow with the dataset; read this way they stay in
the kernel's page cache, which is shared and given back under pressure. ``.cache`` is a hidden top-level entry,
which `gloverec push` leaves out (recorder/hub/manifest.py).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from recorder.paths import cache_dir

FORMAT = 1  # bumped when the layout changes: older caches are then simply not found
MANIFEST = "columns.json"
MEMORY_SHARE = 0.5  # auto: on disk when the decoded frames would take more than this share of the available memory
_BLOCK = 4096  # rows per read when a whole column is scanned (statistics)


@dataclass
class DiskColumn:
    """One column of a frame cache on disk: rows of shape ``row`` and ``dtype``, in one file per part (several after
    FrameCache.join)."""

    dtype: np.dtype
    row: tuple[int, ...]
    parts: list[tuple[Path, int]] = field(default_factory=list)  # (file, rows)

    def __post_init__(self):
        self._starts = np.cumsum([0] + [n for _, n in self.parts])
        self._fds: list[int] = []

    @property
    def row_bytes(self) -> int:
        return int(np.dtype(self.dtype).itemsize * math.prod(self.row))

    @property
    def shape(self) -> tuple[int, ...]:
        return (len(self), *self.row)

    def __len__(self) -> int:
        return int(self._starts[-1])

    def take(self, indices) -> torch.Tensor:
        """The rows at ``indices`` (any order, repeats allowed) as a new tensor."""
        idx = np.asarray(indices, dtype=np.int64)
        out = np.empty((len(idx), *self.row), dtype=self.dtype)
        if not self._fds:  # opened on first use, kept open: a batch is one preadv per row, no open/close
            self._fds = [os.open(p, os.O_RDONLY) for p, _ in self.parts]
            weakref.finalize(self, _close, self._fds)
        part = np.searchsorted(self._starts, idx, side="right") - 1
        flat = out.reshape(len(idx), -1).view(np.uint8)
        for j, (i, p) in enumerate(zip(idx.tolist(), part.tolist())):
            os.preadv(self._fds[p], [flat[j]], (i - int(self._starts[p])) * self.row_bytes)
        return torch.from_numpy(out)

    def rows(self, start: int, stop: int) -> torch.Tensor:
        return self.take(np.arange(start, stop))

    @classmethod
    def join(cls, columns: list[DiskColumn]) -> DiskColumn:
        return cls(columns[0].dtype, columns[0].row, [p for c in columns for p in c.parts])


def _close(fds: list[int]) -> None:
    for fd in fds:
        os.close(fd)


def take(column, indices: torch.Tensor) -> torch.Tensor:
    """Rows of a column in memory (a tensor) or on disk alike."""
    return column[indices] if torch.is_tensor(column) else column.take(indices)


def scan(column, pick) -> torch.Tensor:
    """``pick(rows)`` of every row, a block at a time: a whole column on disk is never read into memory at once."""
    if torch.is_tensor(column):
        return pick(column)
    return torch.cat([pick(column.rows(a, min(a + _BLOCK, len(column)))) for a in range(0, len(column), _BLOCK)])


class DiskWriter:
    """Columns appended a row at a time to files in a partial folder; ``finish`` writes the manifest and renames
    the folder to its key (the one step that makes the cache visible). A row's dtype and shape are its column's
    first row's."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.partial = folder.with_name(f"{folder.name}.partial-{os.getpid()}")
        _remove_stale_partials(folder)
        if folder.is_dir() and not (folder / MANIFEST).exists():  # not one of ours (those are complete when named)
            shutil.rmtree(folder)
        self.partial.mkdir(parents=True)
        self._files: dict[str, object] = {}
        self._columns: dict[str, dict] = {}

    def add(self, key: str, value: torch.Tensor | np.ndarray) -> None:
        a = np.ascontiguousarray(value.numpy() if torch.is_tensor(value) else value)
        if key not in self._files:
            name = f"{len(self._files)}.bin"
            self._files[key] = open(self.partial / name, "wb")  # noqa: SIM115  (closed in finish)
            self._columns[key] = {"file": name, "dtype": a.dtype.str, "shape": list(a.shape), "rows": 0}
        self._files[key].write(a.tobytes())
        self._columns[key]["rows"] += 1

    def finish(self, extra: dict) -> dict[str, DiskColumn]:
        for f in self._files.values():
            f.close()
        (self.partial / MANIFEST).write_text(json.dumps({"format": FORMAT, "columns": self._columns, **extra}))
        try:
            self.partial.rename(self.folder)
        except OSError:  # another process finished the same cache first: theirs is as good
            shutil.rmtree(self.partial, ignore_errors=True)
        return read(self.folder)[0]

    def abandon(self) -> None:
        for f in self._files.values():
            f.close()
        shutil.rmtree(self.partial, ignore_errors=True)


def read(folder: Path) -> tuple[dict[str, DiskColumn], dict] | None:
    """A complete cache's columns and its manifest's other entries; None when there is none (or only a partial one)."""
    try:
        manifest = json.loads((folder / MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    columns = {
        k: DiskColumn(np.dtype(c["dtype"]), tuple(c["shape"]), [(folder / c["file"], c["rows"])])
        for k, c in manifest.pop("columns").items()
    }
    return columns, manifest


def folder_for(root: Path, what: dict) -> Path:
    """The cache folder of ``what`` (episodes, features, deltas) for the dataset at ``root``: beside it, or under
    cache_dir() when the dataset's folder cannot be written."""
    key = hashlib.sha256(json.dumps({"format": FORMAT, **what, "files": _fingerprint(root)}, sort_keys=True,
                                    default=str).encode()).hexdigest()[:20]  # fmt: skip
    beside = Path(root) / ".cache" / "frames"
    try:
        beside.mkdir(parents=True, exist_ok=True)
        if os.access(beside, os.W_OK):
            return beside / key
    except OSError:
        pass
    return cache_dir() / "frames" / key


def _fingerprint(root: Path) -> list:
    """The dataset's files (hidden ones left out: the cache is one) by size and modification time."""
    out = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            st = os.stat(os.path.join(folder, f))
            out.append([os.path.relpath(os.path.join(folder, f), root), st.st_size, st.st_mtime_ns])
    return out


def _remove_stale_partials(folder: Path) -> None:
    """Partial folders of ``folder`` left by a process that is gone (a crash, a kill): never complete, never read."""
    for p in folder.parent.glob(f"{folder.name}.partial-*"):
        try:
            os.kill(int(p.name.rsplit("-", 1)[1]), 0)
        except (ValueError, ProcessLookupError):
            shutil.rmtree(p, ignore_errors=True)
        except PermissionError:  # alive, another user's
            pass


def memory_available() -> int | None:
    """MemAvailable from /proc/meminfo in bytes (None where there is none)."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def choose(mode: str, needed: int, available: int | None) -> tuple[str, str]:
    """Where the frames go ("memory" or "disk") for ``--frame-cache mode`` and why, for one line of output."""
    size = f"about {needed / 1e9:.2f} GB decoded"
    if mode != "auto":
        return mode, f"{size}; --frame-cache {mode}"
    if available is None:
        return "memory", f"{size}; the available memory is unknown"
    limit = MEMORY_SHARE * available
    if needed > limit:
        return "disk", f"{size}, more than {MEMORY_SHARE:.0%} of the {available / 1e9:.1f} GB of memory available"
    return "memory", f"{size}, within {MEMORY_SHARE:.0%} of the {available / 1e9:.1f} GB of memory available"
