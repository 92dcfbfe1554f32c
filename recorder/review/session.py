"""What a review holds: the dataset's episodes as LeRobot's episode metadata and gloverec's sidecar list them (no
data row is read to build the list), one episode's vectors when the page asks for them, and the edits pending
until "publish", which hands them to the same publish() as `gloverec edit`."""

from __future__ import annotations

import json
import math
import threading
import time
from functools import lru_cache
from pathlib import Path

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq

from recorder import GloverecError
from recorder.dataset_check import check_dataset
from recorder.hub.store import Hub
from recorder.record.edit import Edits, frame_ranges
from recorder.record.inspect import action_state_pairs, dataset_root
from recorder.record.sidecar import episode_notes, read_sidecar
from recorder.review.publish import publish

_START = "stats/time.device_s/min"  # the first frame's device time: how read_sidecar matches its records
_EPISODE_COLUMNS = ("episode_index", "tasks", "length", "data/chunk_index", "data/file_index", "dataset_from_index")


class Session:
    """A dataset under review: ``--hub`` (a version of a hub dataset, published as the hub's next version) or
    ``--root`` (a recording folder, published into the new folder ``out``)."""

    def __init__(self, repo_id: str, root: str | None = None, hub: str | None = None, version: str | None = None,
                 out: str | None = None):  # fmt: skip
        self.repo_id = repo_id
        self.hub = Hub(hub) if hub is not None else None
        self.version = version
        if self.hub is None:
            self.src = dataset_root(repo_id, root, None)
            if not self.src.exists():
                raise GloverecError(f"no dataset at {self.src}")
            self.out = Path(out) if out else self.src.with_name(self.src.name + "-reviewed")
        elif out is not None:
            raise GloverecError("--out is for --root: a hub dataset is published as the hub's next version")
        self.lock = threading.Lock()
        self.result: dict | None = None
        self._open()

    def _open(self) -> None:
        if self.hub is not None:  # every file checked against the manifest of a version that push checked
            v = self.hub.checked(self.repo_id, self.version)
            self.src, self.tag = v.path, v.tag
        else:
            self.tag = None
            check_dataset(self.src)  # a damaged dataset: one line, before anything reads it
        self.info = json.loads((self.src / "meta" / "info.json").read_text())
        self.fps = float(self.info["fps"])
        self.features = self.info["features"]
        self.cameras = [k for k, f in self.features.items() if f["dtype"] == "video"]
        self.episodes = _episode_meta(self.src)
        self.records = {int(r["episode_index"]): r for r in read_sidecar(self.src, _keys(self.episodes))}
        self.lengths = {e: int(m["length"]) for e, m in self.episodes.items()}
        self.pending: dict[int, dict] = {}
        self._rows = lru_cache(maxsize=8)(self._read_rows)

    # ------------------------------------------------------------ what the page shows

    def describe(self) -> dict:
        edits = self.edits()
        return {
            "repo_id": self.repo_id,
            "source": str(self.src),
            "version": self.tag,
            "target": f"{self.hub.root} (the next version)" if self.hub else str(self.out),
            "fps": self.fps,
            "cameras": self.cameras,
            "robot": self.info.get("robot_type"),
            "episodes": [self._row(e) for e in sorted(self.episodes)],
            "pending": {str(e): p for e, p in self.pending.items()},
            "edits": edits.describe() or "none",
            "result": self.result,
        }

    def _row(self, e: int) -> dict:
        meta, rec = self.episodes[e], self.records.get(e, {})
        intent = rec.get("demonstration") or {}
        gen = rec.get("generated")
        return {
            "episode": e,
            "frames": self.lengths[e],
            "seconds": round(self.lengths[e] / self.fps, 2),
            "task": meta["tasks"][0] if len(meta["tasks"]) else "",
            "success": rec.get("success"),
            "glove_late": rec.get("glove_late"),
            "glove_dropped": rec.get("glove_dropped"),
            "seed": rec.get("seed"),
            # a generated episode's source (`gloverec generate`): the page's "from" column and its filter
            "source": f"ep {gen.get('source_episode')} of {(gen.get('from') or {}).get('repo_id')}" if gen else None,
            "intent": "; ".join(filter(None, (
                ", ".join(f"{k} {v}" for k, v in intent.items() if k in ("strategy", "failure") and v),
                *episode_notes(rec, source=False),  # a takeover's share, a blow-up (the joint plots jump there)
            ))) or None,
        }  # fmt: skip

    def rows(self, e: int) -> dict[str, np.ndarray]:
        """Episode ``e``'s ``action`` and ``observation.state`` (frames x values), read from its data file."""
        self._known(e)
        return self._rows(e)

    def _read_rows(self, e: int) -> dict[str, np.ndarray]:
        meta = self.episodes[e]
        path = self.src / self.info["data_path"].format(
            chunk_index=int(meta["data/chunk_index"]), file_index=int(meta["data/file_index"])
        )
        names = [c for c in ("action", "observation.state") if c in self.features]
        table = pq.read_table(path, columns=["index", *names])
        first = int(meta["dataset_from_index"])
        table = table.filter(pc.and_(pc.greater_equal(table["index"], first),
                                     pc.less(table["index"], first + self.lengths[e])))  # fmt: skip
        out = {}
        for name in names:
            values = table[name].combine_chunks()
            out[name] = np.asarray(values.flatten(), np.float64).reshape(len(table), -1)
        return out

    def plots(self, e: int) -> dict:
        """Episode ``e``'s joints for the page's plots: per actuated joint, the action (target) and the joint's
        position, in degrees."""
        rows = self.rows(e)
        action, state = rows.get("action"), rows.get("observation.state")
        a_names = self.features.get("action", {}).get("names") or []
        s_names = self.features.get("observation.state", {}).get("names") or []
        pairs = action_state_pairs(a_names, s_names, self.info.get("robot_type")) if state is not None else []
        if not pairs and action is not None:
            pairs = [(a, None) for a in range(action.shape[1])]
        series = []
        for a, s in pairs:
            series.append({
                "name": a_names[a] if a < len(a_names) else f"action {a}",
                "action": np.round(np.degrees(action[:, a]), 2).tolist(),
                "state": None if s is None else np.round(np.degrees(state[:, s]), 2).tolist(),
            })  # fmt: skip
        return {"episode": e, "fps": self.fps, "frames": self.lengths[e], "series": series}

    # ------------------------------------------------------------ edits

    def edit(self, e: int, op: str, t: float | None = None) -> None:
        """One button: ``keep``, ``discard``, ``trim_start`` / ``trim_end`` at ``t`` s, ``untrim``, ``success`` /
        ``failure``, ``unlabel``. A trim that would leave nothing is refused and changes nothing."""
        self._known(e)
        p = dict(self.pending.get(e, {}))
        if op in ("keep", "discard"):
            p["discard"] = op == "discard"
        elif op in ("trim_start", "trim_end"):
            if t is None or not math.isfinite(t) or t < 0:
                raise GloverecError(f"{op}: no time given")
            start, end = p.get("trim") or (0.0, None)
            start, end = (t, end) if op == "trim_start" else (start, t)
            try:
                frames = frame_ranges({e: self.lengths[e]}, self.fps, Edits(trim={e: (start, end)}))[e]
            except GloverecError:
                frames = range(0)
            if not frames:
                raise GloverecError(f"episode {e}: trimming to {start:.2f}-{'end' if end is None else f'{end:.2f}'} "
                                    "s leaves nothing")  # fmt: skip
            whole = frames.start == 0 and frames.stop == self.lengths[e]
            p["trim"] = None if whole else [start, end]
        elif op == "untrim":
            p["trim"] = None
        elif op in ("success", "failure"):
            p["success"] = op == "success"
        elif op == "unlabel":
            p["success"] = None
        else:
            raise GloverecError(f"no such edit {op!r}")
        p = {k: v for k, v in p.items() if v is not None and (k != "discard" or v)}
        if p.get("success") is not None and p["success"] == self.records.get(e, {}).get("success"):
            del p["success"]  # the label it already has
        if p:
            self.pending[e] = p
        else:
            self.pending.pop(e, None)

    def edits(self) -> Edits:
        edits = Edits()
        for e, p in self.pending.items():
            if p.get("discard"):
                edits.delete.add(e)
                continue
            if p.get("trim"):
                edits.trim[e] = tuple(p["trim"])
            if p.get("success") is not None:
                edits.success[e] = p["success"]
        return edits

    def publish(self) -> dict:
        """The pending edits published (the hub's next version, or the folder ``out``); the summary. Refused in one
        line, changing nothing, when there is nothing to publish or nothing would be left."""
        t0 = time.perf_counter()  # the whole of it, as the person waited: checks, writing, the hub's copy, reopening
        edits = self.edits()
        if not edits:
            raise GloverecError("nothing to publish: no episode is discarded, trimmed or relabelled")
        if len(edits.delete) == len(self.episodes):
            raise GloverecError("every episode is discarded: keep at least one to publish")
        frame_ranges(self.lengths, self.fps, edits)  # anything else wrong: before any writing
        summary = publish(self.src, self.repo_id, edits, hub=self.hub, out=None if self.hub else self.out,
                          progress=False)  # fmt: skip
        result = {k: summary.get(k) for k in ("version", "out", "episodes", "frames", "edits", "wall_s")}
        if self.hub is not None:  # go on reviewing what was published: the new newest version
            self.version = None
            self._open()
        result["wall_s"] = round(time.perf_counter() - t0, 2)
        self.result = result
        return result

    def _known(self, e: int) -> None:
        if e not in self.episodes:
            raise GloverecError(f"no episode {e}: the dataset has episodes 0-{len(self.episodes) - 1}")


def _episode_meta(root: Path) -> dict[int, dict]:
    """LeRobot's episode metadata (meta/episodes/*.parquet), without its per-episode statistics but the first
    frame's device time (read_sidecar's key)."""
    out = {}
    for f in sorted((root / "meta" / "episodes").glob("*/*.parquet")):
        file = pq.ParquetFile(f)
        names = file.schema_arrow.names
        columns = [c for c in names if c in _EPISODE_COLUMNS or c.startswith("videos/") or c == _START]
        for row in file.read(columns=columns).to_pylist():
            out[int(row["episode_index"])] = row
    return out


def _keys(episodes: dict[int, dict]) -> dict[int, tuple[int, float | None]]:
    """read_sidecar's key of each episode: its length and first frame's device time (None without one)."""
    keys = {}
    for e, row in episodes.items():
        start = row.get(_START)
        start = start[0] if isinstance(start, list) else start  # stats of a 1-d feature are 1-element lists
        keys[e] = (int(row["length"]), None if start is None else float(start))
    return keys
