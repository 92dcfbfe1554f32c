"""Edit a dataset and publish the result: the hub's next version, or a new folder. The one path both
`gloverec edit` and the review page take (recorder/record/edit.py does the editing; this adds the merge and the
hub, a layer recorder.record may not import), and `gloverec repair`'s (recorder/record/repair.py)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable, Collection, Sequence
from pathlib import Path

from recorder import GloverecError
from recorder.dataset_check import check_dataset
from recorder.hub.store import Hub
from recorder.record.edit import Edits, edit_dataset
from recorder.record.inspect import merge as merge_datasets
from recorder.record.repair import repair_dataset


def publish(
    src: Path,
    repo_id: str,
    edits: Edits,
    hub: Hub | None = None,
    out: Path | None = None,
    merge: Sequence[str | Path] = (),
    progress: bool = True,
) -> dict:
    """``src`` with ``edits`` applied, then the datasets ``merge`` appended, written to the new folder ``out`` or,
    without ``out``, published to ``hub`` as ``repo_id``'s next version (the summary's ``version``). Nothing is
    left behind when it fails: bad edits, a damaged dataset or an existing ``out`` are one-line GloverecErrors."""
    if out is None and hub is None:
        raise GloverecError("pass --out DIR: a recording is not edited in place (or --hub for a hub dataset)")
    if not edits and not merge:
        raise GloverecError("nothing to do: no episode is deleted, trimmed or relabelled")
    given, merge = [str(m) for m in merge], [Path(m) for m in merge]
    for folder in (Path(src), *merge):
        if not folder.exists():
            raise GloverecError(f"no dataset at {folder}")
        check_dataset(folder)

    def write(result: Path, tmp: Path) -> dict:
        first = result if not merge else tmp / "edited" if edits else Path(src)
        if edits:
            summary = edit_dataset(Path(src), first, repo_id, edits, progress=progress)
        else:
            summary = {"source": str(src), "edits": "", "source_episodes": None}
        if merge:
            summary.update(merge_datasets(result, [first, *merge]), merged=given)
        return summary

    return _written(write, repo_id, hub, out, "edit")


def publish_repair(
    src: Path, repo_id: str, hub: Hub | None = None, out: Path | None = None, suspect: Collection[str] = (),
    progress: bool = True,
) -> dict:  # fmt: skip
    """The intact episodes of the damaged dataset at ``src`` (recorder/record/repair.py; ``suspect``: its files
    that differ from a hub manifest) written to ``out`` or published to ``hub``, as ``publish`` does."""
    if out is None and hub is None:
        raise GloverecError("pass --out DIR: a recording is not repaired in place (or --hub for a hub dataset)")
    if not Path(src).exists():
        raise GloverecError(f"no dataset at {src}")
    return _written(lambda result, _: repair_dataset(Path(src), result, repo_id, suspect, progress), repo_id, hub,
                    out, "repair")  # fmt: skip


def _written(write: Callable[[Path, Path], dict], repo_id: str, hub: Hub | None, out: Path | None, verb: str) -> dict:
    """``write(result, tmp)``'s dataset (its summary) in the new folder ``out``, or pushed to ``hub`` as
    ``repo_id``'s next version (the summary's ``version``); nothing is left behind when it fails."""
    if out is not None and (out.exists() or out.is_symlink()):
        raise GloverecError(f"{out} already exists: {verb} into a new folder")
    with tempfile.TemporaryDirectory(prefix=f"gloverec-{verb}-") as tmp:  # push copies it into the hub
        result = out or Path(tmp) / "result"
        try:
            summary = write(result, Path(tmp))
        except BaseException:
            if out is not None:
                shutil.rmtree(out, ignore_errors=True)  # nothing half-written left behind
            raise
        summary["out"] = str(result)
        if out is None:
            version = hub.push(result, repo_id)
            summary["out"] = str(version.path)
            summary["version"] = version.tag
    return summary
