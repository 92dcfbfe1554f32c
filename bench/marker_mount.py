"""Where the marker sits on the glove (recorder/wrist/mounting.py, `gloverec calibrate --wrist`): the mounting the
calibration step finds on the emulator against the one the emulated marker is glued at, and what it buys.

- calibration: `gloverec calibrate --glove emulator --wrist marker:emulated:RX,RY,RZ` (15 s, the emulated wearer
  tilting and turning its palm in front of the emulated webcam) for the marker glued flat, 12.2° off about a
  tilted axis, and 90° turned in the back of the hand's plane: the error of the mounting found, the residual,
  the frames used and those that took IPPE's other pose;
- what it buys: 10 relocate demonstrations filmed by the emulated webcam with the marker glued 12.2° off, fused
  with the palm IMU (0.5° of noise, 100 Hz) taking the marker as flat, as found, and as truly glued: the applied
  target's error at each 30 Hz tick in the robot's world (as bench/wrist_fusion.py scores it).
Writes bench/results/marker_mount.json.

    MUJOCO_GL=egl .venv/bin/python bench/marker_mount.py [--episodes 10]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import envs  # noqa: E402
from recorder import quat  # noqa: E402
from recorder.calibrate.mount import calibrate_mount  # noqa: E402
from recorder.demonstrator import make_demonstrator  # noqa: E402
from recorder.wrist.emulated import EmulatedCamera  # noqa: E402
from recorder.wrist.fusion import FusionConfig, WristFusion, heading_of  # noqa: E402

GLUED = {"flat": "0,0,0", "12deg_tilted": "7,-6,8", "90deg_turned": "0,0,90"}
IMU_HZ, CONTROL_HZ, EPISODE_S = 100.0, 30.0, 7.0


def calibration(glued: str) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        r = calibrate_mount("emulator", f"marker:emulated:{glued}", 15.0, folder=folder, out=open("/dev/null", "w"))
        took = time.perf_counter() - start
    keys = ("emulated_mount_deg", "emulated_error_deg", "residual_deg", "samples", "flipped", "dropped", "turned_deg")
    return {k: r[k] for k in keys} | {"seconds": round(took, 1)}


def targets(episodes: int, glued, mounts: dict) -> dict:
    """The applied target's error (mm) and the palm's (deg) per tick, for each mounting the fusion is given."""
    env = envs.make("relocate", base_position=True)
    u = env.unwrapped
    out = {name: {"mm": [], "deg": []} for name in mounts}
    for seed in range(episodes):
        env.reset(seed=seed)
        motion = make_demonstrator("relocate").plan(u, seed=seed)
        camera = EmulatedCamera(marker_in_palm=glued)
        frames = []
        for k in range(int(EPISODE_S * camera.fps)):
            b = motion.at([k / camera.fps])
            frames.append(camera.capture(k / camera.fps, b.palm_pos[0], b.palm_quat[0])[0])
        camera.close()
        for name, mount in mounts.items():
            rng = np.random.default_rng(seed)
            fusion = WristFusion(FusionConfig(latency_s=camera.latency_s), marker_in_palm=mount)
            zero, next_frame, next_tick = None, 0, 0
            for i in range(int(EPISODE_S * IMU_HZ)):
                t = i / IMU_HZ
                b = motion.at([t])
                fusion.imu(t, quat.mul(b.palm_quat[0], quat.from_rotvec(rng.normal(0, np.radians(0.5), 3))))
                while next_frame < len(frames) and frames[next_frame].t <= t + 1e-9:
                    fusion.tracker(frames[next_frame])
                    next_frame += 1
                    if zero is None:  # the wearer holds still in the start pose until the first frame has come
                        zero = (b.palm_pos[0], heading_of(b.palm_quat[0]))
                        assert fusion.zero(t, zero[0])
                if zero is not None and t + 1e-9 >= next_tick / CONTROL_HZ:
                    next_tick = int(np.floor(t * CONTROL_HZ + 1e-9)) + 1
                    fused = fusion.pose(t)
                    turn = quat.from_axis_angle([0.0, 0.0, 1.0], -zero[1])  # the truth relative to the zero's heading
                    truth = zero[0] + quat.rotate(turn, b.palm_pos[0] - zero[0])
                    out[name]["mm"].append(1e3 * np.linalg.norm(fused.position - truth))
                    palm = quat.mul(turn, b.palm_quat[0])
                    out[name]["deg"].append(np.degrees(quat.angle_between(fused.quat, palm)))
    env.close()

    def rms(x):
        return round(float(np.sqrt(np.mean(np.square(x)))), 2)

    return {
        name: {
            "target_mm_rms": rms(r["mm"]),
            "target_mm_worst": round(float(np.max(r["mm"])), 1),
            "palm_deg_rms": rms(r["deg"]),
            "palm_deg_worst": round(float(np.max(r["deg"])), 2),
        }  # fmt: skip
        for name, r in out.items()
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=10)
    args = p.parse_args(argv)
    calibrations = {name: calibration(glued) for name, glued in GLUED.items()}
    for name, c in calibrations.items():
        print(f"{name}: glued {c['emulated_mount_deg']:.1f} deg off, found to within "
              f"{c['emulated_error_deg']:.2f} deg, residual {c['residual_deg']:.2f} deg over {c['samples']} frames "
              f"({c['flipped']} flipped)")  # fmt: skip
    glued = quat.from_rotvec(np.radians([float(v) for v in GLUED["12deg_tilted"].split(",")]))
    with tempfile.TemporaryDirectory() as folder:
        found = calibrate_mount("emulator", f"marker:emulated:{GLUED['12deg_tilted']}", 15.0, folder=folder,
                                out=open("/dev/null", "w"))["quat"]  # fmt: skip
    fused = targets(args.episodes, glued, {"taken_flat": quat.IDENTITY, "found": np.asarray(found), "true": glued})
    for name, f in fused.items():
        print(f"relocate, marker glued 12.2 deg off, {name}: target {f['target_mm_rms']} mm RMS "
              f"({f['target_mm_worst']} at worst), palm {f['palm_deg_rms']} deg RMS")  # fmt: skip
    write_results("marker_mount", {"calibration": calibrations, "relocate_glued_12deg": fused,
                                   "episodes": args.episodes})  # fmt: skip


if __name__ == "__main__":
    main()
