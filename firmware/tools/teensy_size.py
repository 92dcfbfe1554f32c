#!/usr/bin/env python3
"""The memory a Teensy 4.0 image uses, by region, as Teensyduino's teensy_size reports it after a build.

    teensy_size.py IMAGE.elf [--json FILE]

FLASH (2 MB, 1984 KB for the image): headers, code (copied to ITCM at start-up) and initialised data. RAM1
(512 KB of FlexRAM, tightly coupled) is split in 32 KB banks between ITCM (code: the banks it needs, the rest
of the last one padding) and DTCM (variables, then the stack). RAM2 (512 KB OCRAM): DMA buffers, then the heap.
Reads the section table with arm-none-eabi-objdump; standard library only.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys

KB = 1024
FLASH, RAM1, RAM2, BANK = 1984 * KB, 512 * KB, 512 * KB, 32 * KB


def sections(elf: str) -> dict[str, int]:
    out = subprocess.run(["arm-none-eabi-objdump", "-h", elf], capture_output=True, text=True, check=True).stdout
    found = {}
    for line in out.splitlines():
        m = re.match(r"\s*\d+\s+(\S+)\s+([0-9a-f]+)\s", line)
        if m:
            found[m.group(1)] = int(m.group(2), 16)
    return found


def regions(sec: dict[str, int]) -> dict:
    s = lambda name: sec.get(name, 0)  # noqa: E731
    itcm = s(".text.itcm") + s(".ARM.exidx")
    banks = -(-itcm // BANK)
    flash = {
        "headers": s(".text.headers") + s(".text.csf"),
        "code": s(".text.code") + s(".text.progmem") + itcm,
        "data": s(".data"),
    }
    flash["used"] = sum(flash.values())
    flash["free"] = FLASH - flash["used"]
    ram1 = {
        "itcm_code": itcm,
        "itcm_padding": banks * BANK - itcm,
        "dtcm_variables": s(".data") + s(".bss"),
    }
    ram1["free_for_stack"] = RAM1 - banks * BANK - ram1["dtcm_variables"]
    ram2 = {"variables": s(".bss.dma"), "free_for_heap": RAM2 - s(".bss.dma")}
    return {"flash": flash, "ram1": ram1, "ram2": ram2}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf")
    ap.add_argument("--json", help="also write the figures (bytes) to this file")
    args = ap.parse_args()
    try:
        r = regions(sections(args.elf))
    except (OSError, subprocess.CalledProcessError) as exc:
        print(f"teensy_size: cannot read {args.elf}: {exc}", file=sys.stderr)
        return 1
    f, m1, m2 = r["flash"], r["ram1"], r["ram2"]
    print(f"{args.elf}:")
    print(f"  FLASH: code {f['code']:,}, data {f['data']:,}, headers {f['headers']:,}   free {f['free']:,}")
    print(f"  RAM1:  ITCM code {m1['itcm_code']:,} (+{m1['itcm_padding']:,} padding), DTCM variables "
          f"{m1['dtcm_variables']:,}   free for the stack {m1['free_for_stack']:,}")  # fmt: skip
    print(f"  RAM2:  OCRAM variables {m2['variables']:,}   free for the heap {m2['free_for_heap']:,}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(r, fh, indent=2)
    return 0 if f["free"] >= 0 and m1["free_for_stack"] > 0 else 1


if __name__ == "__main__":
    sys.exit(main())
