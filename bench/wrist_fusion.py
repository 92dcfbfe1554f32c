"""The tracked wrist while it moves: per-frame marker poses against the wrist fused with the palm IMU
(recorder/wrist/fusion.py), scored against the truth at each control tick's time, on the relocate demonstrator's
wrist paths filmed by the emulated webcam (recorder/wrist/emulated.py: 640×480, a 40 mm marker, 50 ms latency).
The per-frame baseline is the newest tracked pose as it arrives (latency and all); the fused one is predicted to
the tick. The IMU here is the demonstration's palm (the glove's palm quaternion with 0.5° of noise, no drift: the
heading test is tests/test_free_wrist.py). Writes bench/results/wrist_fusion.json.

    MUJOCO_GL=egl .venv/bin/python bench/wrist_fusion.py [--episodes 10]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository's envs, not bench/envs.py
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
import numpy as np  # noqa: E402

import envs  # noqa: E402
from recorder import quat  # noqa: E402
from recorder.demonstrator import make_demonstrator  # noqa: E402
from recorder.wrist.emulated import EmulatedCamera  # noqa: E402
from recorder.wrist.fusion import FusionConfig, WristFusion  # noqa: E402


def episode(env, seed: int, camera: EmulatedCamera, rng) -> dict:
    u = env.unwrapped
    env.reset(seed=seed)
    motion = make_demonstrator("relocate").plan(u, seed=seed)
    fusion = WristFusion(FusionConfig(latency_s=camera.latency_s))
    t_in_w = None
    fused_err, frame_err, ang_err = [], [], []
    last_frame, k_frame = None, 0
    dt = 1.0 / 30
    start = None
    for k in range(int(7.0 / dt)):
        t = k * dt
        b = motion.at([t])
        noise = quat.from_rotvec(rng.normal(0, np.radians(0.5), 3))
        fusion.imu(t, quat.mul(b.palm_quat[0], noise))
        while k_frame / camera.fps + camera.latency_s <= t + 1e-9:
            tc = k_frame / camera.fps
            bc = motion.at([tc])
            pose, _ = camera.capture(tc, bc.palm_pos[0], bc.palm_quat[0])
            fusion.tracker(pose)
            if pose.tracked:
                last_frame = pose
            k_frame += 1
        if k == 0:
            pose, _ = camera.capture(0.0, b.palm_pos[0], b.palm_quat[0])
            fusion.tracker(pose)
            start = b.palm_pos[0]
            assert fusion.zero(0.0, start)
            t_in_w, p0 = fusion.t_in_w, fusion.origin[0]
            continue
        out = fusion.pose(t)
        fused_err.append(np.linalg.norm(out.position - b.palm_pos[0]))
        ang_err.append(np.degrees(quat.angle_between(out.quat, b.palm_quat[0])))
        if last_frame is not None:  # the newest frame as it came, mapped with the same zero
            frame_err.append(np.linalg.norm(start + quat.rotate(t_in_w, last_frame.position - p0) - b.palm_pos[0]))
    return {"fused": fused_err, "frame": frame_err, "angle": ang_err, "flips": fusion.flips}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=10)
    args = p.parse_args()
    env = envs.make("relocate")
    camera = EmulatedCamera()
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    runs = [episode(env, s, camera, rng) for s in range(args.episodes)]

    def rmse(key, scale=1e3):
        x = np.concatenate([r[key] for r in runs])
        return round(float(np.sqrt(np.mean(x**2))) * scale, 2)

    out = {
        "episodes": args.episodes,
        "camera": "640x480, fovy 45, 40 mm marker, 0.55 m, 50 ms latency, 30 fps",
        "position_rmse_mm_per_frame_as_it_arrives": rmse("frame"),
        "position_rmse_mm_fused": rmse("fused"),
        "orientation_rmse_deg_fused": rmse("angle", 1.0),
        "orientation_max_deg_fused": round(float(max(max(r["angle"]) for r in runs)), 2),
        "ippe_flips_chosen_by_imu": int(sum(r["flips"] for r in runs)),
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(out))
    path = Path(__file__).parent / "results" / "wrist_fusion.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
