"""Where gloverec's files are. Data (the local hub, recordings, calibrations) lives under the current directory,
``datasets/``, or where the environment says; never inside the installed package. Configs and robot models ship
with the package and are found with importlib.resources, in a checkout and in an installed wheel alike."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

HUB_ENV = "GLOVEREC_HUB"
CALIBRATION_ENV = "GLOVEREC_CALIBRATION_DIR"
DATASETS = Path("datasets")


def hub_dir(arg: str | os.PathLike | None = None) -> Path:
    """The local hub: ``arg`` if given, else $GLOVEREC_HUB, else datasets/hub under the current directory."""
    return Path(arg or os.environ.get(HUB_ENV) or DATASETS / "hub")


def recordings_dir() -> Path:
    """Where recordings go by default: datasets/recordings under the current directory."""
    return DATASETS / "recordings"


def calibration_dir(arg: str | os.PathLike | None = None) -> Path:
    """Saved glove calibrations: ``arg``, else $GLOVEREC_CALIBRATION_DIR, else datasets/calibration."""
    return Path(arg or os.environ.get(CALIBRATION_ENV) or DATASETS / "calibration")


def video_file(target: str | os.PathLike, name: str) -> Path:
    """``--video``'s one rule in every command that films (eval, replay, view): a path ending in ``.mp4`` is the
    file itself; any other path is a folder, made when missing, where the video is written as ``name``."""
    target = Path(target)
    path = target if target.suffix.lower() == ".mp4" else target / name
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def configs_dir() -> Path:
    """The shipped configs (robot, task, record, train, fusion). A wheel carries the repository's configs/ as
    recorder/configs; a checkout (an editable install) has them beside the package."""
    packaged = resources.files("recorder") / "configs"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parent.parent / "configs"


def config_file(kind: str, name: str) -> Path:
    """configs/<kind>/<name>.yaml (the file may not exist)."""
    return configs_dir() / kind / f"{name}.yaml"


def assets_dir() -> Path:
    """The robots' MJCF models (envs/assets, package data of envs)."""
    return Path(str(resources.files("envs") / "assets"))


def checkout_dir() -> Path | None:
    """The repository checkout this code runs from (firmware sources, build folder), None when installed."""
    root = Path(__file__).resolve().parent.parent
    return root if (root / "firmware" / "CMakeLists.txt").is_file() else None


CACHE_ENV = "GLOVEREC_CACHE"


def cache_dir() -> Path:
    """Generated code and compiled kernels (recorder/fusion/dispatch.py): $GLOVEREC_CACHE, else
    $XDG_CACHE_HOME/gloverec, else ~/.cache/gloverec. Safe to delete: it is made again."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "gloverec"


def write_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` whole or not at all: into a temporary file beside it, then renamed over it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return path
