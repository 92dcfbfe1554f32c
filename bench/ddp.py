"""Distributed training benchmark: `lerobot-train` of gloverec_bc on 1 process against 2, on the CPU.

    .venv/bin/python bench/ddp.py [--episodes 20] [--workers 0,1,2] [--repeats 2] [--speed-steps 60]
                                  [--val-steps 300] [--seeds 0,1] [--batch-size 32]

With the commands docs/lerobot.md gives (each in a child process, as a user runs them):
  gloverec record --episodes N (the scripted demonstrator, emulated glove)
  -> speed: for each --num_workers W, `lerobot-train` (1 process; as it starts, and with OMP_NUM_THREADS=1, the
     one thread torchrun gives each of its processes) and `accelerate launch --multi_gpu --num_processes=2
     lerobot-train` (2 processes), interleaved (1, 1, 2, 1, 1, 2, ...) so that all see the same load
     on a shared machine; per run, LeRobot's own log line (`data_s`, `updt_s`, the slowest rank's, averaged over
     each log window; the first window, which holds the start, left out): steps and samples per second, and how
     much of a step is data (the batch and the preprocessor) and how much the update
  -> validation: the same number of samples seen, 1 process for 2S steps and 2 processes for S steps at the same
     batch size per process, each with LeRobot's held-out episodes (`--dataset.eval_split=0.2`: the last 20 % of
     the episodes, the same in both) and its `eval_loss` at the same samples seen (goal: within 10 %).
Writes bench/results/ddp.json.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, gloverec, write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

BIN = Path(sys.executable).parent
LOG = re.compile(r"step:(\d+) .*updt_s:([\d.]+) data_s:([\d.]+)")
EVAL = re.compile(r"step (\d+): eval_loss=([\d.]+)")
GOAL = 0.10  # |val loss of 2 processes / of 1 process - 1| at the same samples seen


def launch(processes: int) -> list[str]:
    """The command docs/lerobot.md settles on: LeRobot's own for 1 process, accelerate's multi-process launch for N."""
    train = str(BIN / "lerobot-train")
    if processes == 1:
        return [train]
    return [str(BIN / "accelerate"), "launch", "--multi_gpu", f"--num_processes={processes}", train]


def train(
    processes: int,
    root: Path,
    out: Path,
    steps: int,
    workers: int,
    batch: int,
    extra: list[str],
    threads: int | None = None,
) -> dict:
    """One training run; ``threads``: OMP_NUM_THREADS (torchrun sets 1 in each of its processes; a plain
    lerobot-train takes one per core)."""
    flags = [
        "--policy.type=gloverec_bc",
        "--dataset.repo_id=me/pose_demos",
        f"--dataset.root={root}",
        "--policy.device=cpu",
        "--policy.push_to_hub=false",
        "--policy.inputs=[state,environment]",
        f"--batch_size={batch}",
        f"--num_workers={workers}",
        f"--steps={steps}",
        f"--save_freq={steps}",
        f"--output_dir={out}",
        *extra,
    ]
    cmd = [*launch(processes), *flags]
    shown = " ".join(Path(c).name if c.startswith(str(BIN)) else c for c in cmd)
    print(f"  $ {shown}", flush=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
    env.pop("OMP_NUM_THREADS", None)
    if threads:
        env["OMP_NUM_THREADS"] = str(threads)
        shown = f"OMP_NUM_THREADS={threads} {shown}"
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1800)
    wall = time.perf_counter() - t
    if r.returncode != 0:
        sys.exit(f"bench: {shown} failed: {r.stderr[-3000:]}")
    effective = re.search(r"Effective batch size: (\d+) x (\d+)", r.stderr)
    assert effective and int(effective.group(2)) == processes, f"{shown}: {effective and effective.group(0)}"
    logs = [(int(s), float(u), float(d)) for s, u, d in LOG.findall(r.stderr)]
    return {
        "command": shown,
        "wall_s": round(wall, 1),
        "logs": logs,
        "eval_loss": {int(s): float(v) for s, v in EVAL.findall(r.stderr)},
    }


def speed_row(run: dict, processes: int, batch: int) -> dict:
    windows = run["logs"][1:] or run["logs"]  # the first window holds the start (the workers, the first batches)
    updt = statistics.mean(u for _, u, _ in windows)
    data = statistics.mean(d for _, _, d in windows)
    step = updt + data
    return {
        "steps_per_s": round(1 / step, 2),
        "samples_per_s": round(batch * processes / step, 1),
        "step_s": round(step, 4),
        "data_s": round(data, 4),
        "updt_s": round(updt, 4),
        "data_share": round(data / step, 3),
        "wall_s": run["wall_s"],
    }


def median_rows(rows: list[dict]) -> dict:
    keys = ("steps_per_s", "samples_per_s", "step_s", "data_s", "updt_s", "data_share", "wall_s")
    return {k: round(statistics.median(r[k] for r in rows), 4) for k in keys} | {"runs": len(rows)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--workers", default="0,1,2")
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--speed-steps", type=int, default=60)
    p.add_argument("--val-steps", type=int, default=300, help="steps of the 2-process run (1 process: twice)")
    p.add_argument("--val-workers", type=int, default=None, help="--num_workers of the validation runs (default: "
                   "the fastest 2-process setting of the speed runs)")  # fmt: skip
    p.add_argument("--seeds", default="0,1")
    p.add_argument("--batch-size", type=int, default=32)
    args = p.parse_args()
    workers = [int(w) for w in args.workers.split(",")]
    tmp = Path(tempfile.mkdtemp(prefix="bench-ddp-"))
    root = tmp / "pose_demos"
    gloverec("record", "--episodes", str(args.episodes), "--repo-id", "me/pose_demos", "--root", str(root))

    runs: dict[str, list[dict]] = {}
    log = 20 if args.speed_steps >= 40 else max(1, args.speed_steps // 2)
    for rep in range(args.repeats):
        for w in workers:
            # interleaved: 1, 1 with one thread, 2, 1, 1 with one thread, 2, ... in the same minutes
            for name, n, threads in (("1proc", 1, None), ("1proc_1thread", 1, 1), ("2proc", 2, None)):
                run = train(n, root, tmp / f"speed-{name}-{w}-{rep}", args.speed_steps, w, args.batch_size,
                            [f"--log_freq={log}"], threads)  # fmt: skip
                row = speed_row(run, n, args.batch_size)
                print(f"    {name}, num_workers={w}: {row}", flush=True)
                runs.setdefault(f"{name}/num_workers={w}", []).append(row)
    speed = {k: median_rows(v) for k, v in runs.items()}
    best = args.val_workers
    if best is None:
        best = max(workers, key=lambda w: speed[f"2proc/num_workers={w}"]["samples_per_s"])
    for w in workers:
        two = speed[f"2proc/num_workers={w}"]
        for name in ("1proc", "1proc_1thread"):
            two[f"samples_per_s_vs_{name}"] = round(
                two["samples_per_s"] / speed[f"{name}/num_workers={w}"]["samples_per_s"], 2
            )

    val: dict[str, dict] = {}
    s = args.val_steps
    every = max(1, s // 5)
    for seed in [int(x) for x in args.seeds.split(",")]:
        common = ["--dataset.eval_split=0.2", f"--seed={seed}", "--log_freq=50"]
        a = train(1, root, tmp / f"val-1-{seed}", 2 * s, best, args.batch_size, [*common, f"--eval_steps={2 * every}"])
        b = train(2, root, tmp / f"val-2-{seed}", s, best, args.batch_size, [*common, f"--eval_steps={every}"])
        curve = {}
        for step2, loss2 in sorted(b["eval_loss"].items()):
            loss1 = a["eval_loss"].get(2 * step2)
            if loss1 is not None:
                samples = step2 * 2 * args.batch_size
                curve[str(samples)] = {"1proc": loss1, "2proc": loss2, "ratio": round(loss2 / loss1, 3)}
        last = curve[max(curve, key=int)]
        print(f"    seed {seed}: val loss at {max(curve, key=int)} samples: {last}", flush=True)
        val[f"seed={seed}"] = {
            "by_samples_seen": curve,
            "final": last,
            "wall_s": {"1proc": a["wall_s"], "2proc": b["wall_s"]},
            "commands": {"1proc": a["command"], "2proc": b["command"]},
        }
    ratios = [v["final"]["ratio"] for v in val.values()]
    write_results(
        "ddp",
        {
            "setup": {
                "dataset": f"gloverec record --episodes {args.episodes} (pose, glovehand, no camera)",
                "batch_size_per_process": args.batch_size,
                "speed_steps": args.speed_steps,
                "repeats": args.repeats,
                "validation": f"--dataset.eval_split=0.2 (held-out episodes); 1 process {2 * s} steps, "
                f"2 processes {s} steps, --num_workers={best}",
                "launch_1proc": "lerobot-train ...",
                "launch_2proc": "accelerate launch --multi_gpu --num_processes=2 $(which lerobot-train) ...",
                "machine": "2 cores, shared with other jobs: figures are medians of interleaved runs",
            },
            "speed": speed,
            "num_workers_chosen": best,
            "validation": val,
            "goal": {
                "val_loss_ratio_within": GOAL,
                "ratios": ratios,
                "met": all(abs(r - 1) <= GOAL for r in ratios),
            },
        },
    )


if __name__ == "__main__":
    main()
