"""Our per-episode metadata beside a LeRobot dataset (seed, success, robot, task, glove and loop figures): one
JSON object per line in ``meta/gloverec/episodes.jsonl``, written by the recorder's store, read by inspect, the
policies and the hub.

Other tools edit datasets without knowing the file: lerobot-edit-dataset's delete_episodes, split and merge
write datasets without it (renumbering the episodes), and a file copied along with edited episodes would
describe others. So each record is checked against the episode it names by a key both sides keep: the episode's
length and the device time of its first frame (``time.device_s``, whose per-episode minimum lerobot keeps in
its episode metadata); records that do not match are ignored, with one warning. ``carry_sidecar`` rebuilds the
file of an edited dataset from the datasets it was made from, by the same key."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Collection
from pathlib import Path

SIDECAR = "meta/gloverec/episodes.jsonl"
_START = "stats/time.device_s/min"  # lerobot's per-episode stats column of the first frame's device time


def episode_notes(record: dict, source: bool = True) -> list[str]:
    """What a person should know of an episode beyond its success, from its record: where a generated one came
    from (`gloverec generate`), why it failed (as its task
    saw the end), how much a takeover's wearer drove, and where MuJoCo reset a blown-up simulation (the saved line,
    inspect and review say the same)."""
    notes = []
    gen = record.get("generated")
    if gen and source:  # (review's list has a column of its own for it)
        moved = ", ".join(f"{k} {100 * v:.0f} cm" for k, v in (gen.get("moved_m") or {}).items())
        notes.append(f"generated from episode {gen.get('source_episode')} of {(gen.get('from') or {}).get('repo_id')}"
                     + (f" ({moved} moved)" if moved else ""))  # fmt: skip
    if record.get("failed_because"):
        notes.append(f"failed: {record['failed_because']}")
    wearer = (record.get("takeover") or {}).get("frames_by_wearer")
    if wearer is not None:
        notes.append(f"the wearer drove {wearer} frames")
    if record.get("physics_unstable_s") is not None:
        notes.append(f"physics blew up at {record['physics_unstable_s']} s (MuJoCo reset the simulation)")
    return notes


def append_sidecar(root: str | Path, index: int, fields: dict) -> Path:
    """Append episode ``index``'s metadata (flushed, not fsynced: the store fsyncs what it publishes)."""
    path = Path(root) / SIDECAR
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a") as f:
        f.write(json.dumps({"episode_index": index, **fields}) + "\n")
    return path


def _records(root: str | Path) -> list[dict]:
    path = Path(root) / SIDECAR
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def episode_keys(root: str | Path) -> dict[int, tuple[int, float | None]]:
    """Each episode's (length, first frame's device time or None) from the dataset's episode metadata."""
    import pyarrow.parquet as pq  # not at start-up (every command imports this module)

    keys: dict[int, tuple[int, float | None]] = {}
    for f in sorted((Path(root) / "meta" / "episodes").glob("*/*.parquet")):
        names = pq.read_schema(f).names
        cols = ["episode_index", "length"] + ([_START] if _START in names else [])
        for row in pq.read_table(f, columns=cols).to_pylist():
            keys[int(row["episode_index"])] = episode_key(row)
    return keys


def episode_key(row: dict) -> tuple[int, float | None]:
    """(length, first frame's device time or None) of one row of the episode metadata."""
    start = row.get(_START)
    start = start[0] if isinstance(start, list) else start  # stats of a 1-d feature are 1-element lists
    return int(row["length"]), None if start is None else float(start)


def _same_episode(record: dict, key: tuple[int, float | None] | None) -> bool:
    """Whether ``record`` describes the episode of ``key``, by what the record has (a record without a length or
    a time, as a library caller may save, is taken by its index)."""
    if key is None or record.get("frames", key[0]) != key[0]:
        return False
    start, recorded = key[1], record.get("start_device_time_s")
    if start is None or recorded is None:
        return True  # no times to compare (a dataset without time.device_s): the length has to do
    return abs(start - recorded) <= 1e-4 + 4e-7 * abs(recorded)  # time.device_s is stored as float32


def read_sidecar(
    root: str | Path, keys: dict[int, tuple[int, float | None]] | None = None, among: Collection[int] | None = None
) -> list[dict]:
    """Our per-episode metadata of a dataset, the records that describe its episodes (empty when it has none);
    ``keys``: its ``episode_keys``, when the caller has read the episode metadata already; ``among``: only the
    records of these episodes (the others neither matched nor warned about: `gloverec repair`'s lost ones)."""
    records = [r for r in _records(root) if among is None or int(r["episode_index"]) in among]
    if not records:
        return []
    keys = episode_keys(root) if keys is None else keys
    good = [r for r in records if _same_episode(r, keys.get(int(r["episode_index"])))]
    if len(good) < len(records):
        print(
            f"warning: {len(records) - len(good)} of the {len(records)} episode records in {Path(root) / SIDECAR} "
            "do not match the dataset's episodes (edited by another tool?): ignoring them; "
            "`gloverec carry-meta --root ROOT --from ORIGINAL` rebuilds them",
            file=sys.stderr,
            flush=True,
        )
    return good


def carry_sidecar(root: str | Path, sources: list[str | Path]) -> tuple[int, int]:
    """Write ``root``'s sidecar from the records of ``sources`` (the datasets it was edited from) that match its
    episodes; (episodes matched, episodes in ``root``). Written whole, then renamed over the old file."""
    pool = [r for src in sources for r in read_sidecar(src)]
    keys = episode_keys(root)
    lines = []
    for index, key in sorted(keys.items()):
        match = next((r for r in pool if _same_episode(r, key) and key[1] is not None), None)
        if match is not None:
            lines.append(json.dumps({**match, "episode_index": index}))
    path = Path(root) / SIDECAR
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    with tmp.open("w") as f:
        f.write("".join(line + "\n" for line in lines))
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    return len(lines), len(keys)
