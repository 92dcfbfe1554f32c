"""The tracked wrist while it moves: the marker's pose per frame against the wrist fused with the palm IMU
(recorder/wrist/fusion.py), on the relocate demonstrator's wrist paths (the demonstrators' speeds) filmed by the
emulated webcam (recorder/wrist/emulated.py: 640x480, a 40 mm marker, 30 fps, 50 ms latency). Episode k's camera
stands 0.45-0.7 m from the workspace (spread over the episodes) and 35-60 degrees above the table; the marker, on
the moving hand, is seen from the distances the results list (5th-95th percentile) and tilted 25-60 degrees. The
IMU is the demonstration's palm at 100 Hz with 0.5 degrees of noise (the synthetic glove's); its heading drift is
bench/wrist_heading.py's.

Scored, against the truth:
- tracking, at each camera frame's capture time, in the camera's frame: the per-frame tracker ("subpix": OpenCV's
  cornerSubPix corners, the usual choice; "apriltag": gloverec's edge fit; each with solvePnPGeneric's first
  pose) and the fused estimate right after that frame (a causal filter: what it knew then, so lag counts);
  detection among the frames where the whole marker is in the image; frames off by more than 10 degrees;
- the applied target, at each 30 Hz control tick, in the robot's world: the fused wrist predicted to the tick
  (the 50 ms latency compensated) against the truth at the tick, both taken relative to the zero (the wearer's
  heading at the zero is the robot's +x by definition).
Writes bench/results/wrist_fusion.json.

    MUJOCO_GL=egl .venv/bin/python bench/wrist_fusion.py [--episodes 10]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import envs  # noqa: E402
from recorder import quat  # noqa: E402
from recorder.demonstrator import make_demonstrator  # noqa: E402
from recorder.wrist.emulated import EmulatedCamera  # noqa: E402
from recorder.wrist.fusion import FusionConfig, WristFusion, heading_of  # noqa: E402
from recorder.wrist.marker import MarkerTracker  # noqa: E402

IMU_HZ, CONTROL_HZ, IMU_NOISE_DEG, EPISODE_S = 100.0, 30.0, 0.5, 7.0


def visible(camera: EmulatedCamera, p, q) -> bool:
    """The whole marker is in the image and faces the camera (truth, camera frame)."""
    corners = p + quat.rotate(q, camera.tracker.marker.corners())
    m = camera.camera
    u = m.fx * corners[:, 0] / corners[:, 2] + m.cx
    v = m.fy * corners[:, 1] / corners[:, 2] + m.cy
    facing = quat.rotate(q, np.array([0.0, 0.0, 1.0])) @ p < 0
    return bool(facing and np.all(corners[:, 2] > 0) and np.all((u >= 0) & (u < m.width) & (v >= 0) & (v < m.height)))


def episode(env, seed: int, distance: float, elevation: float, rng) -> dict:
    u = env.unwrapped
    env.reset(seed=seed)
    motion = make_demonstrator("relocate").plan(u, seed=seed)
    camera = EmulatedCamera(distance_m=distance, elevation_deg=elevation)
    subpix = MarkerTracker(camera.tracker.marker, camera.camera, "subpix")
    fusion = WristFusion(FusionConfig(latency_s=camera.latency_s))
    frames = []  # (capture t, pose as it arrives, subpix pose, true p, true q, visible)
    for k in range(int(EPISODE_S * camera.fps)):
        tc = k / camera.fps
        b = motion.at([tc])
        image, p_true, q_true = camera.scene.render(*camera.placement(b.palm_pos[0], b.palm_quat[0]))
        frames.append((tc, camera.tracked(tc, image), camera.tracked(tc, image, subpix), p_true, q_true,
                       visible(camera, p_true, q_true)))  # fmt: skip
    camera.close()
    out = {k: [] for k in ("subpix", "apriltag", "fused", "subpix_deg", "apriltag_deg", "fused_deg", "target",
                           "target_deg")}  # fmt: skip
    out |= {"visible": 0, "detected": 0, "untracked_ticks": 0, "distance": []}
    zero = None
    next_frame, next_tick = 0, 0
    for i in range(int(EPISODE_S * IMU_HZ)):
        t = i / IMU_HZ
        b = motion.at([t])
        fusion.imu(t, quat.mul(b.palm_quat[0], quat.from_rotvec(rng.normal(0, np.radians(IMU_NOISE_DEG), 3))))
        while next_frame < len(frames) and frames[next_frame][1].t <= t + 1e-9:
            tc, pose, raw, p_true, q_true, seen = frames[next_frame]
            next_frame += 1
            fusion.tracker(pose)
            if zero is None:  # the wearer holds still in the start pose until the first frame has come
                zero = (t, b.palm_pos[0], heading_of(b.palm_quat[0]))
                assert fusion.zero(t, zero[1])
                continue
            out["distance"].append(np.linalg.norm(p_true))
            out["visible"] += seen
            out["detected"] += seen and pose.tracked
            for name, found in (("subpix", raw), ("apriltag", pose)):
                if found.tracked:
                    out[name].append(np.linalg.norm(found.position - p_true))
                    out[name + "_deg"].append(np.degrees(quat.angle_between(found.quat, q_true)))
            if seen:
                p, q = fusion.marker(tc)
                out["fused"].append(np.linalg.norm(p - p_true))
                out["fused_deg"].append(np.degrees(quat.angle_between(q, q_true)))
        if zero is not None and t + 1e-9 >= next_tick / CONTROL_HZ:
            next_tick = int(np.floor(t * CONTROL_HZ + 1e-9)) + 1
            fused = fusion.pose(t)
            out["untracked_ticks"] += not fused.tracked
            turn = quat.from_axis_angle([0.0, 0.0, 1.0], -zero[2])  # the truth, relative to the zero's heading
            truth = zero[1] + quat.rotate(turn, b.palm_pos[0] - zero[1])
            out["target"].append(np.linalg.norm(fused.position - truth))
            out["target_deg"].append(np.degrees(quat.angle_between(fused.quat, quat.mul(turn, b.palm_quat[0]))))
    out["flips"] = fusion.flips
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=10)
    args = p.parse_args(argv)
    env = envs.make("relocate")
    rng = np.random.default_rng(0)
    t0 = time.perf_counter()
    distances = np.linspace(0.45, 0.7, args.episodes)
    elevations = 35.0 + 25.0 * ((np.arange(args.episodes) * 0.618) % 1.0)
    runs = [episode(env, s, float(d), float(e), rng) for s, (d, e) in enumerate(zip(distances, elevations))]

    def cat(key):
        return np.concatenate([r[key] for r in runs])

    def rmse(key, scale=1e3):
        return round(float(np.sqrt(np.mean(cat(key) ** 2))) * scale, 2)

    def figures(name: str, mm_key: str) -> dict:
        deg = cat(name + "_deg")
        return {
            "position_rmse_mm": rmse(mm_key),
            "orientation_rmse_deg": round(float(np.sqrt(np.mean(deg**2))), 2),
            "orientation_max_deg": round(float(deg.max()), 2),
            "frames_off_over_10_deg": int(np.sum(deg > 10)),
        }

    visible_frames = sum(r["visible"] for r in runs)
    out = {
        "episodes": args.episodes,
        "camera": "640x480, fovy 45, 40 mm marker, 30 fps, 50 ms latency",
        "camera_distance_m": [round(float(distances[0]), 2), round(float(distances[-1]), 2)],
        "camera_elevation_deg": [35, 60],
        "marker_distance_m_p5_p95": [round(float(v), 2) for v in np.percentile(cat("distance"), [5, 95])],
        "imu": f"{IMU_HZ:g} Hz, {IMU_NOISE_DEG} deg noise, no drift",
        "visible_frames": visible_frames,
        "detected_fraction_of_visible": round(sum(r["detected"] for r in runs) / max(visible_frames, 1), 4),
        "tracking_per_frame_subpix": figures("subpix", "subpix"),
        "tracking_per_frame_apriltag": figures("apriltag", "apriltag"),
        "tracking_fused": figures("fused", "fused"),
        "ippe_flips_chosen_by_imu": int(sum(r["flips"] for r in runs)),
        "applied_target_world": {
            "position_rmse_mm": rmse("target"),
            "orientation_rmse_deg": round(float(np.sqrt(np.mean(cat("target_deg") ** 2))), 2),
            "orientation_max_deg": round(float(cat("target_deg").max()), 2),
            "untracked_ticks": int(sum(r["untracked_ticks"] for r in runs)),
        },
        "per_episode": [
            {
                "camera_distance_m": round(float(d), 3),
                "camera_elevation_deg": round(float(e), 1),
                "position_rmse_mm_per_frame_apriltag": round(
                    float(np.sqrt(np.mean(np.square(r["apriltag"])))) * 1e3, 2
                ),
                "position_rmse_mm_fused": round(float(np.sqrt(np.mean(np.square(r["fused"])))) * 1e3, 2),
                "applied_target_rmse_mm": round(float(np.sqrt(np.mean(np.square(r["target"])))) * 1e3, 2),
            }
            for r, d, e in zip(runs, distances, elevations)
        ],
        "wall_s": round(time.perf_counter() - t0, 1),
    }
    print(json.dumps(out, indent=1))
    write_results("wrist_fusion", out)


if __name__ == "__main__":
    main()
