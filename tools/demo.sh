#!/usr/bin/env bash
# The main job: replay the bundled recorded trace (real VL53L0X noise on a known
# attitude schedule, traces/demo/README.md) through host_sim — simulated I²C bus,
# VL53 device models, the drivers, the fault manager and all four estimators —
# print the summary table and write the estimates, a JSON report and a plot to out/.
# Extra arguments go to `host_sim replay` (e.g. --faults nack=0.01 --seed 3).
# Then a head as built (docs/how-to/calibrate-a-head.md): a simulated head whose parts have
# offsets and gains is calibrated in a simulated fixture (`host_sim calibrate`), and the same
# recording seen through that head is replayed before and after: the table says what the
# calibration buys and what an uncalibrated head honestly says.
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

H=build/host-release/host_sim/app/host_sim
echo
echo "== a head as built: fixture, host_sim calibrate, the recording before and after"
$H scenario fixture --seed 7 --trace-out out/fixture.csv
$H calibrate out/fixture.csv --out out/head.cal --report out/head.cal.json 2>out/head.cal.log
tools/head_trace.py out/fixture.csv traces/demo/realnoise_demo.csv out/head_demo.csv --seed 7
$H replay out/head_demo.csv --estimator consensus --quiet --out out/head_before.est.csv \
  --report out/head_before.report.json
$H replay out/head_demo.csv --estimator consensus --quiet --calibration out/head.cal \
  --out out/head_after.est.csv --report out/head_after.report.json --plot out/head_after.png
tools/head_table.py out/fixture.csv out/head.cal out/head_before.report.json \
  out/head_after.report.json
echo "fixture: out/fixture.csv  calibration: out/head.cal (+ .json, .log)  before/after:" \
  "out/head_{before,after}.est.csv, out/head_after.png"
