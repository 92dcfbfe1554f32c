"""Fit a robot's fingertip map and joint map: the ``retarget.tips`` and ``retarget.joints`` of a new robot.

    python -m recorder.retarget.fit shadow [--samples 400] [--actuators robot0:A_THJ4,...]

Samples human poses (gestures with variability and random poses in the anatomical ranges, on the reference hand),
then
1. tips: one scale and offset for the hand that best match the joint-mapped fingers (thumb excluded: its base
   differs most), then, per finger, the scale and offset that map the human fingertips onto where the robot's
   finger actually gets (fingertip least squares within its joint limits, clear of the other fingers; a few
   rounds): each finger's workspace mapped onto the robot's, so targets are reachable and a pinch's fingertips
   meet where the robot can meet them;
2. joints: fingertip IK for each pose (posture pulled weakly toward the current joint map), and every listed
   actuator (default: those with a human source) fitted as offset + sum(weight * angle) over the human joints of
   the finger(s) its current source uses.
Prints the fitted ``tips`` and ``joints`` entries as YAML, and the mean fingertip error of the current and the
fitted maps on the samples; review them, then paste into the robot's yaml.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from envs.robots.config import FingerTips, TipsConfig
from recorder.hand.gestures import GESTURES
from recorder.hand.kinematics import JOINTS, LIMITS, interpolate_dip
from recorder.retarget.retargeter import Retargeter

TIP_ROUNDS = 4


def sample_poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    names = list(GESTURES)
    out = []
    for k in range(n):
        if k % 2:
            a = GESTURES[names[k // 2 % len(names)]] + rng.normal(0, np.radians(8), len(JOINTS))
        else:
            a = rng.uniform(LIMITS[:, 0], LIMITS[:, 1])
        out.append(interpolate_dip(np.clip(a, LIMITS[:, 0], LIMITS[:, 1])))
    return np.array(out)


def mean_tip_error(r: Retargeter, poses: np.ndarray) -> float:
    return float(np.mean([r(a)[1]["tip_error_mean"] for a in poses]))


def _reached(r: Retargeter, poses: np.ndarray) -> np.ndarray:
    """Robot fingertips (N, n, 3) that fingertip least squares reaches for each pose's targets."""
    out = []
    for a in poses:
        r.reset()
        out.append(r.robot_tips(r(a)[1]["qpos"]))
    return np.array(out)


def fit_tips(robot: str, poses: np.ndarray) -> TipsConfig:
    joint = Retargeter(robot, "joint", base_rotation=False)
    human = np.array([joint.reference_tips(a) for a in poses])  # (N, n, 3)
    rob = np.array([joint.robot_tips(joint.qpos(joint.joint_map(a))) for a in poses])
    s, o = _similarity(human[:, 1:], rob[:, 1:])
    tips = TipsConfig(s, o)
    reach = Retargeter(robot, "pinch", base_rotation=False)  # fingertips only: the other terms off
    reach.pinch.config = dataclasses.replace(
        reach.pinch.config, vector_weight=1e-9, pinch_weight=1e-9, smooth_weight=1e-9, iterations=25, improvement=1e-6
    )
    for _ in range(TIP_ROUNDS):
        reach.tips = tips
        got = _reached(reach, poses)
        fingers = {f: FingerTips(*_similarity(human[:, k], got[:, k])) for k, f in enumerate(reach.fingers)}
        tips = TipsConfig(s, o, fingers)
    return tips


def _similarity(human: np.ndarray, robot: np.ndarray) -> tuple[float, tuple]:
    """Least-squares scale and offset with robot ~ scale * human + offset (points (..., 3))."""
    h, r = human.reshape(-1, 3), robot.reshape(-1, 3)
    X = np.zeros((h.size, 4))
    X[:, 0] = h.reshape(-1)
    for k in range(3):
        X[k::3, 1 + k] = 1.0
    s, *o = np.linalg.lstsq(X, r.reshape(-1), rcond=None)[0]
    return float(s), tuple(float(v) for v in o)


def fit(robot: str, samples: int = 400, actuators=None, seed: int = 0) -> dict:
    poses = sample_poses(samples, seed)
    tips = fit_tips(robot, poses)
    ik = Retargeter(robot, "ik", base_rotation=False)
    c = ik.map
    ik.tips = tips
    ik.ik.config = dataclasses.replace(ik.ik.config, iterations=30, posture_cost=0.01)
    ik.ik.posture.set_cost(np.where(ik.ik.posture.cost > 1, ik.ik.posture.cost, 0.01))
    # 2. IK targets per pose
    targets = []
    for a in poses:
        ik.reset()
        targets.append(ik(a)[1]["joint_targets"])
    targets = np.array(targets)
    # 3. per actuator: least squares over its finger's human joints
    names = actuators or [n for i, n in enumerate(c.actuators) if not c.constant[i]]
    fitted = {}
    for name in names:
        i = c.actuators.index(name)
        fingers = {JOINTS[j].split("_")[0] for j in np.flatnonzero(c.A[i])}
        cols = [j for j, n in enumerate(JOINTS) if n.split("_")[0] in fingers and not n.endswith("dip")]
        X = np.column_stack((poses[:, cols], np.ones(len(poses))))
        w = np.linalg.lstsq(X, targets[:, i], rcond=1e-6)[0]
        fitted[name] = (
            {JOINTS[j]: round(float(v), 3) for j, v in zip(cols, w[:-1]) if abs(v) > 1e-3},
            round(float(w[-1]), 3),
        )
    A, b = c.A.copy(), c.b.copy()
    for name, (src, off) in fitted.items():
        i = c.actuators.index(name)
        A[i] = 0.0
        for j, v in src.items():
            A[i, JOINTS.index(j)] = v
        b[i] = off
    before = Retargeter(robot, "joint", base_rotation=False)
    before.tips = tips
    after = Retargeter(robot, "joint", base_rotation=False)
    after.tips = tips
    after.map = dataclasses.replace(c, A=A, b=b)
    return {
        "tips": tips,
        "joints": fitted,
        "error_before_m": mean_tip_error(before, poses),
        "error_after_m": mean_tip_error(after, poses),
    }


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:.4f}" for x in v) + "]"


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("robot")
    p.add_argument("--samples", type=int, default=400)
    p.add_argument("--actuators", help="comma-separated actuator names (default: all with a human source)")
    args = p.parse_args(argv)
    out = fit(args.robot, args.samples, args.actuators.split(",") if args.actuators else None)
    print(
        f"# mean fingertip error on {args.samples} poses: current map {out['error_before_m'] * 1000:.1f} mm, "
        f"fitted {out['error_after_m'] * 1000:.1f} mm"
    )
    t = out["tips"]
    print("  tips:")
    print(f"    scale: {t.scale:.3f}")
    print(f"    offset: {_vec(t.offset)}")
    print("    fingers:")
    for f, ft in t.fingers.items():
        print(f"      {f}: {{scale: {ft.scale:.3f}, offset: {_vec(ft.offset)}}}")
    print("  joints:")
    for name, (src, off) in out["joints"].items():
        print(f'    "{name}": {{source: {src}, offset: {off}}}')


if __name__ == "__main__":
    main()
