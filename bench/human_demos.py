"""Learning from imperfect demonstrations: BC on the human-like demonstrator's takes against the scripted one's.

    .venv/bin/python bench/human_demos.py [--tasks grasp] [--robot glovehand] [--episodes 50] [--failure-rate 0.15]
                                          [--steps 3000]

For each task, with the gloverec commands a user runs (each in a child process), on the same seeds (0..N-1):
  record N demonstrations with the scripted demonstrator, and N with the human-like one (--demonstrator human)
  -> train BC (--steps, 3000) on: the scripted takes; all the human-like takes
     (--all-episodes); the reviewed human-like takes (the failed ones left out: train's default)
  -> and LeRobot's ACT (`lerobot-train`, bench/_common.py's small ACT, --act-steps) on all the human-like takes
  -> eval each on 50 unseen seeds (100000..), success with its Wilson 95 % interval.
Writes bench/results/human_demos.json.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import gloverec, train_act, wilson, write_results  # noqa: E402

EVAL_SEED = 100_000  # bench/learning.py's: seeds no demonstration was recorded with

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")


def record(task: str, robot: str, demonstrator: str, args, tmp: Path) -> dict:
    root = tmp / f"{task}_{demonstrator}"
    extra = ["--demonstrator", "human", "--failure-rate", str(args.failure_rate)] if demonstrator == "human" else []
    rec = gloverec("record", "--view", "none", "--glove", "emulator", "--task", task, "--robot", robot,
                   "--episodes", str(args.episodes), "--root", str(root), "--repo-id", f"bench/{task}_{demonstrator}",
                   "--seed", "0", "--fast", "--no-log", *extra)  # fmt: skip
    return {"root": str(root), "repo_id": f"bench/{task}_{demonstrator}", "success_rate": rec["success_rate"]}


def train_eval(task: str, robot: str, data: dict, name: str, all_takes: bool, args, tmp: Path) -> dict:
    out = tmp / "runs" / f"{task}_{name}".replace(", ", "_").replace(" ", "_")
    t = time.perf_counter()
    trained = gloverec("train", "--repo-id", data["repo_id"], "--root", data["root"], "--steps", str(args.steps),
                       "--out", str(out), "--inputs", "state,environment",
                       *(["--all-episodes"] if all_takes else []))  # fmt: skip
    train_s = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--task", task, "--robot", robot, "--episodes",
                  str(args.eval_episodes), "--seed", str(EVAL_SEED))  # fmt: skip
    return {
        "training_set": name,
        "train_episodes": trained["train_episodes"],
        "train_s": round(train_s, 1),
        "success_rate": ev["success_rate"],
        "successes": ev["successes"],
        "wilson95": wilson(ev["successes"], ev["episodes"]),
    }


def act_eval(task: str, robot: str, data: dict, args, tmp: Path) -> dict:
    """ACT through lerobot-train on every take (lerobot-train has no success filter), evaluated as BC is."""
    out = tmp / "runs" / f"{task}_act"
    command, wall, error = train_act(data["repo_id"], Path(data["root"]), out, args.act_steps)
    if error:
        return {"training_set": "human, all takes (ACT)", "error": error}
    ev = gloverec("eval", "--policy", str(out), "--task", task, "--robot", robot, "--episodes",
                  str(args.eval_episodes), "--seed", str(EVAL_SEED))  # fmt: skip
    return {
        "training_set": "human, all takes (ACT)",
        "policy": "act",
        "steps": args.act_steps,
        "train_s": round(wall, 1),
        "command": command.replace(str(tmp), "$TMP"),
        "success_rate": ev["success_rate"],
        "successes": ev["successes"],
        "wilson95": wilson(ev["successes"], ev["episodes"]),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tasks", default="grasp")
    p.add_argument("--robot", default="glovehand")
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--eval-episodes", type=int, default=50)
    p.add_argument("--failure-rate", type=float, default=0.15)
    p.add_argument("--steps", type=int, default=3000, help="BC training steps")
    p.add_argument("--act-steps", type=int, default=1500, help="lerobot-train ACT steps (0: no ACT row)")
    args = p.parse_args()
    rows, t0 = [], time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gloverec-human-") as tmp_name:
        tmp = Path(tmp_name)
        for task in args.tasks.split(","):
            print(f"[{task} on {args.robot}]", flush=True)
            scripted, human = (record(task, args.robot, d, args, tmp) for d in ("scripted", "human"))
            policies = [
                train_eval(task, args.robot, scripted, "scripted", False, args, tmp),
                train_eval(task, args.robot, human, "human, all takes", True, args, tmp),
                train_eval(task, args.robot, human, "human, reviewed takes", False, args, tmp),
            ]
            if args.act_steps:
                policies.append(act_eval(task, args.robot, human, args, tmp))
            for r in policies:
                print(f"  {r['training_set']}: {r.get('success_rate', r.get('error'))} {r.get('wilson95')}", flush=True)
            rows.append({
                "task": task, "robot": args.robot, "demonstrations": args.episodes,
                "demo_success": {"scripted": scripted["success_rate"], "human": human["success_rate"]},
                "bc": policies,
            })  # fmt: skip
    write_results(
        "human_demos",
        {"failure_rate": args.failure_rate, "eval_seeds_from": EVAL_SEED, "rows": rows,
         "wall_s": round(time.perf_counter() - t0, 1)},
    )  # fmt: skip


if __name__ == "__main__":
    main()
