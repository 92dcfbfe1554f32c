"""Recording benchmark: how much faster than real time `gloverec record` generates data, and how well it
keeps time at real time.

    .venv/bin/python bench/record.py [--runs 3] [--realtime-s 300]

Fast: the scripted demonstrator drives the emulated glove through the pty, fusion-free pose frames, HandPose
on glovehand; frames/s = dataset frames / session wall time (startup excluded), median of --runs sessions,
state-only and with one 128x128 camera (goals: >= 1000 and >= 60 frames/s).
Real time: a separate `gloverec emulate` process is the glove (200 Hz, as a USB glove would be); the loop
records at 100 fps for --realtime-s seconds of episodes: glove frames dropped (goal 0), tick jitter p99
(goal <= 2 ms), glove sample -> action latency p99 (goal <= 10 ms).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_results  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("HF_HUB_OFFLINE", "1")

from recorder.record.config import RecordConfig  # noqa: E402
from recorder.record.recorder import Recorder  # noqa: E402
from recorder.record.store import read_sidecar  # noqa: E402


def session(tmp: str, **cfg) -> tuple[float, int, list[dict]]:
    rec = Recorder(RecordConfig.load(root=f"{tmp}/ds{time.monotonic_ns()}", repo_id="bench/record", **cfg),
                   out=None)
    t = time.perf_counter()
    summary = rec.run()
    wall = time.perf_counter() - t
    return wall, summary["total_frames"], read_sidecar(summary["root"])


def fast(runs: int, cameras: list) -> dict:
    rates = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(runs):
            wall, frames, _ = session(tmp, episodes=10, cameras=cameras, realtime=False, log=False)
            rates.append(frames / wall)
    return {"cameras": cameras, "episodes": 10, "frames_per_s": {
        "median": round(statistics.median(rates), 1), "min": round(min(rates), 1), "max": round(max(rates), 1),
        "runs": runs}}


def realtime(seconds: float, fps: int = 100) -> dict:
    episode_s = 10.0
    with tempfile.TemporaryDirectory() as tmp:
        link = f"{tmp}/glove"
        emu = subprocess.Popen([sys.executable, "-m", "recorder.cli", "emulate", "--rate", "200", "--link", link,
                                "--motion", "random"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        emu.stdout.readline()
        try:
            wall, frames, side = session(tmp, glove=f"serial:{link}", episodes=max(1, round(seconds / episode_s)),
                                         episode_time_s=episode_s, reset_time_s=0.2, fps=fps, realtime=True,
                                         log=True)
        finally:
            emu.terminate()
            emu.communicate(timeout=10)
    return {"fps": fps, "recorded_s": round(frames / fps, 1), "wall_s": round(wall, 1), "frames": frames,
            "glove_dropped": sum(s["glove_dropped"] for s in side),
            "glove_late": sum(s["glove_late"] for s in side),
            "loop_overruns": sum(s["loop_overruns"] for s in side),
            "jitter_ms_p99_worst_episode": max(s["jitter_ms_p99"] for s in side),
            "jitter_ms_p99_median_episode": statistics.median(s["jitter_ms_p99"] for s in side),
            "latency_ms_p99_worst_episode": max(s["latency_ms_p99"] for s in side),
            "latency_ms_p50_median_episode": statistics.median(s["latency_ms_p50"] for s in side)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--realtime-s", type=float, default=300.0)
    ap.add_argument("--realtime-only", action="store_true", help="keep the fast figures of the last results file")
    args = ap.parse_args()
    if args.realtime_only:
        import json

        from _common import RESULTS
        results = {k: v for k, v in json.loads((RESULTS / "record.json").read_text()).items()
                   if k.startswith("fast_")}
    else:
        results = {"fast_state_only": fast(args.runs, []), "fast_one_camera_128": fast(args.runs, ["front"])}
    print(results)
    results["realtime_100hz"] = realtime(args.realtime_s)
    print(results["realtime_100hz"])
    rt = results["realtime_100hz"]
    results["goals"] = {
        "fast_state_only_ge_1000_fps": results["fast_state_only"]["frames_per_s"]["median"] >= 1000,
        "fast_camera_ge_60_fps": results["fast_one_camera_128"]["frames_per_s"]["median"] >= 60,
        "realtime_zero_dropped": rt["glove_dropped"] == 0,
        "realtime_jitter_p99_le_2ms": rt["jitter_ms_p99_worst_episode"] <= 2.0,
        "realtime_latency_p99_le_10ms": rt["latency_ms_p99_worst_episode"] <= 10.0,
    }
    write_results("record", results)


if __name__ == "__main__":
    main()
