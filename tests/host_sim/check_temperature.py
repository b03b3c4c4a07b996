#!/usr/bin/env python3
"""host_sim replay feeds a trace's temp_c through the simulated sensor (sim/sim_temp.c) and the
firmware's hal_temp read into EST.csv: each row's temp_c is the trace's temperature of the
window's last row; a row whose temp_c is empty reads as a failed read and the estimate has no
temperature (never the previous row's); a trace without the column gives an empty temp_c.

usage: check_temperature.py HOST_SIM DEMO_TRACE WORK_DIR
"""
import csv
import os
import subprocess
import sys

host_sim, demo, work = sys.argv[1:4]
os.makedirs(work, exist_ok=True)

# Rows of the demo trace with a temperature ramp (0.01 °C a row from -5 °C, crossing zero) and
# two gaps: rows 195..199 (the end of the second window) and 250..259 (inside the third).
lines = open(demo, encoding="utf-8").read().splitlines()
ramp, expected, k, header_done = [], {}, 0, False
for line in lines:
    if line.startswith("#"):
        ramp.append(line)
        continue
    if not header_done:
        ramp.append(line + ",temp_c")
        header_done = True
        continue
    gap = 195 <= k <= 199 or 250 <= k <= 259
    value = "" if gap else "%.2f" % (-5.0 + 0.01 * k)
    expected[int(line.split(",")[0])] = value
    ramp.append(line + "," + value)
    k += 1
trace = os.path.join(work, "temperature_ramp.csv")
with open(trace, "w", encoding="utf-8") as f:
    f.write("\n".join(ramp) + "\n")


def replay(path, out):
    res = subprocess.run([host_sim, "replay", path, "--out", out, "--quiet"],
                         capture_output=True, text=True, timeout=600)
    if res.returncode != 0:
        sys.exit("host_sim replay %s failed (%d): %s" % (path, res.returncode, res.stderr))
    with open(out, encoding="utf-8") as f:
        return list(csv.DictReader(f))


failures = []
rows = replay(trace, os.path.join(work, "temperature_ramp.est.csv"))
if len(rows) != 50:
    failures.append("%d estimate rows, expected 50" % len(rows))
for row in rows:
    want = expected[int(row["t_ms"])]
    if row["temp_c"] != want:
        failures.append("t_ms %s: temp_c '%s', the trace's last row has '%s'"
                        % (row["t_ms"], row["temp_c"], want))
gap_row = [r for r in rows if r["t_ms"] == "3980"]
if not gap_row or gap_row[0]["temp_c"] != "":
    failures.append("the window ending in a row without temp_c must have an empty temp_c")
if not any(r["temp_c"].startswith("-") for r in rows):
    failures.append("no negative temperature written (the ramp starts at -5 C)")

plain = replay(demo, os.path.join(work, "temperature_none.est.csv"))
if any(r["temp_c"] != "" for r in plain):
    failures.append("a trace without temp_c gave a temperature")

if failures:
    sys.exit("\n".join(failures))
print("temperature: %d windows, each the trace's last-row temp_c; empty for a gap and without "
      "the column" % len(rows))
