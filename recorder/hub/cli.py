"""`gloverec push` and `gloverec hub list|verify|pull`: flags here, the work in ``recorder.hub.store``.

``add_parsers(subparsers)`` adds both commands to the `gloverec` subparsers; each sets ``func`` to its handler,
which returns the exit code or raises GloverecError (one line, exit 1). Heavy modules load inside the handlers.
"""

from __future__ import annotations

import argparse
import functools
import json

from recorder import GloverecError
from recorder.hub import hf
from recorder.paths import HUB_ENV

HUB_HELP = f"the hub folder (default: ${HUB_ENV}, else datasets/hub in the current directory)"
REPO_HELP = "dataset id, USER/NAME"


def add_parsers(subparsers) -> None:
    """Add ``push`` and ``hub`` (with ``list``, ``verify``, ``pull``) to the `gloverec` subparsers."""
    p = subparsers.add_parser("push", help="publish a LeRobot dataset to the local hub as its next version")
    p.add_argument("--repo-id", required=True, help=REPO_HELP)
    p.add_argument("--root", required=True, help="the dataset folder to publish")
    p.add_argument("--hub", help=HUB_HELP)
    p.add_argument(
        "--to-hf",
        action="store_true",
        help="then push the new version to the Hugging Face Hub too (needs a network and a token)",
    )
    p.add_argument("--private", action="store_true", help="with --to-hf: create the Hugging Face repo private")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_push)

    h = subparsers.add_parser("hub", help="list, verify and pull the datasets of the local hub")
    actions = h.add_subparsers(dest="hub_command", required=True, metavar="ACTION")

    ls = actions.add_parser("list", help="datasets and their versions")
    ls.add_argument("--hub", help=HUB_HELP)
    ls.add_argument("--json", action="store_true", help="print one JSON list")
    ls.set_defaults(func=cmd_hub_list)

    v = actions.add_parser("verify", help="check every file against the manifests (exit 1 if any differs)")
    v.add_argument("--repo-id", help=f"{REPO_HELP} (default: every dataset)")
    v.add_argument("--version", help="vN (default: every version; needs --repo-id)")
    v.add_argument("--hub", help=HUB_HELP)
    v.add_argument("--json", action="store_true", help="print one JSON object")
    v.set_defaults(func=cmd_hub_verify)

    pl = actions.add_parser("pull", help="copy a verified version out of the hub")
    pl.add_argument("--repo-id", required=True, help=REPO_HELP)
    pl.add_argument("--version", help="vN (default: the newest)")
    pl.add_argument("--root", required=True, help="where to put it: a new or empty folder")
    pl.add_argument("--hub", help=HUB_HELP)
    pl.add_argument("--json", action="store_true", help="print one JSON object")
    pl.set_defaults(func=cmd_hub_pull)


def _one_line(handler):
    """Turn an OSError that slipped through (a full disk, a folder that vanished) into a one-line GloverecError."""

    @functools.wraps(handler)
    def run(args: argparse.Namespace) -> int:
        try:
            return handler(args)
        except OSError as exc:
            command = " ".join(filter(None, (args.command, getattr(args, "hub_command", None))))
            where = f" {exc.filename}:" if exc.filename else ""
            raise GloverecError(f"{command}:{where} {exc.strerror or exc}") from None

    return run


@_one_line
def cmd_push(args: argparse.Namespace) -> int:
    if args.to_hf:
        hf.require_online()  # before anything is written
    hub = _hub(args.hub)
    version = hub.push(args.root, args.repo_id)
    twin = hub.twin(version)
    out = {**_describe(version), "latest": str(hub.link(args.repo_id)), "same_as": twin.tag if twin else None}
    if not args.json:
        same = f", same content as {twin.tag}" if twin else ""
        print(
            f"pushed {args.repo_id} {version.tag} to {version.path} ({_counts(out)}{same}); "
            f"LeRobotDataset({args.repo_id!r}, root={out['latest']!r}) loads the newest"
        )
    if args.to_hf:
        try:
            out["hf_url"] = hf.push_version(args.repo_id, version.path, private=args.private)
        except GloverecError as exc:
            out["hf_error"] = str(exc)
            if args.json:
                print(json.dumps(out))
            raise GloverecError(f"{exc} (the local push of {version.tag} succeeded)") from None
        if not args.json:
            print(f"pushed to {out['hf_url']}")
    if args.json:
        print(json.dumps(out))
    return 0


@_one_line
def cmd_hub_list(args: argparse.Namespace) -> int:
    hub = _hub(args.hub)
    repos = [
        {
            "repo_id": rid,
            "latest": hub.latest(rid),
            "path": str(hub.link(rid)),
            "versions": [_describe(v) for v in hub.versions(rid)],
        }
        for rid in hub.repo_ids()
    ]
    if args.json:
        print(json.dumps(repos))
    elif not repos:
        print(f"no datasets in {hub.root}")
    for repo in [] if args.json else repos:
        n = len(repo["versions"])
        print(f"{repo['repo_id']}  latest {repo['latest'] or '-'}  ({n} version{'' if n == 1 else 's'})")
        for v in repo["versions"]:
            detail = f"damaged: {v['damaged']}" if v["damaged"] else f"{v['created']}  {_counts(v)}"
            print(f"  {v['version']}  {detail}")
    return 0


@_one_line
def cmd_hub_verify(args: argparse.Namespace) -> int:
    hub = _hub(args.hub)
    report = hub.verify(args.repo_id, args.version)
    if args.json:
        print(
            json.dumps(
                {
                    "hub": str(hub.root),
                    "ok": report.ok,
                    "cleaned": report.cleaned,
                    "relinked": report.relinked,
                    "errors": report.errors,
                    "versions": [
                        {
                            "repo_id": c.version.repo_id,
                            "version": c.version.tag,
                            "path": str(c.version.path),
                            "ok": c.ok,
                            "files": c.files,
                            "problem": c.problem or None,
                            **c.damage.as_dict(),
                        }
                        for c in report.checks
                    ],
                }
            )
        )
    else:
        for c in report.checks:
            print(f"{'ok' if c.ok else 'DAMAGED':8} {c.version.repo_id} {c.version.tag}: {c.describe()}")
        for name in report.cleaned:
            print(f"removed {name}, left by an interrupted command")
        for line in report.relinked:
            print(f"relinked {line} (an interrupted push had left the link behind)")
        for line in report.errors:
            print(f"DAMAGED  {line}")
        if not report.checks:
            print(f"nothing to verify in {hub.root}")
    if not report.ok:
        bad = [f"{c.version.repo_id} {c.version.tag} ({c.describe()})" for c in report.checks if not c.ok]
        bad += report.errors
        raise GloverecError(f"hub verify: {len(bad)} problem(s) in {hub.root}: {'; '.join(bad)}")
    return 0


@_one_line
def cmd_hub_pull(args: argparse.Namespace) -> int:
    hub = _hub(args.hub)
    version = hub.pull(args.repo_id, args.version, args.root)
    out = {**_describe(version), "root": args.root}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"pulled {args.repo_id} {version.tag} into {args.root} ({_counts(out)}, every byte checked)")
    return 0


def _describe(version) -> dict:
    """A version as plain data, from its manifest (``damaged`` says why when the manifest is unusable)."""
    out = {"repo_id": version.repo_id, "version": version.tag, "path": str(version.path), "damaged": None}
    try:
        m = version.manifest()
    except GloverecError as exc:
        return {**out, "damaged": str(exc)}
    ds = m.get("dataset") or {}
    return {
        **out,
        "created": m.get("created"),
        "files": len(m["files"]),
        "bytes": sum(f["size"] for f in m["files"].values()),
        "episodes": ds.get("total_episodes"),
        "frames": ds.get("total_frames"),
        "fps": ds.get("fps"),
    }


def _counts(v: dict) -> str:
    return f"{v['episodes']} episodes, {v['frames']} frames, {v['files']} files, {_size(v['bytes'])}"


def _size(n: float) -> str:
    units, i = ("B", "kB", "MB", "GB", "TB"), 0
    while n >= 1000 and i < len(units) - 1:
        n, i = n / 1000, i + 1
    return f"{n:.0f} B" if i == 0 else f"{n:.1f} {units[i]}"


def _hub(folder):
    from recorder.hub.store import Hub  # pyarrow: not at start-up

    return Hub(folder)
