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
from dataclasses import asdict, dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import gloverec, wilson, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

ROUND_SEED = 10_000  # round r records seeds ROUND_SEED * r ..: never the demonstrations' nor the evaluation's


@dataclass(frozen=True)
class Setting:
    """What every recording, training and evaluation of a DAgger run shares."""

    task: str
    robot: str
    steps: int = 3000
    inputs: str = "state,environment"
    config: str | None = None  # a train YAML (policy settings)
    demonstrator: str = "scripted"  # the expert; "human": the human-like wearer trying to succeed (failure rate 0)
    eval_episodes: int = 50
    eval_seed: int = 100_000


def record(s: Setting, root: Path, seed: int, episodes: int, *extra: str) -> dict:
    if (root / "meta" / "info.json").is_file():  # --work: recorded by an earlier run
        info = json.loads((root / "meta" / "info.json").read_text())
        return {"root": str(root), "episodes": info["total_episodes"], "frames": info["total_frames"], "reused": True}
    out = gloverec("record", "--view", "none", "--glove", "emulator", "--task", s.task, "--robot", s.robot,
                   "--episodes", str(episodes), "--root", str(root), "--repo-id", f"bench/{root.name}",
                   "--seed", str(seed), "--fast", "--no-log", *extra)  # fmt: skip
    return {"root": str(root), "episodes": out["episodes_saved"], "frames": out["total_frames"],
            "success_rate": out["success_rate"]}  # fmt: skip


def train_eval(s: Setting, out: Path, first: str, also: list[str], intended: bool) -> dict:
    """Train on ``first`` (a dataset folder) and ``also``, then evaluate; ``intended``: learn expert.action."""
    extra = ["--also", *also] if also else []
    config = ["--config", s.config] if s.config else []
    learn = ["--learn-from", "intended"] if intended else []
    t = time.perf_counter()
    summary = out / "train_summary.json"
    if summary.is_file():  # --work: trained by an earlier run
        trained = json.loads(summary.read_text())
    else:
        trained = gloverec("train", "--repo-id", f"bench/{Path(first).name}", "--root", first, *extra,
                           "--steps", str(s.steps), "--out", str(out), "--inputs", s.inputs,
                           *learn, *config)  # fmt: skip
    wall = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--episodes", str(s.eval_episodes), "--seed", str(s.eval_seed))
    row = {"policy": out.name, "train_frames": trained["train_frames"], "frames_by_policy": trained["frames_by_policy"],
           "train_wall_s": round(wall, 1), "successes": ev["successes"], "episodes": ev["episodes"],
           "success_rate": ev["success_rate"], "wilson95": wilson(ev["successes"], ev["episodes"])}  # fmt: skip
    print(f"  {out.name}: {row['success_rate']:.0%} {row['wilson95']} ({trained['train_frames']} frames, "
          f"{wall:.0f} s training)", flush=True)  # fmt: skip
    return row


def rounds(s: Setting, work: Path, demos: str, first_policy: Path, n: int, per_round: int) -> list[dict]:
    """DAgger's rounds 1..n after ``first_policy`` (trained on the demonstrations ``demos``): each records
    ``per_round`` episodes driven by the last policy, labelled by the wearer, and trains on everything so far."""
    expert = ["--demonstrator", "human", "--failure-rate", "0"] if s.demonstrator == "human" else []
    policy, recordings, rows = first_policy, [], []
    for r in range(1, n + 1):
        recordings.append(record(s, work / f"round{r}", ROUND_SEED * r, per_round, "--policy", str(policy), *expert))
        policy = work / "runs" / f"P{r}"
        row = train_eval(s, policy, demos, [x["root"] for x in recordings], intended=True)
        rows.append({"round": r, "recorded": recordings[-1], **row})
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="turn")
    p.add_argument("--robot", default="glovehand")
    p.add_argument("--demos", type=int, default=50)
    p.add_argument("--demonstrator", choices=("scripted", "human"), default="scripted",
                   help="human: the demonstrations from the human-like wearer (--failure-rate), the rounds' expert "
                   "the same wearer trying to succeed")  # fmt: skip
    p.add_argument("--failure-rate", type=float, default=0.15)
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
    s = Setting(args.task, args.robot, args.steps, args.inputs, args.config, args.demonstrator, args.eval_episodes,
                args.eval_seed)  # fmt: skip
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gloverec-dagger-") as tmp:
        work = Path(args.work or tmp)
        extra = ["--dart", str(args.dart)] if args.dart else []
        if args.demonstrator == "human":
            extra += ["--demonstrator", "human", "--failure-rate", str(args.failure_rate)]
        demos = record(s, work / "demos", 0, args.demos, *extra)
        first = work / "runs" / "P0"
        rows = [{"round": 0, "recorded": demos, **train_eval(s, first, demos["root"], [], intended=bool(args.dart))}]
        rows += rounds(s, work, demos["root"], first, args.rounds, args.per_round)
    write_results(f"dagger_{args.task}_{args.robot}", {
        **asdict(s), "demos": args.demos, "failure_rate": args.failure_rate, "dart": args.dart,
        "per_round": args.per_round, "rounds": rows, "wall_s": round(time.perf_counter() - t0, 1)})  # fmt: skip


if __name__ == "__main__":
    main()
