"""`gloverec inspect`: what a recording holds, how well its glove and loop kept time, and a plot of the
commanded action against the resulting joint state, per joint, for one episode. `gloverec carry-meta` and
`gloverec merge`: gloverec's episode records through LeRobot's dataset edits."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from recorder import GloverecError, loading
from recorder.dataset_check import check_dataset
from recorder.lerobot_names import gloverec_action_name, gloverec_names
from recorder.record.config import REPO_ID
from recorder.record.sidecar import SIDECAR, carry_sidecar, episode_notes, read_sidecar
from recorder.video_backend import video_backend

COLUMNS = (
    "frames",
    "success",
    "glove_late",
    "glove_dropped",
    "loop_overruns",
    "jitter_ms_p99",
    "latency_ms_p99",
    "retarget_error_mm_mean",
)


def load_meta(repo_id: str, root: Path):
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata  # inspect is a CLI module: not at start-up

    if not (root / "meta" / "info.json").is_file():
        raise GloverecError(f"{root} is not a LeRobot dataset (no meta/info.json)")
    try:
        return LeRobotDatasetMetadata(repo_id, root=root)
    except Exception as exc:  # a damaged dataset: say what, in one line
        raise GloverecError(f"cannot read {root}: {type(exc).__name__}: {str(exc).splitlines()[0]}") from None


def episodes_table(meta) -> list[dict]:
    """Per episode of ``meta`` (a dataset's LeRobotDatasetMetadata): frames, length, task and our sidecar's
    columns."""
    side = {s["episode_index"]: s for s in read_sidecar(Path(meta.root))}
    rows = []
    for e in range(meta.total_episodes):
        ep = meta.episodes[e]
        s = side.get(e, {})
        rows.append(
            {
                "episode": e,
                "frames": int(ep["length"]),
                "seconds": round(ep["length"] / meta.fps, 2),
                "task": ep["tasks"][0] if len(ep["tasks"]) else "",
                **{k: s.get(k) for k in COLUMNS if k != "frames"},
                "demonstration": s.get("demonstration"),  # the human-like demonstrator's intent, if it made the take
                "physics_unstable_s": s.get("physics_unstable_s"),  # when MuJoCo reset a blown-up simulation
                "notes": episode_notes(s),  # a takeover's share, a blow-up
            }
        )
    return rows


def action_state_pairs(action_names, state_names, robot: str | None) -> list[tuple[int, int]]:
    """(action column, state column) of each actuator and the joint it drives (action names in either naming:
    recorder/lerobot_names.py)."""
    joints = None
    if robot:
        try:
            from envs.robots import load_robot  # mujoco: only when a robot is named

            m = load_robot(robot).model
            joints = [m.joint(m.actuator_trnid[i, 0]).name for i in range(m.nu)]
        except (ValueError, KeyError, IndexError):
            joints = None
    pairs = []
    for a, name in enumerate(action_names):
        joint = joints[a] if joints is not None and a < len(joints) else gloverec_action_name(name)
        if f"{joint}.pos" in state_names:
            pairs.append((a, state_names.index(f"{joint}.pos")))
    return pairs


def _extra_panels(a_names, s_names, action, state, data, features) -> list:
    """Beyond the joints: the palm's rotation (the action's rotation vector against the palm's orientation, as one),
    and the task's angles (HandTurn's knob against its target), in degrees."""
    from recorder import quat  # numpy only

    panels = []
    rot = [f"base.r{a}" for a in "xyz"]
    palm = [f"palm.q{c}" for c in "wxyz"]
    if all(n in a_names for n in rot) and all(n in s_names for n in palm):
        turned = np.degrees(action[:, [a_names.index(n) for n in rot]])
        held = np.degrees([quat.to_rotvec(q) for q in state[:, [s_names.index(n) for n in palm]]])
        for i, axis in enumerate("xyz"):
            panels.append((f"palm rotation about {axis}", [("action (target)", turned[:, i]), ("state", held[:, i])]))
    names = (features.get("observation.environment_state") or {}).get("names") or []
    angles = [i for i, n in enumerate(names) if n.endswith(".angle")]
    if angles:
        env = np.stack(data["observation.environment_state"])
        panels.append(("the task's angles", [(names[i], np.degrees(env[:, i])) for i in angles]))
    return panels


def plot_episode(meta, episode: int, out: Path) -> Path:
    """A PNG grid: per actuated joint, the action (target) and the joint position it produced (``meta``: the
    dataset's LeRobotDatasetMetadata, read once by the caller)."""
    import matplotlib  # the Agg backend must be chosen before pyplot loads: both here

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # not at start-up

    if not 0 <= episode < meta.total_episodes:
        raise GloverecError(f"no episode {episode}: the dataset has episodes 0-{meta.total_episodes - 1}")
    ds = LeRobotDataset(meta.repo_id, root=meta.root, episodes=[episode], video_backend=video_backend())
    data = ds.hf_dataset.with_format("numpy")
    action, state = np.stack(data["action"]), np.stack(data["observation.state"])
    t = np.asarray(data["timestamp"])
    names = gloverec_names({k: meta.features[k]["names"] for k in ("action", "observation.state")})
    a_names, s_names = names["action"], names["observation.state"]
    pairs = action_state_pairs(a_names, s_names, meta.robot_type)
    if not pairs:
        raise GloverecError("cannot pair actions with joint states in this dataset")
    panels = [(a_names[a], [("action (target)", np.degrees(action[:, a])), ("state", np.degrees(state[:, s]))])
              for a, s in pairs]  # fmt: skip
    panels += _extra_panels(a_names, s_names, action, state, data, meta.features)
    cols = 5
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.2 * rows), sharex=True, squeeze=False)
    for ax, (title, lines) in zip(axes.flat, panels):
        for label, series in lines:
            ax.plot(t, series, label=label, lw=1.2)
        ax.set_title(title, fontsize=8)
        ax.tick_params(labelsize=7)
        if len(lines) > 2 or lines[0][0] != "action (target)":
            ax.legend(fontsize=6)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.supxlabel("time (s)")
    fig.supylabel("degrees")
    fig.suptitle(f"{meta.repo_id} episode {episode}: action vs joint state")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out


def add_parsers(sub) -> None:
    p = sub.add_parser("inspect", help="episodes, lengths, sync quality, and an action-vs-state plot")
    p.add_argument("--repo-id", required=True, help="the dataset, USER/NAME")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--root", help="a recording folder (default datasets/recordings/USER/NAME)")
    where.add_argument("--hub", help="a local hub folder: the dataset is HUB/USER/NAME")
    p.add_argument("--episode", type=int, default=0, help="episode to plot (default 0)")
    p.add_argument("--plot", metavar="FILE.png", help="write the plot of --episode's actions and states there")
    p.add_argument("--no-plot", action="store_true", help="no plot (the default without --plot; kept for old scripts)")
    p.add_argument("--json", action="store_true", help="print one JSON object: the episodes and the plot's path")
    p.set_defaults(func=run)

    c = sub.add_parser(
        "carry-meta",
        help="give a dataset edited by lerobot-edit-dataset back gloverec's episode metadata (seeds, success, ...)",
        description="lerobot-edit-dataset's delete_episodes, split and merge write datasets without gloverec's "
        f"episode records ({SIDECAR}: seeds for replay, success, glove figures). This writes them again from the "
        "datasets the edited one was made from, matching each episode by its length and first frame's time.",
    )
    c.add_argument("--root", required=True, help="the edited dataset")
    c.add_argument(
        "--from", dest="sources", nargs="+", required=True, metavar="ORIGINAL", help="the dataset(s) it was made from"
    )
    c.set_defaults(func=run_carry)

    m = sub.add_parser(
        "merge",
        help="merge datasets into one (LeRobot's merge, then carry-meta); datasets that differ are refused",
        description="LeRobot's merge_datasets (as lerobot-edit-dataset --operation.type=merge) with gloverec's "
        "episode records carried over. The datasets must have the same fps, robot and features: a dataset recorded "
        "with a tracker (--wrist) and one without differ in their action (docs/wrist.md).",
    )
    m.add_argument("--root", required=True, help="the merged dataset (a new folder)")
    m.add_argument("--from", dest="sources", nargs="+", required=True, metavar="DATASET", help="the datasets to merge")
    m.set_defaults(func=run_merge)


def run_carry(args) -> int:
    for root in (args.root, *args.sources):
        if not (Path(root) / "meta" / "info.json").is_file():
            raise GloverecError(f"{root} is not a LeRobot dataset (no meta/info.json)")
    if not any(read_sidecar(src) for src in args.sources):
        raise GloverecError(f"{' '.join(args.sources)}: no gloverec episode records ({SIDECAR}) to carry")
    matched, total = carry_sidecar(args.root, args.sources)
    print(f"{matched} of {total} episodes of {args.root} matched an episode of {' '.join(args.sources)}")
    return 0 if matched else 1


def run_merge(args) -> int:
    out = Path(args.root)
    if out.exists():
        raise GloverecError(f"{out} already exists: merge into a new folder")
    summary = merge(out, [Path(src) for src in args.sources])
    print(f"{out}: {summary['episodes']} episodes, {summary['frames']} frames from {len(args.sources)} datasets; "
          f"gloverec's records carried for {summary['records_carried']}")  # fmt: skip
    return 0


def merge(out: Path, sources: list[Path]) -> dict:
    """LeRobot's merge_datasets of ``sources`` (in order) into the new folder ``out``, gloverec's records carried;
    datasets that differ in fps, robot or features are refused in one line."""
    from lerobot.datasets.dataset_tools import merge_datasets  # torch and LeRobot: not at start-up
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    metas = [load_meta(f"local/{src.name}", src) for src in sources]
    first, src0 = metas[0], sources[0]
    for meta, src in zip(metas[1:], sources[1:]):
        if (meta.fps, meta.robot_type) != (first.fps, first.robot_type):
            raise GloverecError(f"cannot merge {src0} ({first.robot_type}, {first.fps} fps) and {src} "
                                f"({meta.robot_type}, {meta.fps} fps)")  # fmt: skip
        diff = feature_differences(first.features, meta.features, str(src0), str(src))
        if diff:
            raise GloverecError(f"cannot merge {src0} and {src}: their features differ ({diff})")
    datasets = [LeRobotDataset(f"local/{src.name}", root=src, video_backend=video_backend()) for src in sources]
    merged = merge_datasets(datasets, f"local/{out.name}", out)
    matched = carry_sidecar(out, sources)[0] if any(read_sidecar(src) for src in sources) else 0
    return {"episodes": merged.meta.total_episodes, "frames": merged.meta.total_frames, "records_carried": matched}


def feature_differences(a: dict, b: dict, name_a: str, name_b: str) -> str:
    """What differs between two datasets' features, in a few words ("" when they can be merged: LeRobot's rule)."""
    from lerobot.datasets.feature_utils import features_equal_for_merge  # LeRobot: not at start-up

    def size(f: dict) -> str:
        return "x".join(map(str, f["shape"]))

    both = sorted(set(a) & set(b))
    parts = [f"{k}: {size(a[k])} vs {size(b[k])}" if a[k]["shape"] != b[k]["shape"] else f"{k}: differs"
             for k in both if not features_equal_for_merge({k: a[k]}, {k: b[k]})]  # fmt: skip
    parts += [
        f"only in {n}: {', '.join(sorted(set(x) - set(y)))}"
        for n, x, y in ((name_a, a, b), (name_b, b, a))
        if set(x) - set(y)
    ]
    text = "; ".join(parts)
    if "observation.wrist" in set(a) ^ set(b):
        text += "; one was recorded with a tracker (--wrist) and one without, see docs/wrist.md"
    return text


def dataset_root(repo_id: str, root: str | None, hub: str | None) -> Path:

    if not REPO_ID.match(repo_id) or ".." in repo_id:
        raise GloverecError(f"bad repo id {repo_id!r}: expected USER/NAME (letters, digits, . _ -)")
    if hub:
        return Path(hub) / repo_id
    return Path(root) if root else Path("datasets/recordings") / repo_id


def _meant(demonstration: dict | None) -> str:
    failure = (demonstration or {}).get("failure")
    return f"  [meant to fail: {failure}]" if failure else ""


def run(args) -> int:
    root = dataset_root(args.repo_id, args.root, args.hub)
    if not root.exists():
        raise GloverecError(f"no dataset at {root}")
    check_dataset(root)  # a damaged dataset: one line saying what is wrong, before lerobot reads it
    loading("LeRobot")
    meta = load_meta(args.repo_id, root)
    rows = episodes_table(meta)
    plot = None
    if args.plot and not args.no_plot and rows:  # only where asked: nothing is written beside the dataset unasked
        plot = Path(args.plot)
        plot_episode(meta, args.episode, plot)
    if args.json:
        print(json.dumps({"root": str(root), "episodes": rows, "plot": str(plot) if plot else None}))
        return 0
    head = ("ep", "frames", "s", "ok", "late", "drop", "overrun", "jitter99", "lat99", "retarget", "task")
    print(("{:>3} {:>6} {:>5} {:>3} {:>5} {:>5} {:>7} {:>8} {:>6} {:>8}  {}").format(*head))
    for r in rows:

        def f(v, nd=1):
            return "-" if v is None else (f"{v:.{nd}f}" if isinstance(v, float) else str(v))

        print(
            f"{r['episode']:>3} {r['frames']:>6} {r['seconds']:>5} {_yes_no(r['success']):>3} "
            f"{f(r['glove_late']):>5} {f(r['glove_dropped']):>5} {f(r['loop_overruns']):>7} "
            f"{f(r['jitter_ms_p99'], 2):>8} {f(r['latency_ms_p99']):>6} {f(r['retarget_error_mm_mean']):>8}  "
            f"{r['task']}{_meant(r['demonstration'])}{''.join(f'  [{n}]' for n in r['notes'])}"
        )
    if plot:
        print(f"plot of episode {args.episode}: {plot}")
    return 0


def _yes_no(flag) -> str:
    return "-" if flag is None else "y" if flag else "n"
