"""`gloverec review` (its flags, and serving the page until Ctrl-C) and `gloverec edit`, the same curation without a
browser: both publish through recorder/review/publish.py."""

from __future__ import annotations

import json
import os
import webbrowser
from pathlib import Path

import annotated_types as at

from recorder import GloverecError, config
from recorder.argtypes import number

PORT = number(int, at.Ge(0), at.Le(65535))


def _dataset_flags(p, verb: str) -> None:
    p.add_argument("--repo-id", required=True, help="dataset id, USER/NAME")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--root", help="a recording folder (default datasets/recordings/USER/NAME)")
    where.add_argument("--hub", help=f"a local hub folder: {verb} its version of the dataset")
    p.add_argument("--version", help=f"with --hub: the version to {verb}, vN (default: the newest)")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "review",
        help="review a dataset in a local web page: watch, plot, keep or discard, trim, relabel, publish",
        description="Serve a page listing the dataset's episodes with a player and joint plots; keep or discard, "
        "trim and relabel them, then publish: the hub's next version (--hub), or a new folder (--root: --out, "
        "default ROOT-reviewed). Nothing changes until Publish. Serves until Ctrl-C.",
    )
    _dataset_flags(p, "review")
    p.add_argument("--out", help="with --root: where Publish writes the reviewed dataset, a new folder "
                   "(default: ROOT-reviewed)")  # fmt: skip
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    # the page's port, named apart from the glove's old --port (docs/decisions.md); --port: its old name
    config.add_option(p, "--http-port", "--port", type=PORT, default=8766, metavar="PORT",
                      help="the page's TCP port (default 8766; 0: any free one)")  # fmt: skip
    p.add_argument("--no-browser", action="store_true", help="do not open the page in a browser")
    p.set_defaults(func=run)


def run(args) -> int:
    from recorder.review.server import Review  # the server and LeRobot's metadata: not at start-up
    from recorder.review.session import Session

    if args.version and not args.hub:
        raise GloverecError("--version names a hub version: pass --hub too")
    session = Session(args.repo_id, root=args.root, hub=args.hub, version=args.version, out=args.out)
    review = Review(session, args.host, args.http_port)
    print(f"review: {review.url}", flush=True)
    if not args.no_browser and (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        webbrowser.open(review.url)
    try:
        review.serve()
    except KeyboardInterrupt:
        pass
    return 0


def add_edit_parser(sub) -> None:
    """`gloverec edit` (recorder/record/edit.py; here because it publishes as the page does)."""
    p = sub.add_parser(
        "edit",
        help="delete, trim or relabel episodes: a new dataset folder or the hub's next version",
        description="Curate a dataset: delete episodes, trim an episode's start or end, relabel its success. The "
        "source is not changed: the result goes to --out, or for a hub dataset to the hub's next version.",
    )
    _dataset_flags(p, "edit")
    p.add_argument("--out", help="the edited dataset, a new folder (default with --hub: the hub's next version)")
    p.add_argument("--delete", metavar="EPISODES", help="episodes to delete, e.g. 3,7 or 10-14")
    p.add_argument("--trim", action="append", default=[], metavar="EP:START-END",
                   help="keep only START-END seconds of episode EP (END may be 'end'); repeatable")  # fmt: skip
    p.add_argument("--success", action="append", default=[], metavar="EP:yes|no",
                   help="relabel episode EP successful or failed; repeatable")  # fmt: skip
    p.add_argument("--merge", nargs="+", default=[], metavar="DATASET",
                   help="then append these dataset folders (gloverec merge: same fps, robot and features)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_edit)


def cmd_edit(args) -> int:
    from recorder.record.edit import Edits
    from recorder.review.publish import publish

    edits = Edits.parse(args.delete, args.trim, args.success)
    if not edits and not args.merge:
        raise GloverecError("nothing to do: pass --delete, --trim, --success or --merge")
    src, hub, out, _ = _source(args, "edited")
    summary = publish(src, args.repo_id, edits, hub=hub, out=out, merge=args.merge, progress=not args.json)
    if args.json:
        print(json.dumps(summary), flush=True)
    else:
        what = "; ".join(filter(None, (summary["edits"], f"merged {' '.join(args.merge)}" if args.merge else "")))
        where = _where(args, summary)
        print(f"{where}: {summary['episodes']} episodes, {summary['frames']} frames ({what}; from {src})")
    return 0


def add_repair_parser(sub) -> None:
    """`gloverec repair` (recorder/record/repair.py; here because it publishes as `edit` does)."""
    p = sub.add_parser(
        "repair",
        help="rescue a damaged dataset's intact episodes: a new dataset folder or the hub's next version",
        description="Read each episode of a damaged dataset on its own (its metadata row, data and videos), keep "
        "those that read, re-indexed from 0 with their gloverec records, and say which were dropped and why. The "
        "source is not changed: the result goes to --out, or for a hub dataset to the hub's next version.",
    )
    _dataset_flags(p, "repair")
    p.add_argument("--out", help="the repaired dataset, a new folder (default with --hub: the hub's next version)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_repair)


def cmd_repair(args) -> int:
    from recorder.review.publish import publish_repair

    src, hub, out, suspect = _source(args, "repaired", checked=False)
    summary = publish_repair(src, args.repo_id, hub=hub, out=out, suspect=suspect, progress=not args.json)
    if args.json:
        print(json.dumps(summary), flush=True)
        return 0
    for e, why in summary["dropped"].items():
        print(f"episode {e} dropped: {why}")
    print(f"{_where(args, summary)}: kept {summary['episodes']} of {summary['source_episodes']} episodes, "
          f"{summary['frames']} frames (dropped {len(summary['dropped'])}; from {src})")  # fmt: skip
    return 0


def _source(args, done: str, checked: bool = True):
    """(the dataset folder, the hub or None, --out, the files the hub's manifest says are damaged) of the flags; a
    hub version is checked against its manifest first unless ``checked`` is False (repair reads around damage)."""
    from recorder.hub.store import Hub  # pyarrow: not at start-up
    from recorder.record.inspect import dataset_root

    if args.version and not args.hub:
        raise GloverecError("--version names a hub version: pass --hub too")
    out = Path(args.out) if args.out else None
    if args.hub is None:
        src = dataset_root(args.repo_id, args.root, None)
        if out is None:
            raise GloverecError(f"pass --out DIR: a recording is not {done} in place (or --hub for a hub dataset)")
        return src, None, out, set()
    hub = Hub(args.hub)
    if checked:
        return hub.checked(args.repo_id, args.version).path, hub, out, set()
    version = hub.version(args.repo_id, args.version)
    damage = hub.check(version).damage
    return version.path, hub, out, {*damage.missing, *damage.altered}


def _where(args, summary: dict) -> str:
    return f"{args.repo_id} {summary['version']}" if "version" in summary else summary["out"]
