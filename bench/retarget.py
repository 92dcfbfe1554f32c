"""Retargeting benchmark: every robot and mode on the same human trajectories, for three wearers' hand sizes.

    .venv/bin/python bench/retarget.py [--runs 5] [--robots glovehand,shadow,leap] [--modes joint,ik,pinch]

Trajectories (30 Hz, the wearer's joint angles): the emulator's ``gestures`` (10 s) and ``random`` motion (10 s),
and pinches of the thumb with each finger the robot has (open hand -> thumb tip on the finger tip (pinch_pose
for that hand size) in 0.8 s, held 0.6 s, open again in 0.8 s). Wearers: hand lengths 170, 190 and 210 mm with
breadths 80, 85 and 90 mm (adult proportions are not a single scale: small hands are relatively broader).
Per robot, mode and size:
- fingertip error: mean and p95 over every frame and fingertip, robot fingertip vs the wearer's fingertip scaled
  to the robot (Retargeter.human_tips), mm;
- pinch gap at contact: over the frames where the wearer's thumb and finger tips touch (within 5 mm), how far
  apart the robot's fingertip pads are (their collision geoms; 0 when they touch or overlap), mean and max, mm;
- penetration: the deepest overlap of any two of the robot's fingers (the pairs its model collides), mm;
- time per frame: median over ``--runs`` runs, ms (all three trajectories, warm-started as when recording).
Baseline, same run: Shadow with its fingertip map from before (one scale for the hand, BEFORE), 190 mm hand.
The machine is shared and has 2 cores: single runs vary by tens of percent; medians are reported.
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np
from _common import write_results  # noqa: I001  (first: puts the repository on sys.path)

from envs.robots import robot_names
from envs.robots.config import TipsConfig
from recorder.hand.kinematics import HandSize
from recorder.hand.pinch import retarget_motions, tip_gap
from recorder.retarget import MODES, Retargeter
from recorder.retarget.contacts import FingerGeoms

RATE = 30.0
SIZES = {170: 80.0, 190: 85.0, 210: 90.0}  # hand length: breadth, mm
CONTACT_M = 0.005  # the wearer's fingertips touch
GOALS = {"pinch_gap_mm": 5.0, "mean_tip_mm": 6.0, "penetration_mm": 2.0, "ms_per_frame": 2.0}  # Shadow, pinch
# The baseline: Shadow's fingertip map before hand profiles and per-finger maps, one scale and offset for the whole
# hand (configs/robots/shadow.yaml until then). The errors reported then (IK 9.0 mm, joint map 11.6 mm, on gestures
# alone) were against its targets; measured again here on the same trajectories, 190 mm hand, every mode.
BEFORE = {"shadow": TipsConfig(0.947, (0.0345, 0.0044, -0.0049))}


def evaluate(robot: str, mode: str, size: HandSize, runs: int = 1, tips: TipsConfig | None = None) -> dict:
    r = Retargeter(robot, mode, base_rotation=False, hand_size=size)
    if tips is not None:
        r.tips = tips
    geoms = FingerGeoms(r.model, r.robot.tip_site_ids)
    tracks = retarget_motions(r.fingers[1:], size, RATE)
    tip_err, gaps, depth, per_frame = [], [], [], []
    for run in range(runs):
        frames, t0 = 0, time.perf_counter()
        results = {}
        for name, (angles, _) in tracks.items():
            r.reset()
            results[name] = [r(a)[1] for a in angles]
            frames += len(angles)
        per_frame.append((time.perf_counter() - t0) / frames)
        if run:
            continue
        for name, (angles, which) in tracks.items():
            for a, info, f in zip(angles, results[name], which or [None] * len(angles)):
                tip_err.append(info["tip_error"])
                r.data.qpos[:] = info["qpos"]
                mujoco.mj_kinematics(r.model, r.data)
                depth.append(geoms.deepest(r.data))
                if f is not None and tip_gap(a, size, f) <= CONTACT_M * size.axes()[0]:
                    k = r.fingers.index(f)
                    gaps.append(max(0.0, geoms.pad_distance(r.data, k)))
    e = np.concatenate(tip_err)
    return {
        "mean_tip_mm": round(1e3 * float(e.mean()), 2),
        "p95_tip_mm": round(1e3 * float(np.percentile(e, 95)), 2),
        "pinch_gap_mm": round(1e3 * float(np.mean(gaps)), 2) if gaps else None,
        "pinch_gap_max_mm": round(1e3 * float(np.max(gaps)), 2) if gaps else None,
        "contact_frames": len(gaps),
        "penetration_mm": round(1e3 * float(np.max(depth)), 2),
        "ms_per_frame": round(1e3 * statistics.median(per_frame), 3),
        "runs": runs,
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--robots", default=",".join(robot_names()))
    p.add_argument("--modes", default=",".join(MODES))
    args = p.parse_args(argv)
    results = {}
    for robot in args.robots.split(","):
        for mode in args.modes.split(","):
            for length, breadth in SIZES.items():
                size = HandSize(hand_length_mm=float(length), hand_breadth_mm=breadth)
                results[f"{robot}/{mode}/{length}"] = out = evaluate(robot, mode, size, args.runs)
                print(f"{robot:10s} {mode:6s} {length} mm: {out}", flush=True)
            if robot in BEFORE:
                results[f"{robot}/{mode}/190/map_before"] = out = evaluate(
                    robot, mode, HandSize(), args.runs, BEFORE[robot]
                )
                print(f"{robot:10s} {mode:6s} 190 mm, the fingertip map before: {out}", flush=True)
    shadow = [v for k, v in results.items() if k.startswith("shadow/pinch/") and k.count("/") == 2]  # not BEFORE
    if shadow:
        worst = {k: max(v[k] or 0.0 for v in shadow) for k in GOALS}
        results["goals_shadow_pinch"] = {
            k: {"goal": g, "worst_size": worst[k], "met": worst[k] <= g} for k, g in GOALS.items()
        }
        print("shadow pinch goals:", results["goals_shadow_pinch"])
    depth = {k: v["penetration_mm"] for k, v in results.items() if "/pinch/" in k and k.count("/") == 2}
    if depth:  # the pinch mode keeps every robot's fingers apart, not only Shadow's
        bound = GOALS["penetration_mm"]
        results["pinch_penetration"] = {
            "bound_mm": bound,
            "worst_mm": max(depth.values()),
            "met": max(depth.values()) <= bound,
        }
        print("pinch penetration, every robot:", results["pinch_penetration"])
    write_results("retarget", results)


if __name__ == "__main__":
    main()
