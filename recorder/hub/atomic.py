"""Filesystem steps that make hub changes all-or-nothing: temporary names, fsync, sealing and the link switch.

Temporary entries are named ``.tmp-<pid>-<label>-<random>`` in the folder where they will be renamed into place
(same filesystem, so the rename is atomic). One whose process is gone was left by a killed command: stale.
"""

from __future__ import annotations

import os
import re
import secrets
import shutil
import stat
from pathlib import Path

_TEMP = re.compile(r"\.tmp-(?P<pid>[0-9]+)-")


def temp_name(parent: Path, label: str) -> Path:
    """A fresh temporary name in ``parent`` (nothing is created)."""
    return parent / f".tmp-{os.getpid()}-{label}-{secrets.token_hex(4)}"


def temp_dir(parent: Path, label: str) -> Path:
    """A new, empty temporary folder in ``parent``, with the usual permissions (umask), unlike mkdtemp's 0700:
    it becomes a version that everyone sharing the hub reads."""
    while True:
        path = temp_name(parent, label)
        try:
            os.mkdir(path)
            return path
        except FileExistsError:
            continue


def is_temp(name: str) -> bool:
    """Whether a folder entry is one of our temporaries (whoever made it)."""
    return _TEMP.match(name) is not None


def clean_stale(parent: Path) -> list[str]:
    """Remove the temporaries in ``parent`` whose process is gone; return their names."""
    removed = []
    for entry in sorted(parent.iterdir()) if parent.is_dir() else ():
        m = _TEMP.match(entry.name)
        if m and not _alive(int(m.group("pid"))):
            remove(entry)
            removed.append(entry.name)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def remove(path: Path) -> None:
    """Delete a file, link or folder tree; nothing if it is already gone."""
    if path.is_symlink() or path.is_file():
        path.unlink(missing_ok=True)
    else:
        shutil.rmtree(path, ignore_errors=True)


def fsync_dir(path: Path) -> None:
    """Make a folder's entries (creations, renames) durable."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def seal(root: Path, read_only: bool = True) -> None:
    """Make every file under ``root`` read-only (unless told not to) and every folder's entries durable; the files'
    contents were fsynced as they were written."""
    for folder, _, files in os.walk(root, topdown=False):
        if read_only:
            for name in files:
                path = os.path.join(folder, name)
                os.chmod(path, stat.S_IMODE(os.lstat(path).st_mode) & ~0o222)
        fsync_dir(Path(folder))


def point_link(link: Path, target: str) -> None:
    """Make ``link`` a symlink to ``target`` in one step: a new link under a temporary name, renamed over the old
    one, so a reader sees either the old target or the new one, never no link."""
    temp = temp_name(link.parent, f"{link.name}-link")
    os.symlink(target, temp)
    try:
        os.replace(temp, link)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise
    fsync_dir(link.parent)


def read_link(link: Path) -> str | None:
    """The target of ``link``, or None if it is not a symlink."""
    try:
        return os.readlink(link)
    except OSError:
        return None
