"""The emulated wearers on every task and robot, direct and through the whole recording path (issue 41).

    MUJOCO_GL=egl .venv/bin/python bench/wearers.py [--tasks pinch,relocate] [--robots glovehand,shadow,leap]
                                                    [--episodes 50] [--paths direct,recorded] [--push]

Wearers (seeds 0..N-1, no meant failures):
  script      the task's scripted demonstrator (grasp and pinch: watching the robot hand close)
  open loop   the same, never looking at the robot hand (grasp and pinch only: what watching is worth)
  human       the human-like demonstrator (--demonstrator human --failure-rate 0)
Paths:
  direct      the wearer's joint angles and palm straight into the retargeter (recorder/rig/rollout.py)
  recorded    `gloverec record --glove emulator --fast` as a user runs it: emulated IMUs over the serial protocol,
              host fusion, retargeting, the dataset written (free-wrist tasks: --wrist marker:emulated, the
              emulated webcam filming the glove's marker)
With --push, each relocate and pick take's object is also pushed 2-4 cm mid-reach (direct): the demonstrators re-plan.
Each row: successes, the Wilson 95 % interval, and why the failed takes failed (the task's ``failure()``).
Writes bench/results/wearers.json (rows it does not measure are kept from the last run).
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import gloverec, merged_with_previous, wilson, write_results  # noqa: E402

import envs  # noqa: E402
from recorder.record.sidecar import read_sidecar  # noqa: E402
from recorder.rig.rollout import success_rate  # noqa: E402

ROBOTS = ("glovehand", "shadow", "leap")
WATCHED = ("grasp", "pinch")  # the tasks whose wearer watches the robot hand close: an open-loop row too
PUSH_CM = (2.0, 4.0)
PUSHED = ("relocate", "pick")  # the free-wrist tasks whose wearers re-plan from a pushed object


def wearers(task: str) -> list[tuple[str, dict]]:
    """(name, how) of the wearers measured on ``task``: how = demonstrator, failure_rate, watches."""
    out = [("script", {"demonstrator": "scripted"})]
    if task in WATCHED:
        out.append(("open loop", {"demonstrator": "scripted", "watches": False}))
    from recorder.demonstrator.human import HUMAN  # the tasks with a human-like wearer

    if task in HUMAN:
        out.append(("human", {"demonstrator": "human", "failure_rate": 0.0}))
    return out


def row(successes: int, episodes: int, reasons) -> dict:
    return {"successes": successes, "episodes": episodes, "rate": round(successes / episodes, 3),
            "wilson95": wilson(successes, episodes), "failed_because": dict(collections.Counter(reasons))}  # fmt: skip


def direct(task: str, robot: str, how: dict, episodes: int, push=None) -> dict:
    s = success_rate(task, robot, episodes, push_cm=push, **how)
    return row(s["successes"], episodes, [r.get("failed_because", "?") for r in s["runs"] if not r["success"]])


def recorded(task: str, robot: str, how: dict, episodes: int, tmp: Path) -> dict:
    root = tmp / f"{task}_{robot}_{len(list(tmp.iterdir()))}"
    args = ["record", "--view", "none", "--glove", "emulator", "--task", task, "--robot", robot, "--episodes",
            str(episodes), "--root", str(root), "--repo-id", f"bench/{task}", "--seed", "0", "--fast", "--no-log",
            "--demonstrator", how["demonstrator"]]  # fmt: skip
    if "failure_rate" in how:
        args += ["--failure-rate", str(how["failure_rate"])]
    if how.get("watches") is False:
        args.append("--open-loop")
    if envs.get_task(task).config_class().base_position:  # a free-wrist task: the emulated webcam's wrist
        args += ["--wrist", "marker:emulated"]
    gloverec(*args)
    records = read_sidecar(root)
    ok = sum(bool(r["success"]) for r in records)
    return row(ok, len(records), [r.get("failed_because", "?") for r in records if not r["success"]])


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--tasks", default=",".join(envs.task_names()))
    p.add_argument("--robots", default=",".join(ROBOTS))
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--paths", default="direct,recorded")
    p.add_argument("--push", action="store_true", help="also relocate and pick with the object pushed mid-reach")
    p.add_argument("--wearers", help="only these wearers (comma-separated: script, open loop, human)")
    args = p.parse_args(argv)
    tasks, paths = args.tasks.split(","), args.paths.split(",")
    for t in tasks:
        envs.get_task(t)  # an unknown task: one line, before any work
    results: dict = {"wearers": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for task in tasks:
            for robot in args.robots.split(","):
                for name, how in wearers(task):
                    if args.wearers and name not in args.wearers.split(","):
                        continue
                    for path in paths:
                        if path == "direct":
                            r = direct(task, robot, how, args.episodes)
                        else:
                            r = recorded(task, robot, how, args.episodes, Path(tmp))
                        results["wearers"][f"{task}/{robot}/{name}/{path}"] = r
                        print(f"{task}/{robot}/{name}/{path}: {r['successes']}/{r['episodes']} {r['wilson95']} "
                              f"{r['failed_because']}", flush=True)  # fmt: skip
                    if args.push and task in PUSHED:
                        r = direct(task, robot, how, args.episodes, PUSH_CM)
                        results["wearers"][f"{task}/{robot}/{name}/pushed 2-4 cm"] = r
                        print(f"{task}/{robot}/{name}/pushed: {r['successes']}/{r['episodes']} {r['wilson95']}",
                              flush=True)  # fmt: skip
    write_results("wearers", merged_with_previous("wearers", results))


if __name__ == "__main__":
    main()
