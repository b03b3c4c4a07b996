#!/usr/bin/env bash
# The main job. Until host_sim can replay a bundled trace, the most useful real
# thing: build every firmware image, run the QEMU image, and print image sizes.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
for preset in m4 m0plus qemu; do
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset" >/dev/null
done
echo "== firmware booting under QEMU (mps2-an386, Cortex-M4):"
qemu-system-arm -M mps2-an386 -nographic -monitor none -serial none \
  -semihosting-config enable=on,target=native -kernel build/qemu/boards/mps2/firmware-mps2-an386.elf
for preset in m4 m0plus qemu; do
  echo "== $preset images"
  cmake --build --preset "$preset" --target size | grep -v '^\['
done
