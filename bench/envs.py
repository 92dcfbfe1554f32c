"""Robot-hand environment benchmark: step, render and retarget cost, and the scripted demonstrators'
success rates.

    MUJOCO_GL=egl .venv/bin/python bench/envs.py [--runs 5] [--episodes 50]

- step: seconds of CPU per control frame (state only, 30 Hz control, physics substeps included), replaying a
  demonstration's actions so that contacts are part of it; frames/s = how far faster than real time
  the recorder could run the simulation (goal: >= 1000 frames/s).
- render: one camera, 128x128 and 224x224, per frame (update_scene + render + read back).
- retarget: per frame on a 30 Hz gestures motion, joint map and fingertip IK (warm-started).
- success: scripted demonstrator -> retarget (joint map) -> env, direct and through the SyntheticGlove's
  noisy pose output (0.5 deg, 20 ms late); episodes with seeds 0..N-1.
All costs are medians over ``--runs`` runs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import envs  # noqa: E402
from recorder.demonstrator.rollout import run_episode, success_rate  # noqa: E402
from recorder.hand.motion import Motion  # noqa: E402
from recorder.retarget import Retargeter  # noqa: E402

ROBOTS = ("glovehand", "shadow")
TASKS = envs.task_names()  # every registered task


def _median(fn, n: int, runs: int) -> dict:
    per = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        per.append((time.perf_counter() - t) / n)
    med = statistics.median(per)
    return {"us_per_frame": round(med * 1e6, 1), "frames_per_s": round(1 / med), "runs": runs}


def step_cost(task: str, robot: str, runs: int) -> dict:
    env = envs.make(task, robot, terminate_on_success=False)  # a whole episode, after success too
    actions = []
    run_episode(env, Retargeter(robot), seed=0, on_step=lambda o, a, i: actions.append(a))

    def replay():
        env.reset(seed=0)
        for a in actions:
            env.step(a)

    out = _median(replay, len(actions), runs)
    out["substeps"] = env.unwrapped.n_substeps
    out["frames"] = len(actions)
    return out


def render_cost(robot: str, size: int, runs: int, n: int = 60) -> dict:
    env = envs.make("grasp", robot)
    env.reset(seed=0)
    u = env.unwrapped
    r = mujoco.Renderer(u.model, size, size)

    def render():
        for _ in range(n):
            r.update_scene(u.data, camera="front")
            r.render()

    render()  # warm up the GL context
    out = _median(render, n, runs)
    r.close()
    return out


def retarget_cost(robot: str, mode: str, runs: int, n: int = 300) -> dict:
    block = Motion("gestures", seed=0, rate_hz=30.0).next_block(n)
    r = Retargeter(robot, mode)
    errors = []

    def go():
        r.reset()
        errors.clear()
        for a, q in zip(block.angles, block.palm_quat):
            errors.append(r(a, q)[1]["tip_error_mean"])

    out = _median(go, n, runs)
    out["mean_tip_error_mm"] = round(1000 * float(np.mean(errors)), 2)
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--episodes", type=int, default=50)
    args = p.parse_args(argv)
    results = {"step": {}, "render": {}, "retarget": {}, "success": {}}
    for robot in ROBOTS:
        for task in TASKS:
            results["step"][f"{task}/{robot}"] = r = step_cost(task, robot, args.runs)
            print(f"step {task}/{robot}: {r['us_per_frame']} us/frame ({r['frames_per_s']} frames/s)", flush=True)
        for size in (128, 224):
            results["render"][f"{robot}/{size}x{size}"] = r = render_cost(robot, size, args.runs)
            print(f"render {robot} {size}x{size}: {r['us_per_frame']} us/frame", flush=True)
        for mode in ("joint", "ik"):
            results["retarget"][f"{robot}/{mode}"] = r = retarget_cost(robot, mode, args.runs)
            print(
                f"retarget {robot} {mode}: {r['us_per_frame']} us/frame, tip error {r['mean_tip_error_mm']} mm",
                flush=True,
            )
    for robot in ROBOTS:
        for task in TASKS:
            for via in ("direct", "glove"):
                s = success_rate(task, robot, args.episodes, via)
                results["success"][f"{task}/{robot}/{via}"] = {
                    k: s[k] for k in ("success_rate", "successes", "episodes", "mean_tip_error_mm")
                }
                print(f"success {task}/{robot}/{via}: {s['successes']}/{s['episodes']}", flush=True)
    write_results("envs", results)


if __name__ == "__main__":
    main()
