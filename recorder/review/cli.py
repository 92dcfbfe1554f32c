"""`gloverec review`: its flags, and serving the page until Ctrl-C."""

from __future__ import annotations

import os

import annotated_types as at

from recorder.argtypes import number

PORT = number(int, at.Ge(0), at.Le(65535))


def add_parser(sub) -> None:
    p = sub.add_parser(
        "review",
        help="review a dataset in a local web page: watch, plot, keep or discard, trim, relabel, publish",
        description="Serve a page listing the dataset's episodes with a player and joint plots; keep or discard, "
        "trim and relabel them, then publish: the hub's next version (--hub), or a new folder (--root: --out, "
        "default ROOT-reviewed). Nothing changes until Publish. Serves until Ctrl-C.",
    )
    p.add_argument("--repo-id", required=True, help="dataset id, USER/NAME")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--root", help="a recording folder (default datasets/recordings/USER/NAME)")
    where.add_argument("--hub", help="a local hub folder: review its version of the dataset")
    p.add_argument("--version", help="with --hub: the version to review, vN (default: the newest)")
    p.add_argument("--out", help="with --root: where Publish writes the reviewed dataset, a new folder "
                   "(default: ROOT-reviewed)")  # fmt: skip
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=PORT, default=8766, help="port (default 8766; 0: any free one)")
    p.add_argument("--no-browser", action="store_true", help="do not open the page in a browser")
    p.set_defaults(func=run)


def run(args) -> int:
    from recorder import GloverecError
    from recorder.review.server import Review
    from recorder.review.session import Session

    if args.version and not args.hub:
        raise GloverecError("--version names a hub version: pass --hub too")
    session = Session(args.repo_id, root=args.root, hub=args.hub, version=args.version, out=args.out)
    review = Review(session, args.host, args.port)
    print(f"review: {review.url}", flush=True)
    if not args.no_browser and (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        import webbrowser

        webbrowser.open(review.url)
    try:
        review.serve()
    except KeyboardInterrupt:
        pass
    return 0
