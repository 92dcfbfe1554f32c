"""DAgger with the demonstrator as the expert: does labelling the policy's own states finish the task?

    .venv/bin/python bench/dagger.py [--task turn] [--robot glovehand] [--demos 50] [--rounds 3] [--per-round 25]
                                     [--steps 3000] [--config YAML] [--dart 0] [--eval-episodes 50]
                                     [--eval-seed 100000] [--work DIR]

With the gloverec commands a user runs (each in a child process), the scripted demonstrator wearing the emulated
glove as the expert (Ross et al. 2011, "A Reduction of Imitation Learning and Structured Prediction to No-Regret
Online Learning"):
  round 0: record --demos demonstrations (seeds 0..; with --dart SCALE, DART's noise injected) -> train P0
  round r: `gloverec record --policy P(r-1)` for --per-round episodes (seeds 10000 r ..): the policy drives every
           frame, the wearer demonstrates beside it and its action is stored as expert.action (the label of the
           state the policy reached) -> train P(r) on the demonstrations and every round's recording
           (`--also`, `--learn-from intended`: every frame labelled with the wearer's action)
  -> eval every P(r) on --eval-episodes seeds from --eval-seed (never recorded), success with its Wilson interval.
Choose settings with --eval-seed 200000 (validation); report with 100000 (bench/learning.py's seeds).
Writes bench/results/dagger_<task>_<robot>.json.
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
from _common import gloverec, wilson, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

ROUND_SEED = 10_000  # round r records seeds ROUND_SEED * r ..: never the demonstrations' nor the evaluation's


def record(args, root: Path, seed: int, episodes: int, *extra: str) -> dict:
    if (root / "meta" / "info.json").is_file():  # --work: recorded by an earlier run
        info = json.loads((root / "meta" / "info.json").read_text())
        return {"root": str(root), "episodes": info["total_episodes"], "frames": info["total_frames"], "reused": True}
    out = gloverec("record", "--view", "none", "--glove", "emulator", "--task", args.task, "--robot", args.robot,
                   "--episodes", str(episodes), "--root", str(root), "--repo-id", f"bench/{root.name}",
                   "--seed", str(seed), "--fast", "--no-log", *extra)  # fmt: skip
    return {"root": str(root), "episodes": out["episodes_saved"], "frames": out["total_frames"],
            "success_rate": out["success_rate"]}  # fmt: skip


def train_eval(args, name: str, first: dict, also: list[dict], work: Path) -> dict:
    out = work / "runs" / name
    extra = ["--also", *[a["root"] for a in also]] if also else []
    config = ["--config", args.config] if args.config else []
    learn = ["--learn-from", "intended"] if also or args.dart else []  # plain demonstrations alone: their action
    t = time.perf_counter()
    summary = out / "train_summary.json"
    if summary.is_file():  # --work: trained by an earlier run
        trained = json.loads(summary.read_text())
    else:
        trained = gloverec("train", "--repo-id", f"bench/{Path(first['root']).name}", "--root", first["root"], *extra,
                           "--steps", str(args.steps), "--out", str(out), "--inputs", args.inputs,
                           *learn, *config)  # fmt: skip
    wall = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--episodes", str(args.eval_episodes), "--seed",
                  str(args.eval_seed))  # fmt: skip
    row = {"policy": name, "train_frames": trained["train_frames"], "frames_by_policy": trained["frames_by_policy"],
           "train_wall_s": round(wall, 1), "successes": ev["successes"], "episodes": ev["episodes"],
           "success_rate": ev["success_rate"], "wilson95": wilson(ev["successes"], ev["episodes"])}  # fmt: skip
    print(f"  {name}: {row['success_rate']:.0%} {row['wilson95']} ({trained['train_frames']} frames, "
          f"{wall:.0f} s training)", flush=True)  # fmt: skip
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="turn")
    p.add_argument("--robot", default="glovehand")
    p.add_argument("--demos", type=int, default=50)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--per-round", type=int, default=25)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--inputs", default="state,environment")
    p.add_argument("--config", help="a train YAML (policy settings) for every round")
    p.add_argument("--dart", type=float, default=0.0, help="DART's noise in the demonstrations (0: none)")
    p.add_argument("--eval-episodes", type=int, default=50)
    p.add_argument("--eval-seed", type=int, default=100_000)
    p.add_argument("--work", help="keep recordings and runs here (default: a temporary folder)")
    args = p.parse_args()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gloverec-dagger-") as tmp:
        work = Path(args.work or tmp)
        dart = ["--dart", str(args.dart)] if args.dart else []
        demos = record(args, work / "demos", 0, args.demos, *dart)
        rounds, recordings = [], []
        rounds.append({"round": 0, "recorded": demos, **train_eval(args, "P0", demos, [], work)})
        for r in range(1, args.rounds + 1):
            policy = work / "runs" / f"P{r - 1}"
            recordings.append(record(args, work / f"round{r}", ROUND_SEED * r, args.per_round, "--policy", str(policy)))
            rounds.append({"round": r, "recorded": recordings[-1],
                           **train_eval(args, f"P{r}", demos, recordings, work)})  # fmt: skip
    write_results(f"dagger_{args.task}_{args.robot}", {
        "task": args.task, "robot": args.robot, "demos": args.demos, "dart": args.dart, "per_round": args.per_round,
        "steps": args.steps, "inputs": args.inputs, "config": args.config, "eval_seed": args.eval_seed,
        "rounds": rounds, "wall_s": round(time.perf_counter() - t0, 1)})  # fmt: skip


if __name__ == "__main__":
    main()
