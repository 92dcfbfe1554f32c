"""Wrist tracking benchmark: the printed marker's pose from rendered webcam frames with known truth.

    MUJOCO_GL=egl .venv/bin/python bench/wrist.py [--frames 300] [--seed 0]

Each frame places a 40 mm ArUco marker (4X4_50, id 0) at 0.4-0.8 m from a 640x480, 45 degree webcam, anywhere in
the middle 70 % of the view, tilted up to 50 degrees about a random axis and turned at random in its plane
(recorder/wrist/marker.py MarkerScene, MuJoCo offscreen, lossless). The same frames go to the per-frame tracker
(MarkerTracker: OpenCV's ArUco detector and solvePnPGeneric IPPE_SQUARE, no filtering) with each corner
refinement: "subpix" (cornerSubPix, the usual choice and the baseline) and "apriltag" (the edge fit, gloverec's
default). Scored against the truth: detection rate, position and orientation RMSE (overall, near and far), the
depth's bias (the marker read too far away), frames whose orientation is off by more than 10 degrees (the planar
pose ambiguity's flips) as the solver ranks the two poses and once the palm IMU chooses between them (the IMU
here: the truth with 0.5 degrees of noise, the synthetic glove's), and the time per frame (median, detection and
pose). Issue 24's goals: position RMSE <= 5 mm, orientation RMSE <= 1.5 degrees, >= 95 % detected, no frame off
by more than 10 degrees once fused with the palm IMU, <= 5 ms per frame. Moving wrists, filtered and fused:
bench/wrist_fusion.py.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

from recorder import quat  # noqa: E402
from recorder.wrist.marker import MarkerScene, MarkerTracker  # noqa: E402

IMU_NOISE_DEG = 0.5


def frames(scene: MarkerScene, n: int, rng):
    """n rendered frames: (distance, image, true position, true quat) in the camera's frame."""
    face = quat.from_two_vectors(np.array([0.0, 0, 1]), np.array([-1.0, 0, 0]))
    half_fov = np.tan(np.radians(45.0) / 2)
    for _ in range(n):
        d = rng.uniform(0.4, 0.8)
        pos = [d, rng.uniform(-1, 1) * 0.7 * d * half_fov * 640 / 480, rng.uniform(-1, 1) * 0.7 * d * half_fov]
        axis = np.array([0.0, *rng.normal(size=2)])
        axis /= np.linalg.norm(axis)
        spin = quat.from_axis_angle(np.array([1.0, 0, 0]), rng.uniform(-np.pi, np.pi))
        q = quat.mul(quat.from_axis_angle(axis, np.radians(rng.uniform(0, 50))), quat.mul(spin, face))
        yield (d, *scene.render(pos, q))


def score(tracker: MarkerTracker, shots, rng) -> dict:
    rows = []
    for d, image, p_true, q_true in shots:
        t = time.perf_counter()
        found = tracker.track(image)
        ms = (time.perf_counter() - t) * 1000
        if found is None:
            rows.append((d, None, None, None, None, ms))
            continue
        imu = quat.mul(quat.from_rotvec(rng.normal(0, np.radians(IMU_NOISE_DEG), 3)), q_true)
        p, q = found.position, found.quat
        if found.alternative is not None and quat.angle_between(found.alternative[1], imu) < quat.angle_between(q, imu):
            p, q = found.alternative
        first_deg = float(np.degrees(quat.angle_between(found.quat, q_true)))
        rows.append((d, 1000 * np.linalg.norm(found.position - p_true), first_deg, 1000 * np.linalg.norm(p - p_true),
                     float(np.degrees(quat.angle_between(q, q_true))), ms,
                     (found.position[2] - p_true[2]) / p_true[2]))  # fmt: skip
    seen = [r for r in rows if r[1] is not None]

    def rmse(values):
        return round(float(np.sqrt(np.mean(np.square(values)))), 2) if values else None

    return {
        "detected_fraction": round(len(seen) / len(rows), 4),
        "position_rmse_mm": rmse([r[1] for r in seen]),
        "position_rmse_mm_0.40_0.55": rmse([r[1] for r in seen if r[0] < 0.55]),
        "position_rmse_mm_0.65_0.80": rmse([r[1] for r in seen if r[0] > 0.65]),
        "depth_bias_percent": round(100 * float(np.mean([r[6] for r in seen])), 3),
        "orientation_rmse_deg": rmse([r[2] for r in seen]),
        "frames_off_over_10_deg": sum(r[2] > 10 for r in seen),
        "imu_chosen": {
            "position_rmse_mm": rmse([r[3] for r in seen]),
            "orientation_rmse_deg": rmse([r[4] for r in seen]),
            "frames_off_over_10_deg": sum(r[4] > 10 for r in seen),
        },
        "ms_per_frame_median": round(statistics.median(r[5] for r in rows), 2),
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=300)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    scene = MarkerScene()
    shots = list(frames(scene, args.frames, np.random.default_rng(args.seed)))
    scene.close()
    result = {
        "frames": len(shots),
        "image": [640, 480],
        "marker_mm": 40,
        "distance_m": [0.4, 0.8],
        "tilt_deg_max": 50,
        "imu_noise_deg": IMU_NOISE_DEG,
        "tracker": "per frame: ArUco corners, solvePnPGeneric IPPE_SQUARE; no filtering",
    }
    for refinement in ("subpix", "apriltag"):
        tracker = MarkerTracker(scene.marker, scene.camera, refinement)
        result[refinement] = score(tracker, shots, np.random.default_rng(args.seed + 1))
        print(refinement, result[refinement], flush=True)
    write_results("wrist", result)


if __name__ == "__main__":
    main()
