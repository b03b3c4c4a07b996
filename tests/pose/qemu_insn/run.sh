#!/usr/bin/env bash
# Instructions per frame of pose/ on Cortex-M4 under QEMU (docs/explanation/pose.md).
# Out of the CMake tree because boards/ belongs to the integrator: this builds a
# bare-metal mps2-an386 program from boards/cortex-m + boards/mps2 sources and the
# pose sources with the m4 preset's flags (-Os, FPv4-SP hard float), with two
# rendered frames in flash, and runs it with -icount shift=7.
#   tests/pose/qemu_insn/run.sh [OUT_DIR]      (default: build/pose-qemu-insn)
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
out="${1:-$root/build/pose-qemu-insn}"
mkdir -p "$out"
here="$root/tests/pose/qemu_insn"
cc -O2 -std=c11 -I"$root/host_sim/camera/include" -I"$root/pose/include" \
  "$here/gen_frames.c" "$root"/host_sim/camera/src/camera_render.c \
  "$root"/host_sim/camera/src/camera_scenario.c "$root"/pose/src/*.c -lm \
  -o "$out/gen_frames"
"$out/gen_frames" > "$out/frames.c"
core=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16)
arm-none-eabi-gcc "${core[@]}" -Os -std=c11 -DBOARD_IRQ_COUNT=32 \
  -I"$root/boards/cortex-m" -I"$root/boards/mps2" -I"$root/pose/include" \
  -ffunction-sections -fdata-sections \
  "$here/pose_insn_main.c" "$out/frames.c" "$root/boards/cortex-m/startup.c" \
  "$root/boards/mps2/semihost.c" "$root/boards/mps2/insn_counter.c" \
  "$root"/pose/src/*.c -lm \
  -T"$root/boards/mps2/mps2.ld" -L"$root/boards/cortex-m" -nostartfiles --specs=nano.specs \
  -Wl,--gc-sections -Wl,--no-warn-rwx-segments -o "$out/pose_insn.elf"
qemu-system-arm -M mps2-an386 -nographic -monitor none -serial none \
  -semihosting-config enable=on,target=native -icount shift=7 -kernel "$out/pose_insn.elf"
