#!/usr/bin/env bash
# Regenerate the golden estimate files (the bundled demo trace's, the long-range target
# test's) after a deliberate change
# to the estimators or the firmware pipeline. The host integration test checks host_sim
# against it and the QEMU target test checks the on-target replay against it, so the two
# stay byte-identical to each other. Review the diff before committing it.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset host-release >/dev/null
cmake --build --preset host-release --target host_sim >/dev/null
build/host-release/host_sim/app/host_sim replay traces/demo/realnoise_demo.csv --quiet \
  --out traces/demo/realnoise_demo.est.csv
# the long-range target test's (a VL53L1X in long mode at 2 m: tests/boards/data)
build/host-release/host_sim/app/host_sim replay tests/boards/data/long_range.csv --quiet \
  --out tests/boards/data/long_range.est.csv
git --no-pager diff --stat -- traces/demo/realnoise_demo.est.csv tests/boards/data/long_range.est.csv
