#!/usr/bin/env bash
# Run every test: install what is missing, configure and build all six
# presets (m4-i2c100: the flight image for a 100 kHz bus, which the twin also runs) (the image checks run at link time), run the host tests (ASan+UBSan),
# the release-build tests, the on-target QEMU tests, the twin tests (the m4 ELF on the
# emulated STM32L476), static analysis, and the
# on-target benchmark (which must run and write build/qemu/bench.json).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh

for preset in host host-release m4 m4-i2c100 m0plus qemu; do
  echo "== configure + build: $preset"
  cmake --preset "$preset" >/dev/null
  cmake --build --preset "$preset"
done

echo "== image sizes"
for preset in m4 m4-i2c100 m0plus qemu; do
  cmake --build --preset "$preset" --target size
done

echo "== tests: host (sanitizers on)"
ctest --preset host -j "$(nproc)"
echo "== tests: host-release"
ctest --preset host-release -j "$(nproc)"
echo "== tests: on target (QEMU)"
ctest --preset qemu -j "$(nproc)"
echo "== tests: the flight ELF (m4 preset) in the twin (build/twin)"
cmake --preset twin >/dev/null
cmake --build --preset twin
ctest --preset twin
echo "== static analysis"
cmake --build --preset host --target analyze
echo "== benchmark: exact instruction counts under QEMU -> build/qemu/bench.json"
cmake --build --preset qemu --target bench
echo "== docs: the instruction counts and image sizes they quote equal the bench's"
python3 tools/docs_figures.py --check --only bench,images
echo "== all tests passed"
