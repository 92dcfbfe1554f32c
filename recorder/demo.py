"""`make demo`: the main job end to end with the built-in glove emulator, no hardware.

Today: emulate a glove on a pseudo-terminal -> log 10 s to MCAP over the real serial path -> print the link
statistics -> play the log back. Later issues grow it into record -> push -> train -> eval.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

OUT = Path("datasets/recordings/demo")


def gloverec(*args: str, capture: bool = True) -> subprocess.CompletedProcess:
    print(f"  $ gloverec {' '.join(args)}", flush=True)
    r = subprocess.run([sys.executable, "-m", "recorder.cli", *args], capture_output=capture, text=True)
    if r.returncode != 0:
        sys.exit(f"demo: step failed: {r.stderr.strip()}")
    return r


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    log = OUT / "session.mcap"
    print("[1/3] Starting the glove emulator: 12 synthetic MPU9250s behind a pseudo-terminal (raw mode, 200 Hz)")
    emu = subprocess.Popen([sys.executable, "-m", "recorder.cli", "emulate", "--mode", "raw", "--rate", "200",
                            "--duration", "30"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    port = emu.stdout.readline().split(": ", 1)[-1].strip()
    print(f"      glove on {port}")
    try:
        print("[2/3] Logging 10 s of the glove to MCAP through pyserial")
        t = time.monotonic()
        report = json.loads(gloverec("log", "--port", port, "--out", str(log), "--duration", "10",
                                     "--json").stdout)
        print(f"      {log} ({log.stat().st_size / 1e6:.2f} MB) in {time.monotonic() - t:.1f} s")
    finally:
        emu.terminate()
        emu.communicate(timeout=10)
    print("      link statistics:")
    for key in ("protocol", "frames", "rate_hz", "errors", "gaps", "queue_drops", "latency_ms_p50",
                "latency_ms_p99", "clock"):
        print(f"        {key:16} {report[key]}")
    print("[3/3] Playing the log back as a glove source, as fast as it decodes")
    replay = json.loads(gloverec("monitor", "--port", f"mcap:{log}", "--fast", "--json").stdout)
    print(f"      {replay['frames']} frames, {replay['errors']} errors, {replay['gaps']} gaps from the log")
    print(f"\nDone. Open {log} in Foxglove, or replay it: gloverec monitor --port mcap:{log}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
