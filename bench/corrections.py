"""Do corrections pay? Takeover recording (HG-DAgger) against fresh demonstrations, the same recording effort.

    .venv/bin/python bench/corrections.py [--task grasp] [--robot glovehand] [--demos 20] [--rounds 2]
                                          [--per-round 10] [--steps 3000] [--eval-episodes 100]

With the gloverec commands a user runs (each in a child process):
  record --demos human-like demonstrations (--demonstrator human, failure rate 0.15; seeds 0..) -> train BC -> P0
  takeover arm, each round r: `gloverec record --policy P(r-1) --takeover` for --per-round episodes (seeds after
      the demonstrations'; the wearer: the human-like demonstrator trying to succeed, --failure-rate 0), then train
      BC on the demonstrations and every round's takeover recording (`--also`) -> P(r)
  fresh arm, each round r: --per-round more human-like demonstrations on the same seeds (the same recorded
      frames: the task's episodes have a fixed length) -> train on all of them -> F(r)
  -> eval every policy on --eval-episodes unseen seeds (100000..); each policy is trained with --train-seeds seeds
     (BC on 10-40 episodes varies with its initialisation) and their successes pooled, with the Wilson 95 % interval.
Writes bench/results/corrections.json and the plot bench/results/corrections.png.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS, gloverec, wilson, write_results  # noqa: E402

EVAL_SEED = 100_000  # bench/learning.py's: seeds no demonstration was recorded with

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")


def record(args, root: Path, seed: int, episodes: int, failure_rate: float, *extra: str) -> dict:
    if (root / "meta" / "info.json").is_file():  # --work: made by an earlier run
        eps = _records(root)
        return {"root": str(root), "episodes": len(eps), "frames": sum(e["frames"] for e in eps),
                "success_rate": round(sum(e["success"] for e in eps) / len(eps), 3)}  # fmt: skip
    out = gloverec("record", "--view", "none", "--glove", "emulator", "--task", args.task, "--robot", args.robot,
                   "--episodes", str(episodes), "--root", str(root), "--repo-id", f"bench/{root.name}",
                   "--seed", str(seed), "--fast", "--no-log", "--demonstrator", "human",
                   "--failure-rate", str(failure_rate), *extra)  # fmt: skip
    return {"root": str(root), "episodes": out["episodes_saved"], "frames": out["total_frames"],
            "success_rate": out["success_rate"]}  # fmt: skip


def train_eval(args, name: str, first: dict, also: list[dict], tmp: Path) -> tuple[dict, Path]:
    """Policy ``name`` trained with --train-seeds seeds, each evaluated: the pooled row, and the first seed's policy
    (the one the next takeover round runs)."""
    rows = [_train_eval_seed(args, name, seed, first, also, tmp) for seed in range(args.train_seeds)]
    row = dict(rows[0])
    if len(rows) > 1:
        successes, episodes = sum(r["successes"] for r in rows), sum(r["episodes"] for r in rows)
        row.update(successes=successes, episodes=episodes, success_rate=round(successes / episodes, 4),
                   wilson95=wilson(successes, episodes), per_seed=[r["success_rate"] for r in rows])  # fmt: skip
        print(f"  {name}, {len(rows)} seeds pooled: {row['success_rate']:.0%} {row['wilson95']}", flush=True)
    return row, tmp / "runs" / name


def _train_eval_seed(args, name: str, seed: int, first: dict, also: list[dict], tmp: Path) -> dict:
    out = tmp / "runs" / (name if seed == 0 else f"{name}_seed{seed}")
    if (out / "eval.json").is_file():  # --work: trained and evaluated by an earlier run
        return json.loads((out / "eval.json").read_text())
    t = time.perf_counter()
    trained = gloverec("train", "--repo-id", "bench/demos", "--root", first["root"], "--steps", str(args.steps),
                       "--seed", str(seed), "--out", str(out), "--inputs", "state,environment",
                       *(["--also", *(a["root"] for a in also)] if also else []))  # fmt: skip
    train_s = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--task", args.task, "--robot", args.robot, "--episodes",
                  str(args.eval_episodes), "--seed", str(EVAL_SEED))  # fmt: skip
    row = {
        "policy": name,
        "train_episodes": trained["train_episodes"],
        "train_frames": trained["train_frames"],
        "frames_by_wearer": trained["frames_by_wearer"],
        "frames_by_policy": trained["frames_by_policy"],
        "train_s": round(train_s, 1),
        "success_rate": ev["success_rate"],
        "successes": ev["successes"],
        "episodes": ev["episodes"],
        "wilson95": wilson(ev["successes"], ev["episodes"]),
    }
    print(f"  {name} (training seed {seed}): {row['success_rate']:.0%} {row['wilson95']}", flush=True)
    (out / "eval.json").write_text(json.dumps(row))
    return row


def _records(root: Path) -> list[dict]:
    lines = (root / "meta" / "gloverec" / "episodes.jsonl").read_text().splitlines()
    return [json.loads(x) for x in lines if x.strip()]


def takeover_stats(rec: dict) -> dict:
    """Who drove the takeover episodes (their records in meta/gloverec/episodes.jsonl)."""
    eps = _records(Path(rec["root"]))
    taken = [e["takeover"] for e in eps]
    return {
        "episodes_taken_over": sum(t["interventions"] > 0 for t in taken),
        "frames_by_wearer": sum(t["frames_by_wearer"] for t in taken),
        "frames": sum(e["frames"] for e in eps),
        "success_rate": rec["success_rate"],
    }


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4), dpi=100)
    for arm, colour in (("takeover", "#d6604d"), ("fresh", "#4393c3")):
        pts = [r for r in rows if r["arm"] in (arm, "start")]
        x = [r["frames_recorded"] for r in pts]
        y = [100 * r["success_rate"] for r in pts]
        lo = [100 * (r["success_rate"] - r["wilson95"][0]) for r in pts]
        hi = [100 * (r["wilson95"][1] - r["success_rate"]) for r in pts]
        label = "takeover rounds (HG-DAgger)" if arm == "takeover" else "fresh human-like demonstrations"
        ax.errorbar(x, y, yerr=[lo, hi], marker="o", capsize=4, color=colour, label=label)
    ax.set_xlabel("frames recorded (demonstrations + later rounds)")
    ax.set_ylabel("BC success, % (Wilson 95 %)")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="grasp")
    p.add_argument("--robot", default="glovehand")
    p.add_argument("--demos", type=int, default=20)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--per-round", type=int, default=10)
    p.add_argument("--steps", type=int, default=3000, help="BC training steps")
    p.add_argument("--eval-episodes", type=int, default=100)
    p.add_argument("--train-seeds", type=int, default=3, help="BC trained with seeds 0..N-1, successes pooled (the "
                   "takeover rounds run seed 0's policy)")  # fmt: skip
    p.add_argument("--failure-rate", type=float, default=0.15, help="the demonstrations' (the corrections': 0)")
    p.add_argument("--threshold", type=float, default=None, help="--takeover-threshold (default: the recorder's)")
    p.add_argument("--work", help="keep the datasets and policies in this folder (default: a temporary one)")
    args = p.parse_args()
    t0 = time.perf_counter()
    rows, rounds = [], []
    with tempfile.TemporaryDirectory(prefix="gloverec-corrections-") as tmp_name:
        tmp = Path(args.work or tmp_name)
        print(f"[{args.task} on {args.robot}]", flush=True)
        demos = record(args, tmp / "demos", 0, args.demos, args.failure_rate)
        start, policy = train_eval(args, "P0", demos, [], tmp)
        rows.append({"arm": "start", "round": 0, "frames_recorded": demos["frames"], **start})
        takeovers, fresh = [], []
        frames = {"takeover": demos["frames"], "fresh": demos["frames"]}
        for r in range(1, args.rounds + 1):
            seed = args.demos + (r - 1) * args.per_round
            extra = ["--takeover-threshold", str(args.threshold)] if args.threshold else []
            t = record(args, tmp / f"takeover{r}", seed, args.per_round, 0.0, "--policy", str(policy),
                       "--takeover", *extra)  # fmt: skip
            takeovers.append(t)
            frames["takeover"] += t["frames"]
            row, policy = train_eval(args, f"P{r}", demos, takeovers, tmp)
            rows.append({"arm": "takeover", "round": r, "frames_recorded": frames["takeover"], **row})
            f = record(args, tmp / f"fresh{r}", seed, args.per_round, args.failure_rate)
            fresh.append(f)
            frames["fresh"] += f["frames"]
            row, _ = train_eval(args, f"F{r}", demos, fresh, tmp)
            rows.append({"arm": "fresh", "round": r, "frames_recorded": frames["fresh"], **row})
            rounds.append({"round": r, "takeover": takeover_stats(t), "fresh_success_rate": f["success_rate"]})
    png = RESULTS / "corrections.png"
    RESULTS.mkdir(parents=True, exist_ok=True)
    plot(rows, png)
    last = {arm: next(r for r in reversed(rows) if r["arm"] == arm) for arm in ("takeover", "fresh")}
    write_results("corrections", {
        "task": args.task, "robot": args.robot, "demonstrations": args.demos, "per_round": args.per_round,
        "failure_rate": args.failure_rate, "steps": args.steps, "eval_seeds_from": EVAL_SEED, "rows": rows,
        "rounds": rounds, "start_success": rows[0]["success_rate"],
        "gain": {arm: round(last[arm]["success_rate"] - rows[0]["success_rate"], 3) for arm in last},
        "corrections_pay": last["takeover"]["success_rate"] > last["fresh"]["success_rate"],
        "plot": str(png), "wall_s": round(time.perf_counter() - t0, 1),
    })  # fmt: skip


if __name__ == "__main__":
    main()
