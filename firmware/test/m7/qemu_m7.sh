#!/bin/sh
# Run a Cortex-M7 test program on QEMU's mps2-an500 with newlib semihosting: its output on stdout, its exit
# status as ours, its arguments passed through. ctest uses this as the M7 build's CROSSCOMPILING_EMULATOR.
#   qemu_m7.sh PROGRAM.elf [ARG ...]
# -icount shift=0: one instruction is one nanosecond of the emulated clock, so SysTick (25 MHz) counts
# instructions (one tick per 40), deterministically; glove_core_bench reads it for bench/firmware.py.
set -e
[ $# -ge 1 ] || { echo "usage: qemu_m7.sh PROGRAM.elf [ARG ...]" >&2; exit 2; }
command -v qemu-system-arm >/dev/null || { echo "qemu-system-arm not found: apt-get install qemu-system-arm" >&2; exit 127; }
prog=$1
shift
semi="enable=on,target=native,arg=$(basename "$prog")"
for a in "$@"; do semi="$semi,arg=$a"; done
exec qemu-system-arm -M mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none -icount shift=0 \
  -semihosting-config "$semi" -kernel "$prog"
