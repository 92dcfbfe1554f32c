"""Learning benchmark: do emulated-glove demonstrations teach a policy?

    .venv/bin/python bench/learning.py [--episodes 50] [--eval-episodes 50] [--steps 3000]
                                       [--robots glovehand,shadow] [--tasks pose,grasp] [--act-steps 1500]
                                       [--demonstrator scripted|human] [--failure-rate 0.15]
                                       [--dagger-rounds 3] [--per-round 25]

For each task and robot, with the gloverec commands a user runs (each in a child process):
  record --episodes N (emulated glove, seeds 0..N-1; the scripted demonstrator, or with --demonstrator human the
  human-like wearer who gets --failure-rate of its takes wrong; HandRelocate always the scripted one: the human-like
  wearer has no free wrist yet) -> push to a local hub
  -> replay every episode open loop (max |replayed - recorded state|; goal: 0, MuJoCo is deterministic)
  -> train BC on the joint and environment state (--inputs state,environment; --steps or the task's STEPS;
     goal <= 10 min on this CPU); bench/learning_visual.py trains on what a robot has (cameras, joints, instruction)
  -> eval 50 episodes with seeds 100000.. (never training seeds) (goals: HandPose >= 95 %, HandGrasp >= 80 %)
  -> on the tasks where BC alone falls short (DAGGER_TASKS), --dagger-rounds of DAgger (bench/dagger.py): each round
     records --per-round episodes driven by the last policy, labelled by the wearer (`gloverec record --policy`),
     and trains on everything so far (`--also ... --learn-from intended`); each round's policy is evaluated alike
     (off by default: with the script's demonstrator as the expert the rounds made the policies worse, docs/policies.md)
  -> BC variants (--policies: POLICIES, e.g. history) trained and evaluated alike on the same dataset
and, on the first task/robot, LeRobot's ACT through `lerobot-train` on the same hub dataset (a short run of
a small ACT), evaluated by `gloverec eval`. Writes bench/results/learning.json (rows of other task/robot pairs
already there are kept, each row with the time it was measured) and the loss curves as
bench/results/learning_loss_<task>_<robot>.png.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS, gloverec, train_act, wilson, write_results  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _common took bench/ off the path (bench/envs.py)
from dagger import Setting, rounds  # noqa: E402

sys.path[:] = [p for p in sys.path if p != str(Path(__file__).resolve().parent)]  # dagger put it back too

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

GOALS = {"pose": 0.95, "grasp": 0.80, "pinch": 0.80, "keys": 0.80, "turn": 0.80, "relocate": 0.80}
TRAIN_GOAL_S = 600
STEPS = 3000
TASK_STEPS = {"relocate": 10_000}  # a free wrist's reach, carry and release: val loss still falls at 3000
EVAL_SEED = 100_000
POLICIES = {"history": {"n_obs_steps": 4, "obs_stride": 8}}  # BC variants beside the default (--policies)
DAGGER_TASKS = ("turn", "relocate")  # BC from demonstrations alone: 0-4 % and 38 % (docs/policies.md, diagnosis)
SCRIPTED_ONLY = ("relocate",)  # the human-like wearer has no free wrist yet
INPUTS = "state,environment"  # the simulator's state: what these rows measure (bench/learning_visual.py: a robot's)


def one(task: str, robot: str, args, tmp: Path, hub: Path) -> dict:
    repo = f"bench/{task}_{robot}"
    demonstrator = "scripted" if task in SCRIPTED_ONLY else args.demonstrator
    wearer = ["--demonstrator", "human", "--failure-rate", str(args.failure_rate)] if demonstrator == "human" else []
    t = time.perf_counter()
    rec = gloverec(
        "record",
        "--view",
        "none",
        "--glove",
        "emulator",
        "--task",
        task,
        "--robot",
        robot,
        "--episodes",
        str(args.episodes),
        "--root",
        str(tmp / "rec" / f"{task}_{robot}"),
        "--repo-id",
        repo,
        "--seed",
        "0",
        "--fast",
        "--no-log",
        *wearer,
    )
    record_s = time.perf_counter() - t
    gloverec("push", "--repo-id", repo, "--root", rec["root"], "--hub", str(hub))

    from policies.data import resolve
    from policies.replay import replay

    ref = resolve(repo, hub=hub)
    replays = [replay(ref, e) for e in range(args.episodes)]
    gloverec("replay", "--repo-id", repo, "--hub", str(hub), "--episode", "0")  # the command itself, once

    out = tmp / "runs" / f"{task}_{robot}"
    t = time.perf_counter()
    steps = args.steps or TASK_STEPS.get(task, STEPS)
    trained = gloverec("train", "--repo-id", repo, "--hub", str(hub), "--steps", str(steps), "--out", str(out),
                       "--inputs", INPUTS)  # fmt: skip
    train_s = time.perf_counter() - t
    shutil.copyfile(out / "loss_curve.png", RESULTS / f"learning_loss_{task}_{robot}.png")
    ev = gloverec(
        "eval",
        "--policy",
        str(out),
        "--task",
        task,
        "--robot",
        robot,
        "--episodes",
        str(args.eval_episodes),
        "--seed",
        str(EVAL_SEED),
    )
    variants = {name: variant(name, settings, repo, hub, steps, args, tmp / "runs" / f"{task}_{robot}_{name}")
                for name, settings in POLICIES.items() if name in args.policies}  # fmt: skip
    demo = gloverec(
        "eval",
        "--policy",
        "demonstrator",
        "--task",
        task,
        "--robot",
        robot,
        "--episodes",
        str(args.eval_episodes),
        "--seed",
        str(EVAL_SEED),
    )
    dagger = []
    if task in DAGGER_TASKS and args.dagger_rounds > 0:
        setting = Setting(task, robot, steps, INPUTS, None, demonstrator, args.eval_episodes, EVAL_SEED)
        dagger = rounds(setting, tmp / "dagger" / f"{task}_{robot}", str(ref.root), out, args.dagger_rounds,
                        args.per_round)  # fmt: skip
    result = {
        "task": task,
        "robot": robot,
        "demonstrator": demonstrator,
        "failure_rate": args.failure_rate if demonstrator == "human" else None,
        "dagger": dagger,
        "dataset": {
            "repo_id": repo,
            "episodes": rec["total_episodes"],
            "frames": rec["total_frames"],
            "demo_success_rate": rec["success_rate"],
            "record_wall_s": round(record_s, 1),
        },
        "replay": {
            "episodes": len(replays),
            "max_abs_state": max(r["state_max_abs"] for r in replays),
            "max_abs_environment_state": max(r.get("environment_state_max_abs", 0.0) for r in replays),
            "reproduced": sum(r["reproduced"] for r in replays),
        },
        "train": {
            "steps": steps,
            "train_episodes": trained["train_episodes"],
            "val_episodes": trained["val_episodes"],
            "final_train_loss": trained["final_train_loss"],
            "final_val_loss": trained["final_val_loss"],
            "wall_s": round(train_s, 1),
            "goal_s": TRAIN_GOAL_S,
            "met": train_s <= TRAIN_GOAL_S,
        },
        "eval": {
            "episodes": ev["episodes"],
            "seeds": ev["seeds"],
            "success_rate": ev["success_rate"],
            "mean_return": ev["mean_return"],
            "mean_length": ev["mean_length"],
            "successes": ev["successes"],
            "wilson95": wilson(ev["successes"], ev["episodes"]),
            "goal": GOALS[task],
            "met": ev["success_rate"] >= GOALS[task],
        },
        "demonstrator_same_seeds": {"success_rate": demo["success_rate"], "mean_return": demo["mean_return"]},
        "variants": variants,
    }
    last = dagger[-1] if dagger else None  # the policy this row reports: BC, or BC after its DAgger rounds
    result["final"] = {
        "policy": f"BC + {last['round']} DAgger rounds" if last else "BC",
        "success_rate": last["success_rate"] if last else ev["success_rate"],
        "wilson95": last["wilson95"] if last else result["eval"]["wilson95"],
        "met": (last["success_rate"] if last else ev["success_rate"]) >= GOALS[task],
    }
    print(
        f"  {task}/{robot}: BC success {ev['success_rate']:.0%} (goal {GOALS[task]:.0%}), demonstrator "
        f"{demo['success_rate']:.0%}, training {train_s:.0f} s, "
        f"replay max |diff| {result['replay']['max_abs_state']:.3g}; {result['final']['policy']}: "
        f"{result['final']['success_rate']:.0%}",
        flush=True,
    )
    return result


def variant(name: str, settings: dict, repo: str, hub: Path, steps: int, args, out: Path) -> dict:
    """BC with other policy settings (POLICIES) on the same dataset, steps and evaluation seeds."""
    config = out.with_suffix(".yaml")
    config.parent.mkdir(parents=True, exist_ok=True)
    config.write_text(json.dumps({"policy": settings}))  # YAML is a superset of JSON
    t = time.perf_counter()
    gloverec("train", "--repo-id", repo, "--hub", str(hub), "--steps", str(steps), "--out", str(out),
             "--inputs", INPUTS, "--config", str(config))  # fmt: skip
    wall = time.perf_counter() - t
    ev = gloverec("eval", "--policy", str(out), "--episodes", str(args.eval_episodes), "--seed", str(EVAL_SEED))
    print(f"  {name}: {ev['success_rate']:.0%}, training {wall:.0f} s", flush=True)
    return {"settings": settings, "train_wall_s": round(wall, 1), "successes": ev["successes"],
            "episodes": ev["episodes"], "success_rate": ev["success_rate"],
            "wilson95": wilson(ev["successes"], ev["episodes"])}  # fmt: skip


def act(task: str, robot: str, steps: int, args, tmp: Path, hub: Path) -> dict:
    repo = f"bench/{task}_{robot}"
    out = tmp / "act"
    command, wall, error = train_act(repo, hub / repo, out, steps)
    if error:
        return {"task": task, "robot": robot, "error": error}
    ev = gloverec("eval", "--policy", str(out), "--episodes", str(args.eval_episodes), "--seed", str(EVAL_SEED))
    return {
        "task": task,
        "robot": robot,
        "steps": steps,
        "train_wall_s": round(wall, 1),
        "command": command.replace(str(tmp), "$TMP"),
        "eval": {
            "episodes": ev["episodes"],
            "success_rate": ev["success_rate"],
            "mean_return": ev["mean_return"],
            "mean_length": ev["mean_length"],
        },
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=50, help="demonstrations per task and robot (<= 50)")
    p.add_argument("--eval-episodes", type=int, default=50)
    p.add_argument("--steps", type=int, default=None, help=f"BC training steps (default {STEPS}; {TASK_STEPS})")
    p.add_argument("--tasks", default=",".join(GOALS), help="registered tasks (default: those with a goal here)")
    p.add_argument("--robots", default="glovehand,shadow")
    p.add_argument("--act-steps", type=int, default=1500, help="lerobot-train ACT steps (0: skip ACT)")
    p.add_argument("--demonstrator", choices=("scripted", "human"), default="scripted",
                   help="who demonstrates (HandRelocate: always scripted)")  # fmt: skip
    p.add_argument("--failure-rate", type=float, default=0.15, help="--demonstrator human: takes it gets wrong")
    p.add_argument("--policies", default=",".join(POLICIES), help=f"BC variants beside the default: {POLICIES}")
    p.add_argument("--dagger-rounds", type=int, default=0, help=f"DAgger rounds on {', '.join(DAGGER_TASKS)} (0: none)")
    p.add_argument("--per-round", type=int, default=25, help="episodes each DAgger round records")
    args = p.parse_args()
    runs = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="gloverec-learning-") as tmp_name:
        tmp = Path(tmp_name)
        hub = tmp / "hub"
        pairs = [(t, r) for r in args.robots.split(",") for t in args.tasks.split(",")]
        for task, robot in pairs:
            print(f"[{task} on {robot}]", flush=True)
            runs.append(one(task, robot, args, tmp, hub))
        act_result = None
        if args.act_steps > 0:
            print(f"[ACT through lerobot-train on {pairs[0][0]} / {pairs[0][1]}]", flush=True)
            act_result = act(*pairs[0], args.act_steps, args, tmp, hub)
            print(f"  ACT: {act_result.get('eval', act_result)}", flush=True)
    last = previous()
    runs = merged_runs(runs, last)
    act_result = act_result or last.get("act")
    write_results(
        "learning",
        {
            "episodes": args.episodes,
            "eval_episodes": args.eval_episodes,
            "eval_seeds_from": EVAL_SEED,
            "bc_steps": args.steps or {"default": STEPS, **TASK_STEPS},
            "runs": runs,
            "act": act_result,
            "all_goals_met": all(r.get("final", r["eval"])["met"] and r["train"]["met"] for r in runs),
            "wall_s": round(time.perf_counter() - t0, 1),
        },
    )


def previous() -> dict:
    path = RESULTS / "learning.json"
    return json.loads(path.read_text()) if path.exists() else {}


def merged_runs(runs: list[dict], last: dict) -> list[dict]:
    """This run's rows, after the rows of ``last`` (bench/results/learning.json as it was) for the (task, robot)
    pairs it did not measure: `--tasks pinch` adds a row and keeps the others (each row says when it was
    measured)."""
    when = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    for r in runs:
        r["when"] = when
    done = {(r["task"], r["robot"]) for r in runs}
    kept = [r for r in last.get("runs", []) if (r["task"], r["robot"]) not in done]
    for r in kept:
        r.setdefault("when", last.get("meta", {}).get("when"))
    return kept + runs


if __name__ == "__main__":
    main()
