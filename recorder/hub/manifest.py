"""The manifest of a hub version (size and sha256 of every file) and the one pass that hashes, copies and compares.

Push, verify and pull all read each file exactly once through ``hash_files``: push copies into the staging folder
while hashing, pull copies out while hashing, verify only hashes.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

from tqdm import tqdm

from recorder import GloverecError

NAME = "gloverec-manifest.json"  # at the top of every version folder; not itself listed
FORMAT = "gloverec-hub-manifest/1"
_CHUNK = 1 << 20
_BAR_FILES, _BAR_BYTES = 20, 64 << 20  # show a progress bar from this many files or bytes (on a terminal)


def dataset_files(root: Path) -> list[str]:
    """What a push takes from a dataset folder: every file except top-level hidden entries (``.cache``, ...),
    ``images/`` (lerobot's temporary PNGs, which its own push_to_hub skips too) and a manifest."""
    return [rel for rel in all_files(root) if not (rel.startswith(".") or rel.startswith("images/") or rel == NAME)]


def all_files(root: Path) -> list[str]:
    """Every file under ``root`` (symlinks included, not followed into folders) as sorted POSIX paths."""
    found = []
    for folder, dirs, files in os.walk(root):
        dirs.sort()
        rel = Path(folder).relative_to(root)
        found += [(rel / f).as_posix() for f in files]
        found += [(rel / d).as_posix() for d in dirs if os.path.islink(os.path.join(folder, d))]
    return sorted(found)


def hash_files(src: Path, files: list[str], dest: Path | None = None, label: str = "hashing") -> dict[str, dict]:
    """``{rel: {"size", "sha256"}}`` for each file, copying it to ``dest/rel`` (fsynced) on the way when ``dest``
    is given: the hashes describe exactly the bytes written, even if the source changes meanwhile."""
    sizes = {rel: _size(src / rel) for rel in files}
    quiet = len(files) < _BAR_FILES and sum(sizes.values()) < _BAR_BYTES
    out = {}
    with tqdm(
        total=sum(sizes.values()),
        unit="B",
        unit_scale=True,
        desc=label,
        leave=False,
        file=sys.stderr,
        disable=True if quiet else None,
    ) as bar:
        for rel in files:
            out[rel] = _hash_one(src / rel, None if dest is None else dest / rel, bar.update)
    return out


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError as exc:
        raise GloverecError(f"cannot read {path}: {exc.strerror or exc}") from None


def _hash_one(path: Path, copy_to: Path | None, progress) -> dict:
    digest, size = hashlib.sha256(), 0
    try:
        with open(path, "rb") as f, _create(copy_to) if copy_to else contextlib.nullcontext() as out:
            while chunk := f.read(_CHUNK):
                digest.update(chunk)
                if out is not None:
                    out.write(chunk)
                size += len(chunk)
                progress(len(chunk))
            if out is not None:
                out.flush()
                os.fsync(out.fileno())
    except OSError as exc:
        what = f"copy {path} to {copy_to}" if copy_to else f"read {path}"
        raise GloverecError(f"cannot {what}: {exc.strerror or exc}") from None
    return {"size": size, "sha256": digest.hexdigest()}


def _create(path: Path):
    path.parent.mkdir(parents=True, exist_ok=True)
    return open(path, "xb")


@dataclass
class Damage:
    """How a folder differs from its manifest."""

    missing: list[str] = field(default_factory=list)
    altered: list[str] = field(default_factory=list)
    unexpected: list[str] = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.missing or self.altered or self.unexpected)

    def summary(self, limit: int = 3) -> str:
        """``"altered data/chunk-000/file-000.parquet; missing meta/stats.json"`` (at most ``limit`` names each)."""
        parts = []
        for kind in ("altered", "missing", "unexpected"):
            names = getattr(self, kind)
            if names:
                more = f" and {len(names) - limit} more" if len(names) > limit else ""
                parts.append(f"{kind} {', '.join(names[:limit])}{more}")
        return "; ".join(parts)

    def as_dict(self) -> dict:
        return {"missing": self.missing, "altered": self.altered, "unexpected": self.unexpected}


def compare(folder: Path, manifest: dict, dest: Path | None = None, label: str = "verifying") -> Damage:
    """Hash every file of ``folder`` listed in ``manifest`` (copying it to ``dest`` if given) and say what differs:
    files missing, files whose size or sha256 changed, and files the manifest does not list."""
    expected: dict[str, dict] = manifest["files"]
    present = set(all_files(folder)) - {NAME}
    damage = Damage(missing=sorted(set(expected) - present), unexpected=sorted(present - set(expected)))
    common = sorted(present & set(expected))
    got = hash_files(folder, common, dest, label)
    damage.altered = [rel for rel in common if got[rel] != expected[rel]]
    return damage


def write(folder: Path, manifest: dict) -> None:
    """Write ``manifest`` as ``folder/gloverec-manifest.json`` (fsynced)."""
    path = folder / NAME
    with open(path, "w") as f:
        json.dump(manifest, f, indent=1, sort_keys=True)
        f.write("\n")
        f.flush()
        os.fsync(f.fileno())


def read(folder: Path) -> dict:
    """The manifest of a version folder; GloverecError if it is missing or not one of ours."""
    try:
        manifest = json.loads((folder / NAME).read_text())
    except FileNotFoundError:
        raise GloverecError(f"{folder} is damaged: no {NAME}") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise GloverecError(f"{folder} is damaged: unreadable {NAME} ({exc})") from None
    files = manifest.get("files") if isinstance(manifest, dict) else None
    if (
        not isinstance(files, dict)
        or manifest.get("format") != FORMAT
        or not all(isinstance(v, dict) and set(v) == {"size", "sha256"} for v in files.values())
    ):
        raise GloverecError(f"{folder} is damaged: {NAME} is not a {FORMAT} manifest")
    return manifest
