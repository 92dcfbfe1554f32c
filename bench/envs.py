"""Robot-hand environment benchmark: step, render and retarget cost, and the scripted demonstrators'
success rates.

    MUJOCO_GL=egl .venv/bin/python bench/envs.py [--runs 5] [--episodes 50]

- step: seconds of CPU per control frame (state only, 30 Hz control, physics substeps included), replaying a
  demonstration's actions so that contacts are part of it; frames/s = how far faster than real time
  the recorder could run the simulation (goal: >= 1000 frames/s).
- render: one camera, 128x128 and 224x224, per frame (update_scene + render + read back).
- retarget: per frame on a 30 Hz gestures motion, joint map and fingertip IK (warm-started).
- step ratio: each task's step cost over HandGrasp's on the same robot, measured in the same run (goal for the
  dexterous tasks: <= 1.5).
- success: scripted demonstrator -> retarget (joint map) -> env, direct and through the SyntheticGlove's
  noisy pose output (0.5 deg, 20 ms late); episodes with seeds 0..N-1, on glovehand, Shadow and LEAP.
- trivial: policies that must not solve a task, on the same seeds: the zero action, the open hand, a constant fist,
  and the replay of a demonstration recorded for another instruction or goal (pinch: the other finger; keys:
  another sequence; turn: the opposite direction; grasp: another shape; pose: another gesture; pick: the other
  colour, on another seed's layout). Goal <= 5 % (pick: <= 10 %). With a free wrist the open hand and the fist are
  held where the episode starts (the zero action puts the palm on the table at the workspace's centre).
All costs are medians over ``--runs`` runs.

    --robots glovehand,shadow,leap --tasks pinch,keys,turn   a subset (the rows it does not measure are kept from
                                                             bench/results/envs.json; "measured" says when each was)
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
from _common import merged_with_previous, write_results  # noqa: E402

import envs  # noqa: E402
from recorder.hand.gestures import GESTURES  # noqa: E402
from recorder.hand.motion import Motion  # noqa: E402
from recorder.retarget import Retargeter  # noqa: E402
from recorder.rig.rollout import run_episode, success_rate  # noqa: E402

ROBOTS = ("glovehand", "shadow")  # the costs
SUCCESS_ROBOTS = ("glovehand", "shadow", "leap")
TASKS = envs.task_names()  # every registered task
# what an episode's instruction (or lit sequence, or mark) asks for: a demonstration for another one is "wrong"
GOAL = {
    "pose": lambda e: e.goal_name,
    "grasp": lambda e: e.object_shape,
    "pinch": lambda e: e.finger,
    "keys": lambda e: e.sequence,
    "turn": lambda e: bool(e.target > 0),
    "pick": lambda e: e.target,  # the colour: another seed's demonstration reached for the other colour elsewhere
}


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
    run_episode(env, Retargeter.for_env(env), seed=0, on_step=lambda o, a, i: actions.append(a))

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


def _play(env, seed: int, policy) -> bool:
    env.reset(seed=seed)
    k = 0
    while True:
        _, _, terminated, truncated, info = env.step(policy(k))
        k += 1
        if terminated or truncated:
            return bool(info["is_success"])


def trivial(task: str, robot: str, episodes: int) -> dict:
    """Successes of the trivial policies over seeds 0..episodes-1."""
    env = envs.make(task, robot)
    u = env.unwrapped
    r = Retargeter.for_env(env)
    free = u.config.base_position  # a free wrist: the open hand and the fist are held where the episode starts
    fixed = {
        "zero": np.zeros(env.action_space.shape, np.float32),
        "open hand": r(GESTURES["open"], palm_pos=np.zeros(3) if free else None)[0],
        "fist": r(GESTURES["fist"], palm_pos=np.zeros(3) if free else None)[0],
    }

    def held(a, name):
        if not free or name == "zero":
            return lambda k: a
        start = a.copy()

        def policy(k):
            if k == 0:
                start[-3:] = u.palm_pose()[0]
            return start

        return policy

    out = {name: sum(_play(env, s, held(a, name)) for s in range(episodes)) for name, a in fixed.items()}
    wrong = 0
    for seed in range(episodes):
        env.reset(seed=seed)
        goal = GOAL[task](u)
        other = next(s for s in range(10_000 + seed, 20_000) if env.reset(seed=s) and GOAL[task](u) != goal)
        actions: list = []
        run_episode(env, r, other, on_step=lambda o, a, i, out=actions: out.append(a))
        wrong += _play(env, seed, lambda k, acts=actions: acts[min(k, len(acts) - 1)])
    out["wrong-instruction replay"] = wrong
    env.close()
    return {name: {"successes": n, "episodes": episodes, "rate": round(n / episodes, 3)} for name, n in out.items()}


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--robots", default=",".join(SUCCESS_ROBOTS), help="robots for success and trivial policies")
    p.add_argument("--tasks", default=",".join(TASKS))
    args = p.parse_args(argv)
    tasks = args.tasks.split(",")
    for t in tasks:
        envs.get_task(t)  # an unknown task: its one-line error, before any work
    results = {"step": {}, "step_ratio_to_grasp": {}, "render": {}, "retarget": {}, "success": {}, "trivial": {}}
    for robot in ROBOTS:
        grasp = step_cost("grasp", robot, args.runs)
        for task in tasks:
            results["step"][f"{task}/{robot}"] = r = grasp if task == "grasp" else step_cost(task, robot, args.runs)
            ratio = round(r["us_per_frame"] / grasp["us_per_frame"], 2)
            results["step_ratio_to_grasp"][f"{task}/{robot}"] = ratio
            print(f"step {task}/{robot}: {r['us_per_frame']} us/frame ({r['frames_per_s']} frames/s), "
                  f"{ratio}x HandGrasp", flush=True)  # fmt: skip
        for size in (128, 224):
            results["render"][f"{robot}/{size}x{size}"] = r = render_cost(robot, size, args.runs)
            print(f"render {robot} {size}x{size}: {r['us_per_frame']} us/frame", flush=True)
        for mode in ("joint", "ik"):
            results["retarget"][f"{robot}/{mode}"] = r = retarget_cost(robot, mode, args.runs)
            print(
                f"retarget {robot} {mode}: {r['us_per_frame']} us/frame, tip error {r['mean_tip_error_mm']} mm",
                flush=True,
            )
    for robot in args.robots.split(","):
        for task in tasks:
            for via in ("direct", "glove"):
                s = success_rate(task, robot, args.episodes, via)
                results["success"][f"{task}/{robot}/{via}"] = {
                    k: s[k] for k in ("success_rate", "successes", "episodes", "mean_tip_error_mm")
                }
                print(f"success {task}/{robot}/{via}: {s['successes']}/{s['episodes']}", flush=True)
            results["trivial"][f"{task}/{robot}"] = t = trivial(task, robot, args.episodes)
            rates = ", ".join(f"{k} {v['successes']}/{v['episodes']}" for k, v in t.items())
            print(f"trivial {task}/{robot}: {rates}", flush=True)
    write_results("envs", merged_with_previous("envs", results))


if __name__ == "__main__":
    main()
