"""Which dataset a command reads (a recording folder, or a version in the local hub), found and checked without
torch or LeRobot: a missing, foreign or damaged dataset is one line in a fraction of a second, before those load
(seconds). policies/data.py builds the training data from it."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from recorder import GloverecError
from recorder.dataset_check import check_dataset
from recorder.hub.names import parse_repo_id
from recorder.hub.store import Hub
from recorder.paths import recordings_dir
from recorder.record.sidecar import read_sidecar


@dataclass(frozen=True)
class DatasetRef:
    repo_id: str
    root: Path
    version: str | None = None  # the hub version (vN) when it came from the hub

    def as_dict(self) -> dict:
        return {"repo_id": self.repo_id, "root": str(self.root), "version": self.version}


def resolve(
    repo_id: str,
    hub: str | os.PathLike | None = None,
    root: str | os.PathLike | None = None,
    version: str | None = None,
) -> DatasetRef:
    """The dataset ``repo_id``: ``root`` if given (a recording, e.g. datasets/recordings/USER/NAME), else its
    version in the local hub (the newest unless ``version``), checked first: a missing or damaged dataset is a
    one-line GloverecError saying what is wrong (a folder by its parquet files and counts, a hub version against
    its manifest's checksums)."""

    parse_repo_id(repo_id)
    if root is not None:
        path = Path(root)
        if not (path / "meta" / "info.json").is_file():
            raise GloverecError(f"{root} is not a LeRobot dataset (no meta/info.json)")
        check_dataset(path)
        return DatasetRef(repo_id, path.absolute(), None)

    store = Hub(hub)
    if not store.versions(repo_id):  # `record` writes to datasets/recordings, train and replay read the hub
        recording = recordings_dir() / repo_id
        if (recording / "meta" / "info.json").is_file():
            raise GloverecError(f"no dataset {repo_id} in the hub {store.root}, but a recording of it is at "
                                f"{recording}: pass --root {recording}, or push it first (gloverec push --repo-id "
                                f"{repo_id} --root {recording})")  # fmt: skip
    v = store.checked(repo_id, version)
    return DatasetRef(repo_id, v.path.resolve(), v.tag)


def sidecar(root: Path) -> dict[int, dict]:
    """Our per-episode metadata (seed, success, robot, task, ...) by episode index."""

    return {int(e["episode_index"]): e for e in read_sidecar(root)}


def recorded_with(root: Path | None) -> dict:
    """The sidecar record of a dataset's first episode (its robot, env_task, ...: one per dataset), or {} for a
    dataset without our sidecar (lerobot-record's)."""
    side = sidecar(root) if root is not None else {}
    return side[min(side)] if side else {}


def recorded_options(info: dict, record: dict, cameras: bool = True) -> dict:
    """The environment settings a dataset was recorded with, from its info.json and an episode's sidecar record:
    its rate, a free wrist (the action carries the palm position), its cameras (``cameras``) and what a generated
    dataset set beyond the task's defaults (``env_options``, `gloverec generate --scene`)."""
    features = info.get("features", {})
    options = {"control_hz": float(info.get("fps") or record.get("fps") or 30)}
    if "base.x" in (features.get("action", {}).get("names") or []):
        options["base_position"] = True
    cams = [k.removeprefix("observation.images.") for k in features if k.startswith("observation.images.")]
    if cams and cameras:
        options.update(cameras=tuple(cams), image_size=tuple(features[f"observation.images.{cams[0]}"]["shape"][:2]))
    scene = {k: tuple(v) if isinstance(v, list) else v for k, v in (record.get("env_options") or {}).items()}
    return {**options, **scene}
