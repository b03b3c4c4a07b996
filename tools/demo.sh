#!/usr/bin/env bash
# The main job: replay the bundled recorded trace (real VL53L0X noise on a known
# attitude schedule, traces/demo/README.md) through host_sim — simulated I²C bus,
# VL53 device models, the drivers, the fault manager and all four estimators —
# print the summary table and write the estimates, a JSON report and a plot to out/.
# Extra arguments go to `host_sim replay` (e.g. --faults nack=0.01 --seed 3).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
cmake --preset host-release >/dev/null
cmake --build --preset host-release --target host_sim >/dev/null
mkdir -p out
build/host-release/host_sim/app/host_sim replay traces/demo/realnoise_demo.csv \
  --estimator consensus --out out/demo.est.csv --report out/demo.report.json \
  --plot out/demo.png "$@"
echo "estimates: out/demo.est.csv  report: out/demo.report.json  plot: out/demo.png"
