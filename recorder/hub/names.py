"""Names in the hub: repo ids (USER/NAME) and version tags (vN). Where the hub folder is: recorder/paths.py."""

from __future__ import annotations

import re

from recorder import GloverecError

# one part of a repo id: what the Hugging Face Hub accepts, minus anything a path could misread
_PART = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,95}")
_VERSION = re.compile(r"v?([1-9][0-9]{0,8})")


def parse_repo_id(text: str) -> tuple[str, str]:
    """``"USER/NAME"`` -> ``("USER", "NAME")``; anything else (``..``, absolute paths, empty parts) is an error."""
    parts = str(text).split("/")
    if len(parts) != 2 or not all(_PART.fullmatch(p) for p in parts) or ".." in text:
        raise GloverecError(
            f"bad repo id {text!r}: expected USER/NAME, each part 1-96 characters from "
            "A-Z a-z 0-9 . _ - starting with a letter or digit, without '..'"
        )
    return parts[0], parts[1]


def parse_version(text: str) -> int:
    """``"v3"`` or ``"3"`` -> 3."""
    m = _VERSION.fullmatch(str(text).strip())
    if not m:
        raise GloverecError(f"bad version {text!r}: expected vN with N >= 1, e.g. v1")
    return int(m.group(1))


def tag(number: int) -> str:
    """3 -> ``"v3"``, the version tag used in folder names and manifests."""
    return f"v{number}"
