"""Our per-episode metadata beside a LeRobot dataset (seed, success, robot, task, glove and loop figures): one
JSON object per line in ``meta/gloverec/episodes.jsonl``, written by the recorder's store, read by inspect, the
policies and the hub."""

from __future__ import annotations

import json
from pathlib import Path

SIDECAR = "meta/gloverec/episodes.jsonl"


def append_sidecar(root: str | Path, index: int, fields: dict) -> Path:
    """Append episode ``index``'s metadata (flushed, not fsynced: the store fsyncs what it publishes)."""
    path = Path(root) / SIDECAR
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as f:
        f.write(json.dumps({"episode_index": index, **fields}) + "\n")
    return path


def read_sidecar(root: str | Path) -> list[dict]:
    """Our per-episode metadata of a dataset (empty when it has none)."""
    path = Path(root) / SIDECAR
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
