"""`make demo`: the main job end to end with the built-in glove emulator, no hardware.

1. the glove link: emulate a glove on a pseudo-terminal, log it to MCAP over pyserial, print the statistics;
2. record demonstrations of the HandPose task: the scripted demonstrator drives the emulated glove;
3. push the dataset to the local hub (datasets/hub);
4. train the behaviour-cloning policy from the hub;
5. evaluate it in the simulator and print the success rate and where everything is.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

OUT = Path("datasets/recordings/demo")
HUB = Path("datasets/hub")
POLICY = Path("datasets/policies/demo_bc")
REPO = "demo/pose"
EPISODES, STEPS, EVAL = 30, 2000, 20


def gloverec(*args: str) -> dict | None:
    print(f"  $ gloverec {' '.join(args)}", flush=True)
    r = subprocess.run([sys.executable, "-m", "recorder.cli", *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"demo: step failed: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}")
    last = r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""
    return json.loads(last) if last.startswith("{") else None


def link_check() -> Path:
    log = OUT / "link.mcap"
    print("[1/5] The glove link: 12 synthetic MPU9250s behind a pseudo-terminal, 200 Hz raw frames, logged 5 s")
    emu = subprocess.Popen(
        [sys.executable, "-m", "recorder.cli", "emulate", "--output", "raw", "--rate", "200", "--duration", "30"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    port = emu.stdout.readline().split(": ", 1)[-1].strip()
    try:
        rep = gloverec("log", "--glove", port, "--out", str(log), "--duration", "5", "--json")
    finally:
        emu.terminate()
        emu.communicate(timeout=10)
    print(
        f"      {rep['samples']} frames at {rep['rate_hz']:.1f} Hz, {rep['errors']} errors, {rep['gaps']} gaps, "
        f"latency p50 {rep['latency_ms_p50']:.2f} ms / p99 {rep['latency_ms_p99']:.2f} ms -> {log}"
    )
    return log


def main() -> int:
    t0 = time.monotonic()
    shutil.rmtree(OUT, ignore_errors=True)
    shutil.rmtree(POLICY, ignore_errors=True)
    OUT.mkdir(parents=True)
    link_check()
    root = OUT / "pose"
    print(
        f"[2/5] Recording {EPISODES} demonstrations of HandPose on the glovehand robot: the scripted demonstrator "
        "drives the emulated glove through the serial path, faster than real time"
    )
    rec = gloverec(
        "record",
        "--view",
        "none",
        "--task",
        "pose",
        "--robot",
        "glovehand",
        "--episodes",
        str(EPISODES),
        "--repo-id",
        REPO,
        "--root",
        str(root),
        "--json",
    )
    print(
        f"      {rec['total_episodes']} episodes, {rec['total_frames']} frames, demonstrator success "
        f"{rec['success_rate']:.0%} -> {root} (session log {root / rec['log']})"
    )
    print("[3/5] Publishing it to the local hub")
    gloverec("push", "--repo-id", REPO, "--root", str(root), "--hub", str(HUB), "--json")
    print(f"      {HUB / REPO} (LeRobotDataset({REPO!r}, root={str(HUB / REPO)!r}))")
    print(f"[4/5] Training the behaviour-cloning policy from the hub ({STEPS} steps on the CPU)")
    train = gloverec(
        "train",
        "--repo-id",
        REPO,
        "--hub",
        str(HUB),
        "--policy",
        "bc",
        "--steps",
        str(STEPS),
        "--out",
        str(POLICY),
        "--json",
    )
    print(f"      {json.dumps({k: v for k, v in (train or {}).items() if not isinstance(v, (dict, list))})}")
    print(f"[5/5] Evaluating it on {EVAL} new HandPose episodes (seeds the recording never used)")
    ev = gloverec(
        "eval",
        "--policy",
        str(POLICY),
        "--task",
        "pose",
        "--robot",
        "glovehand",
        "--episodes",
        str(EVAL),
        "--video",
        str(POLICY / "videos"),
        "--json",
    )
    print(
        f"\nSuccess rate {ev['success_rate']:.0%} over {ev['episodes']} episodes (mean return "
        f"{ev['mean_return']:.2f}), in {time.monotonic() - t0:.0f} s."
    )
    print(f"  dataset   {root}  (hub: {HUB / REPO})")
    print(f"  policy    {POLICY}  (loss curve and checkpoints inside)")
    print(f"  videos    {POLICY / 'videos'}")
    print(f"  inspect   gloverec inspect --repo-id {REPO} --hub {HUB} --plot {OUT / 'episode0.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
