"""Generation benchmark: how far do a person's 10 glove demonstrations go once `gloverec generate` multiplies them?

    .venv/bin/python bench/generate.py [--tasks relocate,pick,turn] [--robots glovehand,shadow] [--sources 10]
                                       [--sizes 50,200,1000] [--human 50] [--eval-episodes 50]

For each task (one with a segmentation) and robot, with the gloverec commands a user runs (each in a child process):
  record --sources human-like takes (`--demonstrator human --failure-rate 0.15`, seeds 0.., the emulated glove
  through the whole recording path; a free-wrist task with `--wrist marker:emulated`)
  -> generate the --sizes from them: the first size, then each next one's extra episodes as another dataset on the
     seeds after (generation is per seed, so 50 + 150 more are the first 200 of one run), timing each
  -> train BC with history (configs/train/history.yaml, the policies issue's best; --inputs state,environment) on
     each size (the later chunks through `train --also`), and evaluate it on --eval-episodes unseen seeds
     (100000..; the generated scenes use 10000.., the recordings 0..)
  -> the same BC on --human recorded human-like takes (seeds 0..), where affordable (--human 0: not measured)
Writes bench/results/generate.json (rows of other task/robot pairs already there are kept) and the learning curves,
docs/images/generate_curve.png (docs/policies.md shows them).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, gloverec, merged_with_previous, wilson, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

GOALS = {"relocate": 0.90, "pick": 0.90, "grasp": 0.90, "turn": 0.80, "pinch": 0.80}
STEPS = {"relocate": 10_000, "pick": 10_000, "turn": 5_000}
FREE_WRIST = ("relocate", "pick")
EVAL_SEED = 100_000
GEN_SEED = 10_000
HISTORY = str(REPO / "configs" / "train" / "history.yaml")
INPUTS = "state,environment"
CURVE = REPO / "docs" / "images" / "generate_curve.png"  # docs/policies.md shows it (bench/results/*.png: not kept)
PERSON_TAKE_S = 15.0  # a person's take with its reset (the issue: 10-20 s each)


def record(task: str, robot: str, n: int, root: Path, failure_rate: float) -> dict:
    wrist = ["--wrist", "marker:emulated"] if task in FREE_WRIST else []
    t = time.perf_counter()
    out = gloverec("record", "--view", "none", "--glove", "emulator", "--task", task, "--robot", robot, "--episodes",
                   str(n), "--root", str(root), "--repo-id", f"bench/{task}_{robot}_{n}", "--seed", "0", "--fast",
                   "--no-log", "--demonstrator", "human", "--failure-rate", str(failure_rate), *wrist)  # fmt: skip
    out["wall_s"] = round(time.perf_counter() - t, 1)
    return out


def train_eval(task: str, robot: str, datasets: list[Path], out: Path, eval_episodes: int, steps: int | None) -> dict:
    first, also = datasets[0], datasets[1:]
    t = time.perf_counter()
    trained = gloverec("train", "--repo-id", f"bench/{first.name}", "--root", str(first), "--out", str(out),
                       "--config", HISTORY, "--inputs", INPUTS, "--steps", str(steps or STEPS.get(task, 5000)),
                       *(["--also", *map(str, also)] if also else []))  # fmt: skip
    train_s = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--task", task, "--robot", robot, "--episodes", str(eval_episodes),
                  "--seed", str(EVAL_SEED))  # fmt: skip
    return {
        "train_episodes": trained["train_episodes"],
        "train_wall_s": round(train_s, 1),
        "successes": ev["successes"],
        "eval_episodes": ev["episodes"],
        "success_rate": ev["success_rate"],
        "wilson95": wilson(ev["successes"], ev["episodes"]),
    }


def one(task: str, robot: str, args, tmp: Path) -> dict:
    src = record(task, robot, args.sources, tmp / f"src_{task}_{robot}", args.failure_rate)
    good = round(src["success_rate"] * src["total_episodes"])
    print(f"  {task}/{robot}: {good}/{src['total_episodes']} human-like takes succeeded", flush=True)
    chunks, seed, curve, made = [], GEN_SEED, [], 0
    for size in args.sizes:
        root = tmp / f"gen_{task}_{robot}_{size}"
        g = gloverec("generate", "--from", src["root"], "--out", str(root), "--episodes", str(size - made),
                     "--seeds", str(seed), "--max-attempts", str(10 * (size - made)), "--repo-id",
                     f"bench/gen_{task}_{robot}_{size}")  # fmt: skip
        chunks.append({k: g[k] for k in ("accepted", "attempts", "acceptance_rate", "wall_s", "accepted_per_min",
                                         "rejected_because", "seeds")})  # fmt: skip
        seed, made = g["seeds"][1] + 1, size
        datasets = [tmp / f"gen_{task}_{robot}_{s}" for s in args.sizes[: len(chunks)]]
        r = train_eval(
            task, robot, datasets, tmp / "runs" / f"{task}_{robot}_gen{size}", args.eval_episodes, args.steps
        )
        curve.append({**r, "episodes": size})
        print(f"  {task}/{robot}: {size} generated -> {r['success_rate']:.0%} {r['wilson95']}", flush=True)
    attempts = sum(c["attempts"] for c in chunks)
    accepted = sum(c["accepted"] for c in chunks)
    wall = sum(c["wall_s"] for c in chunks)
    human = []
    if args.human:
        rec = record(task, robot, args.human, tmp / f"human_{task}_{robot}", args.failure_rate)
        r = train_eval(task, robot, [Path(rec["root"])], tmp / "runs" / f"{task}_{robot}_human", args.eval_episodes,
                       args.steps)  # fmt: skip
        human.append({**r, "episodes": args.human, "takes_successful": rec["success_rate"]})
        print(f"  {task}/{robot}: {args.human} human-like takes -> {r['success_rate']:.0%}", flush=True)
    best = max(curve, key=lambda c: c["episodes"])
    return {
        "task": task,
        "robot": robot,
        "sources": {
            "takes": src["total_episodes"],
            "successful": good,
            "record_wall_s": src["wall_s"],
            "person_minutes": round(args.sources * PERSON_TAKE_S / 60, 1),
        },  # fmt: skip
        "generation": {
            "chunks": chunks,
            "acceptance_rate": accepted / attempts if attempts else 0.0,
            "accepted_per_min": round(60 * accepted / wall, 1) if wall else 0.0,
            "s_per_accepted": round(wall / accepted, 2) if accepted else None,
        },
        "curve": curve,
        "human": human,
        "goal": GOALS.get(task),
        "met": best["success_rate"] >= GOALS.get(task, 1.0),
    }


def plot(rows: dict, path: Path) -> None:
    """One panel per task: success against training episodes, generated (a line per robot, from its person's few
    takes) and recorded human-like takes (squares), each with its Wilson interval; the legend says the person's
    minutes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = sorted({row["task"] for row in rows.values()})
    fig, axes = plt.subplots(1, len(tasks), figsize=(max(7.0, 4.2 * len(tasks)), 3.8), squeeze=False, sharey=True)
    for ax, task in zip(axes[0], tasks, strict=True):
        for row in (r for _, r in sorted(rows.items()) if r["task"] == task):
            n = [c["episodes"] for c in row["curve"]]
            p = [100 * c["success_rate"] for c in row["curve"]]
            lo = [100 * c["wilson95"][0] for c in row["curve"]]
            hi = [100 * c["wilson95"][1] for c in row["curve"]]
            takes = row["sources"]["takes"]
            line = ax.plot(n, p, "o-", label=f"{row['robot']}: generated from {takes} takes "
                           f"({takes * PERSON_TAKE_S / 60:.1f} min of a person)")[0]  # fmt: skip
            ax.fill_between(n, lo, hi, color=line.get_color(), alpha=0.12)
            for h in row.get("human", []):
                err = [[100 * (h["success_rate"] - h["wilson95"][0])], [100 * (h["wilson95"][1] - h["success_rate"])]]
                ax.errorbar([h["episodes"] * 1.12], [100 * h["success_rate"]], yerr=err, fmt="s", mfc="none",
                            color=line.get_color(), label=f"{row['robot']}: {h['episodes']} recorded takes "
                            f"({h['episodes'] * PERSON_TAKE_S / 60:.1f} min)")  # fmt: skip
        goal = GOALS.get(task)
        if goal:
            ax.axhline(100 * goal, color="grey", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_title(task)
        ax.set_xlabel("training episodes (log)")
        ax.set_ylim(0, 102)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, loc="lower right")
    axes[0][0].set_ylabel("success, 50 unseen seeds (%; Wilson 95 %)")
    fig.suptitle("BC + history trained on generated demonstrations (bench/generate.py); dotted: the goal", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", default="relocate,pick,turn")
    ap.add_argument("--robots", default="glovehand,shadow")
    ap.add_argument("--sources", type=int, default=10)
    ap.add_argument("--sizes", default="50,200,1000")
    ap.add_argument("--human", type=int, default=50)
    ap.add_argument("--eval-episodes", type=int, default=50)
    ap.add_argument("--failure-rate", type=float, default=0.15)
    ap.add_argument("--steps", type=int, help="training steps (default: the task's, STEPS)")
    args = ap.parse_args()
    args.sizes = sorted(int(s) for s in args.sizes.split(","))
    with tempfile.TemporaryDirectory(prefix="gloverec-generate-") as tmp:
        for task in args.tasks.split(","):
            for robot in args.robots.split(","):
                row = one(task, robot, args, Path(tmp))
                results = merged_with_previous("generate", {"rows": {f"{task}/{robot}": row}})  # each row as it ends
                write_results("generate", results)
                plot(results["rows"], CURVE)


if __name__ == "__main__":
    main()
