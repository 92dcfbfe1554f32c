#!/usr/bin/env python3
"""Instructions the glove core executes per cycle on the Cortex-M7, counted on QEMU (mps2-an500, -icount
shift=0, SysTick as the counter: tools/glove_core_bench.cpp), against the committed baseline m7_counts.json.

    m7_counts.py --build firmware/build/m7 [--check] [--update] [--json]

--check fails (exit 1) when a count grew by more than 10 % over the baseline; a deliberate algorithm change
updates the baseline in the same commit (--update) and says why in the commit message. QEMU counts instructions,
not clock cycles: a 14-cycle divide counts as one. Standard library only: ctest runs it with any python3.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
BASELINE = HERE.parent / "m7_counts.json"
QEMU = HERE.parent / "test" / "m7" / "qemu_m7.sh"
CYCLES = 200
GROWTH = 1.10
WORKLOADS = {
    "filter": "12 filter updates (one per IMU), the default filter (FilterMode::Inertial)",
    "filter_thesis": "12 updates of the thesis' filter (FilterMode::Thesis, the glove's filter until issue 13)",
    "glove": "a full 12-IMU cycle in pose mode (gc::Glove::sense, a pose frame every cycle)",
    "glove_raw": "a full cycle in raw mode (a raw frame every cycle)",
    "glove_json": "a full cycle in legacy JSON mode (a JSON line every cycle)",
    "glove_compact": "a full cycle in compact mode (a pose_compact frame every cycle)",
}
VARIANTS = {"double": "glove_core_bench.elf", "float": "glove_core_bench_f32.elf"}


def measure(build: Path) -> dict:
    out: dict = {}
    for variant, elf in VARIANTS.items():
        out[variant] = {}
        for what in WORKLOADS:
            done = subprocess.run([str(QEMU), str(build / elf), what, str(CYCLES)], capture_output=True, text=True,
                                  timeout=300)  # fmt: skip
            found = re.search(r"m7_instructions_per_cycle ([0-9.]+)", done.stdout)
            if done.returncode or not found:
                tail = (done.stdout + done.stderr)[-800:]
                sys.exit(f"m7_counts: {elf} {what} failed (exit {done.returncode}): {tail}")
            out[variant][what] = round(float(found.group(1)))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path, required=True, help="the M7 build directory (GLOVE_TARGET=m7)")
    ap.add_argument("--check", action="store_true", help="fail when a count grew over 10 %% of the baseline")
    ap.add_argument("--update", action="store_true", help="write the counts as the new baseline")
    ap.add_argument("--json", action="store_true", help="print the counts as JSON")
    args = ap.parse_args()
    counts = measure(args.build)
    if args.json:
        print(json.dumps({"cycles": CYCLES, "workloads": WORKLOADS, "instructions_per_cycle": counts}))
    base = json.loads(BASELINE.read_text())["instructions_per_cycle"] if BASELINE.exists() else None
    grew = []
    for variant, table in counts.items():
        for what, n in table.items():
            was = (base or {}).get(variant, {}).get(what)
            ratio = f"{n / was:6.3f}x" if was else "   new"
            if was and n > GROWTH * was:
                grew.append(f"{variant} {what}: {n} > {GROWTH:.2f} x {was}")
            if not args.json:
                print(f"M7 {variant:6s} {what:14s} {n:8d} instructions/cycle  baseline {was or '-':>8}  {ratio}")
    if args.update:
        method = __doc__.split("\n\n")[0].replace("\n", " ")
        table = {"method": method, "cycles": CYCLES, "workloads": WORKLOADS, "instructions_per_cycle": counts}
        BASELINE.write_text(json.dumps(table, indent=2) + "\n")
        print(f"wrote {BASELINE}")
        return 0
    if args.check and base is None:
        print(f"m7_counts: no baseline at {BASELINE} (run with --update)", file=sys.stderr)
        return 1
    if args.check and grew:
        print("m7_counts: instruction counts grew over 10 % of the baseline (update it with --update if meant):\n  "
              + "\n  ".join(grew), file=sys.stderr)  # fmt: skip
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
