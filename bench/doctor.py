"""`gloverec doctor` on emulated gloves (docs/recording.md, "Bringing up a new glove"): each kind of build error
the emulator injects (--fault) on N seeds, each seed a different glove (its IMUs' own errors), wearer (how deep
each finger curls and how much its neighbours follow), hand size (0.8-1.2 of the 190 mm hand), IMUs glued up to
4 degrees off (RMS) and, per seed, another IMU or pair for the fault; and N healthy gloves drawn the same way. A
fault counts as found when the doctor names exactly it (its kind and IMUs) and nothing else; a healthy glove passes
when the doctor names nothing. The analysis runs on the bytes the emulator's encoder sends (decoded as the host
decodes them); one end-to-end run (`gloverec emulate --motion doctor --fault ...` on a pty, `gloverec doctor`)
measures the wearer's time. Writes bench/results/doctor.json.

    .venv/bin/python bench/doctor.py [--seeds 20]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, write_results  # noqa: E402

from recorder.emulator.checkup import checkup_emulator  # noqa: E402
from recorder.glove.checks import examine  # noqa: E402
from recorder.hand import checkup  # noqa: E402
from recorder.hand.kinematics import HandSize  # noqa: E402
from recorder.protocol import StreamDecoder  # noqa: E402

KINDS = {"swap": "swapped", "rotate": "rotated", "dead": "dead", "stuck": "stuck", "flaky": "intermittent",
         "rate": "slow_rate"}  # fmt: skip


def fault_for(kind: str, rng) -> tuple[str, tuple]:
    if kind == "swap":
        a, b = sorted(rng.choice(12, 2, replace=False).tolist())
        return f"swap:{a},{b}", (a, b)
    if kind == "rotate":
        i = int(rng.integers(1, 12))  # the palm's turn is not checked (no move shows it)
        return f"rotate:{i}:{int(rng.choice([90, 180, 270]))}", (i,)
    if kind == "rate":
        return f"rate:{int(rng.choice([50, 60, 100, 150]))}", ()
    i = int(rng.integers(0, 12))
    return f"{kind}:{i}", (i,)


def checkup_of(faults, seed: int):
    rng = np.random.default_rng([seed, 7])
    emu = checkup_emulator(faults, seed=seed, misalign_deg=4.0, size=HandSize(scale=float(rng.uniform(0.8, 1.2))),
                           glove_id=0xE0E00000 + seed)  # fmt: skip
    dec, frames = StreamDecoder("binary"), []
    for chunk in emu.stream(checkup.TOTAL_S + 0.2):
        frames += dec.feed(chunk)
    return examine(frames)


def end_to_end() -> dict:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    with tempfile.TemporaryDirectory() as tmp:
        link = f"{tmp}/glove"
        emu = subprocess.Popen([sys.executable, "-m", "recorder.cli", "emulate", "--link", link, "--motion", "doctor",
                                "--fault", "swap:3,4"], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)  # fmt: skip
        try:
            while not os.path.exists(link):
                time.sleep(0.05)
            start = time.monotonic()
            r = subprocess.run([sys.executable, "-m", "recorder.cli", "doctor", "--glove", link, "--yes", "--json",
                                "--dir", tmp], env=env, capture_output=True, text=True, timeout=120)  # fmt: skip
            wall = time.monotonic() - start
        finally:
            emu.terminate()
            emu.wait()
    out = json.loads(r.stdout)
    return {"command_s": round(wall, 2), "wearer_s": out["wearer_s"], "moves_s": out["moves_s"],
            "found": [p["found"] for p in out["problems"]]}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    args = ap.parse_args()
    results, start = {"seeds": args.seeds, "faults": {}}, time.monotonic()
    for kind, name in KINDS.items():
        found, misses = 0, []
        for seed in range(args.seeds):
            fault, imus = fault_for(kind, np.random.default_rng([seed, list(KINDS).index(kind)]))
            c = checkup_of([fault], seed)
            got = [(p.kind, tuple(sorted(p.imus))) for p in c.problems]
            if got == [(name, imus)]:
                found += 1
            else:
                misses.append({"seed": seed, "fault": fault, "named": [p.found for p in c.problems]})
        results["faults"][kind] = {"found": found, "of": args.seeds, "misses": misses}
        print(f"{kind}: {found}/{args.seeds}", flush=True)
    false = [{"seed": s, "named": [p.found for p in c.problems]} for s in range(100, 100 + args.seeds)
             if not (c := checkup_of([], s)).ok]  # fmt: skip
    results["healthy"] = {"passed": args.seeds - len(false), "of": args.seeds, "false_alarms": false}
    print(f"healthy: {args.seeds - len(false)}/{args.seeds}", flush=True)
    results["analysis_s"] = round(time.monotonic() - start, 1)
    results["end_to_end"] = end_to_end()
    results["glove"] = ("emulated: noise, turn-on biases, accelerometer offsets, IMUs 4 deg RMS off, hand 0.8-1.2 of "
                        "190 mm, each curl 0.7-1.2 of 60 deg (thumb 0.6 of that), neighbours following up to "
                        "35 %")  # fmt: skip
    print(json.dumps(results["end_to_end"]))
    write_results("doctor", results)


if __name__ == "__main__":
    main()
