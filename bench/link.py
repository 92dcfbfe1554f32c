"""Glove link benchmark: frame sizes, Python decode rate, and emulator -> pty -> reader loss and latency.

    .venv/bin/python bench/link.py [--duration 60] [--rates 200 1000]

Latency is host receive time minus the emulator's sample time; both are CLOCK_MONOTONIC on this machine,
so it is absolute (reader thread wake-up, pty and decoding included). Goals (issue 2): pose frame
≤ 160 B, decode ≥ 50 000 pose frames/s, 0 frames lost and p99 ≤ 2 ms at 200 Hz and 1 kHz.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import median_rate, write_results  # noqa: E402

from recorder.emulator.glove import SyntheticGlove  # noqa: E402
from recorder.link.serial_source import SerialSource  # noqa: E402
from recorder.monitor import LinkMonitor  # noqa: E402
from recorder.protocol import PoseFrame, RawFrame, StreamDecoder, encode_frame  # noqa: E402
from recorder.protocol.legacy_json import encode_line  # noqa: E402

THESIS_JSON_BYTES = 1200  # measured average of the prototype's payload (thesis §4.3)


def sizes(block) -> dict:
    pose = encode_frame(PoseFrame(1, 1, block.pose[0]))
    raw = encode_frame(RawFrame(1, 1, block.raw[0]))
    legacy = np.mean([len(encode_line(q)) for q in block.pose])
    return {
        "pose_bytes": len(pose),
        "raw_bytes": len(raw),
        "legacy_json_bytes_ours": round(float(legacy)),
        "thesis_json_bytes": THESIS_JSON_BYTES,
        "pose_vs_thesis_json": round(THESIS_JSON_BYTES / len(pose), 2),
    }


def decode_rates(block, n: int = 100_000) -> dict:
    poses = b"".join(encode_frame(PoseFrame(i & 0xFFFF, i, block.pose[i % len(block.t)])) for i in range(n))
    raws = b"".join(encode_frame(RawFrame(i & 0xFFFF, i, block.raw[i % len(block.t)])) for i in range(n // 4))
    lines = b"".join(encode_line(block.pose[i % len(block.t)]) for i in range(n // 10))

    def run(data, protocol, chunk=4096):
        def go():
            dec = StreamDecoder(protocol)
            for i in range(0, len(data), chunk):
                dec.feed(data[i : i + chunk])

        return go

    return {
        "pose_frames_per_s": median_rate(run(poses, "binary"), n),
        "raw_frames_per_s": median_rate(run(raws, "binary"), n // 4),
        "legacy_json_lines_per_s": median_rate(run(lines, "json"), n // 10),
    }


def stream(rate: int, duration: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        link = f"{tmp}/glove"
        emu = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "recorder.cli",
                "emulate",
                "--rate",
                str(rate),
                "--duration",
                str(duration + 3),
                "--link",
                link,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        emu.stdout.readline()
        with SerialSource(link) as src:
            mon = LinkMonitor(src)
            mon.run(duration)
            rep = mon.report()
        emu.terminate()
        emu.communicate(timeout=10)
    lat = np.array(mon.latencies_s) * 1e3
    return {
        "rate_hz": rate,
        "duration_s": duration,
        "frames": rep["samples"],
        "measured_rate_hz": rep["rate_hz"],
        "frames_lost": rep["gaps"] + rep["queue_drops"],
        "errors": rep["errors"],
        "latency_ms_p50": round(float(np.percentile(lat, 50)), 4),
        "latency_ms_p99": round(float(np.percentile(lat, 99)), 4),
        "latency_ms_max": round(float(lat.max()), 4),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--rates", type=int, nargs="+", default=[200, 1000])
    args = ap.parse_args()
    block = SyntheticGlove(rate_hz=200, seed=1).next_block(400)
    results = {"sizes": sizes(block), "decode": decode_rates(block)}
    print(results)
    results["stream"] = []
    for rate in args.rates:
        t = time.monotonic()
        results["stream"].append(stream(rate, args.duration))
        print(results["stream"][-1], f"({time.monotonic() - t:.0f} s)")
    s, d = results["sizes"], results["decode"]
    results["goals"] = {
        "pose_frame_le_160_bytes": s["pose_bytes"] <= 160,
        "decode_ge_50000_pose_per_s": d["pose_frames_per_s"]["median"] >= 50_000,
        "zero_frames_lost": all(r["frames_lost"] == 0 for r in results["stream"]),
        "latency_p99_le_2ms": all(r["latency_ms_p99"] <= 2.0 for r in results["stream"]),
    }
    write_results("link", results)


if __name__ == "__main__":
    main()
