"""Firmware budget: instructions per 12-IMU cycle of the glove core, the I2C bus time of a sensing cycle, and
bytes/s per output rate and mode.

Instructions on the Cortex-M7 itself: the M7 build (firmware/build/m7, `make firmware` makes it) runs
tools/glove_core_bench.cpp on QEMU's mps2-an500 with -icount shift=0, SysTick counting instructions
(firmware/tools/m7_counts.py; its regression baseline is firmware/m7_counts.json). Next to them, the x86-64
proxy: the host build (cmake + g++, Release) under valgrind --tool=callgrind, repeatable to the instruction:
each workload runs for N cycles and for 0 cycles (start-up only), and (Ir(N) - Ir(0)) / N is one cycle.
The bus: gc::ImuBus::cycle_us for the driver's own transactions (glove_core_bench bus). Then the link budget:
frame sizes (pose, pose_compact and raw fixed, legacy JSON measured on synthetic motion) against a
115200-baud UART and USB full speed, with the status frame the glove adds once a second.

Writes bench/results/firmware.json. Run: .venv/bin/python bench/firmware.py
"""

from __future__ import annotations

import json
import platform
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
BUILD = REPO / "build" / "firmware"
M7_BUILD = REPO / "firmware" / "build" / "m7"
OUT = REPO / "bench" / "results" / "firmware.json"
CYCLES = 2000

M7_HZ = 600e6  # Teensy 4.0, i.MX RT1062 Cortex-M7
UART_BYTES_PER_S = 115200 / 10  # 8N1: 10 bits per byte
USB_FS_BYTES_PER_S = 1.0e6  # USB full speed, 12 Mbit/s: ~1 MB/s of bulk payload in practice
POSE_WIRE, COMPACT_WIRE, RAW_WIRE_12, RAW_WIRE_16 = 144, 52, 188, 244
STATUS_WIRE_12 = 56  # one status frame a second (12 IMUs)
RATES_HZ = [10, 30, 50, 80, 100, 200, 500, 1000]
WORKLOADS = {
    "filter": "12 filter updates, the default filter (FilterMode::Inertial: low-pass in an almost-inertial frame)",
    "filter_thesis": "12 updates of the thesis' filter (median buffer 12, eq. 3.4-3.19), the glove's until issue 13",
    "pose": "parent-relative pose (eq. 3.21, 3.3) + one 144-byte pose frame (CRC-32, COBS)",
    "cycle": "filter + pose: a 12-IMU cycle that also sends a pose frame",
    "glove": "gc::Glove::sense on register counts + pose frame: all the loop does but I2C and serial I/O",
    "json": "parent-relative pose + one legacy JSON line",
    "compact": "parent-relative pose + 20 joint angles + one 52-byte pose_compact frame",
    "glove_raw": "gc::Glove::sense + a raw frame (raw mode)",
    "glove_json": "gc::Glove::sense + a legacy JSON line (json mode)",
    "glove_compact": "gc::Glove::sense + a pose_compact frame (compact mode)",
}


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if done.returncode:
        sys.exit(f"{' '.join(cmd)} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return done


def build() -> None:
    for tool in ("cmake", "g++", "valgrind"):
        if shutil.which(tool) is None:
            sys.exit(f"bench/firmware.py needs {tool} on PATH")
    run(["cmake", "-S", str(REPO / "firmware"), "-B", str(BUILD), "-DCMAKE_BUILD_TYPE=Release"])
    run(["cmake", "--build", str(BUILD), "-j", "4"])


def instructions(exe: str, what: str, cycles: int) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", str(BUILD / exe), what, str(cycles)])
        text = out.read_text()
    m = re.search(r"^(?:summary|totals):\s+(\d+)", text, re.M)
    return int(m.group(1))


def per_cycle(exe: str, what: str) -> float:
    return (instructions(exe, what, CYCLES) - instructions(exe, what, 0)) / CYCLES


def json_line_bytes() -> dict:
    """Mean and max legacy JSON line on 2 s of synthetic hand motion (varied quaternions, 6 decimals)."""
    rng = np.random.default_rng(0)
    t = np.arange(2000) / 1000
    gyro = 2.0 * np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (12, 3)) * t[:, None, None] + rng.uniform(0, 6, (12, 3)))
    accel = np.tile([0.0, 0.0, 1.0], (len(t), 12, 1)) + rng.normal(0, 0.01, (len(t), 12, 3))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "samples.bin"
        np.concatenate([gyro, accel], -1).astype("<f4").tofile(path)
        out = subprocess.run(
            [
                str(BUILD / "glove_core_cli"),
                "run",
                "--mode",
                "json",
                "--calib-samples",
                "0",
                "--output-rate",
                "100",
                str(path),
            ],
            capture_output=True,
            check=True,
        ).stdout
    sizes = [len(line) + 1 for line in out.split(b"\n")[:-1]]
    return {"mean": round(float(np.mean(sizes)), 1), "max": int(max(sizes)), "lines": len(sizes)}


def max_rate(link_bytes_per_s: float, size: float) -> float:
    """Frames a second that fit beside the once-a-second status frame."""
    return (link_bytes_per_s - STATUS_WIRE_12) / size


def link_budget(frame_bytes: dict[str, float]) -> dict:
    table = {}
    for mode, size in frame_bytes.items():
        table[mode] = {
            "bytes_per_frame": size,
            "max_rate_hz_uart_115200": round(max_rate(UART_BYTES_PER_S, size), 1),
            "max_rate_hz_usb_full_speed": round(max_rate(USB_FS_BYTES_PER_S, size)),
            "bytes_per_s": {str(r): round(r * size + STATUS_WIRE_12) for r in RATES_HZ},
            "fits_uart_115200": {str(r): r * size + STATUS_WIRE_12 <= UART_BYTES_PER_S for r in RATES_HZ},
            "fits_usb_full_speed": {str(r): r * size + STATUS_WIRE_12 <= USB_FS_BYTES_PER_S for r in RATES_HZ},
        }
    return table


def i2c_budget() -> dict:
    """What the bus allows the IMU driver (firmware/lib/glove_core/imu_bus.h): per cycle one 14-byte burst read per
    IMU and one TCA9548A switch per channel, at the I2C specification's minimum START/STOP times."""
    bus = {}
    for line in run([str(BUILD / "glove_core_bench"), "bus", "0"]).stdout.splitlines():
        _, n, hz, us = line.split()
        bus.setdefault(f"{n}_imu", {})[f"{int(hz) // 1000}_khz"] = {
            "cycle_us": float(us),
            "max_sense_rate_hz": round(1e6 / float(us), 1),
        }
    return {
        "transactions": "per cycle: a 14-byte register read per IMU (ACCEL_XOUT_H..GYRO_ZOUT_L) and a mux write per "
        "channel; bits at the clock (9 per byte) plus START, repeated START, STOP and bus-free times (UM10204)",
        "previous_driver": "bolderflight Read(): 23 bytes per IMU, at most ~135 12-IMU cycles a second at 400 kHz",
        "thesis": "30 frames a second (thesis §4.3, JSON over serial)",
        **bus,
    }


def m7_counts() -> dict:
    """Instructions per cycle on the emulated Cortex-M7 (firmware/tools/m7_counts.py), built here if needed."""
    missing = [t for t in ("arm-none-eabi-g++", "qemu-system-arm") if shutil.which(t) is None]
    if missing:
        sys.exit(f"bench/firmware.py needs {' and '.join(missing)}: run make firmware (it installs them)")
    toolchain = REPO / "firmware" / "cmake" / "arm-none-eabi.cmake"
    run(["cmake", "-S", str(REPO / "firmware"), "-B", str(M7_BUILD), "--toolchain", str(toolchain),
         "-DGLOVE_TARGET=m7", f"-DGLOVE_HOST_BUILD={BUILD}"])  # fmt: skip
    run(["cmake", "--build", str(M7_BUILD), "-j", "2"])
    out = json.loads(run([sys.executable, str(REPO / "firmware" / "tools" / "m7_counts.py"), "--build", str(M7_BUILD),
                          "--json"]).stdout.splitlines()[0])  # fmt: skip
    base = json.loads((REPO / "firmware" / "m7_counts.json").read_text())["instructions_per_cycle"]
    out["baseline"] = base
    return out


def main() -> None:
    build()
    cpu = {}
    for variant, exe in (("double", "glove_core_bench"), ("float", "glove_core_bench_f32")):
        cpu[variant] = {}
        for what in WORKLOADS:
            ir = per_cycle(exe, what)
            cpu[variant][what] = {
                "instructions_per_cycle": round(ir),
                "m7_rate_hz_at_1_ipc": round(M7_HZ / ir),
                "m7_rate_hz_at_0_5_ipc": round(M7_HZ / 2 / ir),
                "m7_cpu_share_at_1khz_1_ipc": round(ir * 1000 / M7_HZ, 4),
            }
            print(f"x86 {variant:6s} {what:13s} {ir:10.0f} instr/cycle  -> {M7_HZ / ir:8.0f} Hz at 1 IPC")
    m7 = m7_counts()
    for variant, table in m7["instructions_per_cycle"].items():
        for what, n in table.items():
            x86 = cpu[variant][what]["instructions_per_cycle"]
            m7.setdefault("m7_over_x86", {}).setdefault(variant, {})[what] = round(n / x86, 2)
            print(f"M7  {variant:6s} {what:13s} {n:10d} instr/cycle  ({n / x86:.2f}x the x86 count)")

    json_bytes = json_line_bytes()
    links = link_budget(
        {
            "pose": POSE_WIRE,
            "pose_compact": COMPACT_WIRE,
            "raw_12_imu": RAW_WIRE_12,
            "raw_16_imu": RAW_WIRE_16,
            "json": json_bytes["mean"],
        }
    )
    glove = cpu["double"]["glove"]
    m7_glove = m7["instructions_per_cycle"]["double"]["glove"]
    bus = i2c_budget()
    bound = bus["12_imu"]["400_khz"]["max_sense_rate_hz"]
    result = {
        "benchmark": "firmware",
        "host": {
            "machine": platform.machine(),
            "compiler": run(["g++", "--version"]).stdout.splitlines()[0],
            "flags": "-O2 (CMake Release) -ffp-contract=off",
            "valgrind": run(["valgrind", "--version"]).stdout.strip(),
        },
        "method": f"valgrind --tool=callgrind instruction counts (Ir) of firmware/tools/glove_core_bench.cpp; "
        f"per cycle = (Ir({CYCLES} cycles) - Ir(0 cycles)) / {CYCLES}; inputs precomputed at start-up",
        "m7_assumption": "Cortex-M7 at 600 MHz; x86-64 instruction count taken as a proxy for the Thumb-2 count, "
        "~1 instruction per clock on the dual-issue M7 with its FPU (0.5 IPC as a pessimistic "
        "bound: flash wait states, 14-cycle float and ~30-cycle double divide/sqrt). The double "
        "build (default, as the thesis' Eigen Vector3d) costs more cycles per instruction on "
        "the M7 than the float build: use the float figures as its lower bound.",
        "workloads": WORKLOADS,
        "instructions": cpu,
        "m7": m7,
        "i2c": bus,
        "json_line_bytes": json_bytes,
        "links": {
            "uart_115200_bytes_per_s": UART_BYTES_PER_S,
            "usb_full_speed_bytes_per_s": USB_FS_BYTES_PER_S,
            "modes": links,
        },
        "goals": {
            "sense_1khz_12_imu_cpu": {
                "met": M7_HZ / 2 / m7_glove >= 1000,
                "detail": f"{m7_glove} M7 instructions per 12-IMU cycle with a pose frame (QEMU count; x86 proxy "
                f"{glove['instructions_per_cycle']}): {m7_glove * 1000 / M7_HZ:.1%} of the M7 at 1 kHz (1 IPC); "
                f"the I2C bus, not the CPU, limits sensing (see i2c)",
            },
            "sense_at_the_i2c_bound": {
                "met": 190 >= 0.9 * bound,
                "detail": f"the driver's transactions allow {bound} 12-IMU cycles a second on one 400 kHz bus; "
                f"firmware/src/glove_config.h senses at 190 Hz ({190 / bound:.0%} of it, the rest of each period "
                f"for the core and Wire); 1 kHz needs SPI or several buses read at once (the Teensy 4.0 has "
                f"three, but Teensyduino's Wire blocks: see firmware/README.md)",
            },
            "pose_200hz_uart_115200": {
                "met": links["pose_compact"]["fits_uart_115200"]["200"],
                "detail": f"pose_compact frames (kind 0x05, mode 3: palm quaternion + 20 joint angles of 0.1 deg) "
                f"are {COMPACT_WIRE} bytes: {int(max_rate(UART_BYTES_PER_S, COMPACT_WIRE))} Hz into "
                f"11 520 B/s beside the status frame; the {POSE_WIRE}-byte quaternion pose frame "
                f"fits {int(max_rate(UART_BYTES_PER_S, POSE_WIRE))} Hz (the format for USB). The link "
                f"is met; 200 Hz output also needs >= 200 Hz sensing: the driver senses at 190 Hz on one "
                f"400 kHz bus (see i2c)",
            },
        },
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(result, indent=2) + "\n")
    met = "met" if result["goals"]["pose_200hz_uart_115200"]["met"] else "not met"
    print(
        f"over 115200 baud: pose_compact {int(max_rate(UART_BYTES_PER_S, COMPACT_WIRE))} Hz, pose "
        f"{int(max_rate(UART_BYTES_PER_S, POSE_WIRE))} Hz max (goal 200 Hz: {met}); "
        f"JSON line {json_bytes['mean']} B; "
        f"wrote {OUT.relative_to(REPO)}"
    )


if __name__ == "__main__":
    main()
