"""lerobot-eval on a gloverec task (`--env.type=gloverec`, envs/plugin/lerobot_robot_gloverec/gloverec_env.py):
the same per-seed outcomes as `gloverec eval`, and what LeRobot's vector environments buy.

    .venv/bin/python bench/lerobot_eval.py [--episodes 50]

A weak policy, so that episodes both succeed and fail: `gloverec_bc` trained 150 steps on 4 recorded HandPose
episodes (glovehand). Then, on seeds 100000 ... 100000 + episodes - 1, in this run: `gloverec eval` (one process),
and lerobot-eval with `--seed=100000` at `--eval.batch_size` 1 and 2 (2: LeRobot's default AsyncVectorEnv, one
process per environment, and in one process with `--eval.use_async_envs=false`). Per seed, success and return
must match (a return equal to 4 decimals: the same trajectory). Episodes per second are lerobot-eval's own
`eval_s` (the rollouts, not the start-up). LeRobot's rollout runs a batch until its longest episode ends, so the
episodes' lengths bound what batch size 2 can gain (`speedup_bound_lockstep`).
Goals: every seed agrees; batch size 2 reaches >= 1.5x the episodes per second of batch size 1.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, write_results  # noqa: E402

SEED = 100_000
GOAL_SPEEDUP = 1.5
LEROBOT_EVAL = Path(sys.executable).with_name("lerobot-eval")


def _env() -> dict:
    # this tree's gloverec and plugins (the env type lives in envs/plugin), not installed ones
    path = os.pathsep.join([str(REPO)] + [str(REPO / d / "plugin") for d in ("envs", "policies", "recorder")])
    return {**os.environ, "PYTHONPATH": path, "MUJOCO_GL": "egl", "HF_HUB_OFFLINE": "1", "OMP_NUM_THREADS": "1"}


def _run(cmd: list[str], cwd: Path) -> str:
    r = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=cwd, timeout=1800)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd[:3])} failed:\n{r.stderr[-3000:]}")
    return r.stdout


def gloverec(*args: str, cwd: Path) -> str:
    return _run([sys.executable, "-m", "recorder.cli", *args], cwd)


def lerobot_eval(policy: Path, episodes: int, batch: int, use_async: bool, out: Path) -> dict:
    _run([str(LEROBOT_EVAL), f"--policy.path={policy}", "--policy.device=cpu", "--env.type=gloverec",
          "--env.task=pose", "--env.robot=glovehand", f"--eval.n_episodes={episodes}", f"--eval.batch_size={batch}",
          f"--eval.use_async_envs={str(use_async).lower()}", f"--seed={SEED}", f"--output_dir={out}"],
         out.parent)  # fmt: skip
    info = json.loads((out / "eval_info.json").read_text())
    m = info["per_task"][0]["metrics"]
    eval_s = info["overall"]["eval_s"]
    return {
        "name": f"batch_size_{batch}" + ("" if use_async or batch == 1 else "_sync"),
        "batch_size": batch,
        "successes": [bool(s) for s in m["successes"]],
        "returns": [round(r, 4) for r in m["sum_rewards"]],
        "eval_s": round(eval_s, 2),
        "episodes_per_s": round(episodes / eval_s, 3),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=50)
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        gloverec("record", "--episodes", "4", "--root", str(work / "pose4"), "--repo-id", "bench/pose4", cwd=work)
        gloverec("train", "--repo-id", "bench/pose4", "--root", str(work / "pose4"), "--steps", "150",
                 "--out", str(work / "bc"), cwd=work)  # fmt: skip
        policy = work / "bc" / "checkpoints" / "last" / "pretrained_model"
        ours = json.loads(gloverec("eval", "--policy", str(policy), "--episodes", str(args.episodes), "--seed",
                                   str(SEED), "--json", cwd=work))  # fmt: skip
        # batch size 1 runs in this process whatever use_async_envs says; 2 in LeRobot's default (async) and not
        theirs = [
            lerobot_eval(policy, args.episodes, b, use_async, work / f"lerobot_{k}")
            for k, (b, use_async) in enumerate(((1, True), (2, True), (2, False)))
        ]
    want = {"successes": [r["success"] for r in ours["runs"]], "returns": [r["return"] for r in ours["runs"]]}
    agree = {
        t["name"]: {
            "successes_agree": sum(a == b for a, b in zip(want["successes"], t["successes"], strict=True)),
            "returns_agree": sum(a == b for a, b in zip(want["returns"], t["returns"], strict=True)),
            "max_abs_return_diff": max(abs(a - b) for a, b in zip(want["returns"], t["returns"], strict=True)),
        }
        for t in theirs
    }
    speedup = theirs[1]["episodes_per_s"] / theirs[0]["episodes_per_s"]
    # LeRobot's rollout steps a batch until its longest episode ends: with these episodes' lengths, two
    # environments can at best run sum(lengths) / sum(longest of each pair) times as many episodes per second
    lengths = ours["episode_lengths"]
    pairs = [max(lengths[i : i + 2]) for i in range(0, len(lengths), 2)]
    results = {
        "policy": "gloverec_bc, 150 steps on 4 HandPose episodes (glovehand)",
        "episodes": args.episodes,
        "seeds": [SEED, SEED + args.episodes - 1],
        "gloverec_eval": {
            "successes": sum(want["successes"]),
            "wall_s": ours["wall_s"],
            "episodes_per_s": round(args.episodes / ours["wall_s"], 3),
        },
        "lerobot_eval": {t["name"]: {k: v for k, v in t.items() if k not in ("name", "returns")} for t in theirs},
        "per_seed": agree,
        "per_seed_goal_met": all(a["successes_agree"] == args.episodes for a in agree.values()),
        "speedup_batch_2": round(speedup, 2),
        "speedup_batch_2_sync": round(theirs[2]["episodes_per_s"] / theirs[0]["episodes_per_s"], 2),
        "speedup_bound_lockstep": round(sum(lengths) / sum(pairs), 2),
        "speedup_goal": GOAL_SPEEDUP,
        "speedup_goal_met": speedup >= GOAL_SPEEDUP,
        "seed_outcomes": want["successes"],
        "episode_lengths": lengths,
    }
    write_results("lerobot_eval", results)
    print(json.dumps({k: v for k, v in results.items() if k not in ("seed_outcomes", "episode_lengths")}, indent=1))


if __name__ == "__main__":
    main()
