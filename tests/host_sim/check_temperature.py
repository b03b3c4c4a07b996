#!/usr/bin/env python3
"""host_sim replay feeds a trace's temp_c through the simulated sensor (sim/sim_temp.c) and the
firmware's hal_temp read into EST.csv: each row's temp_c is the trace's temperature of the
window's last row; a row whose temp_c is empty reads as a failed read and the estimate has no
temperature (never the previous row's); a trace without the column gives an empty temp_c.
On a 20 -> 40 °C ramp ST's temperature update reruns on each part at every 8 °C, one part
at a time: the parts' readings are missing only in the windows of the crossings, and the
windows say which.

usage: check_temperature.py HOST_SIM DEMO_TRACE WORK_DIR
"""
import csv
import json
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


def write_trace(name, temp_of_row):
    out, k, header_done = [], 0, False
    for line in lines:
        if line.startswith("#"):
            out.append(line)
            continue
        if not header_done:
            out.append(line + ",temp_c")
            header_done = True
            continue
        out.append(line + "," + temp_of_row(k))
        k += 1
    path = os.path.join(work, name)
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")
    return path


def replay(path, out, *extra):
    res = subprocess.run([host_sim, "replay", path, "--out", out, "--quiet", *extra],
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

# The VHV reruns: 20 -> 40 °C over the 5000 rows crosses 28 °C at row 2000, 36 °C at row 4000.
ramp20 = write_trace("temperature_vhv.csv", lambda k: "%.2f" % (20.0 + 0.004 * k))
report_path = os.path.join(work, "temperature_vhv.json")
vhv_rows = replay(ramp20, os.path.join(work, "temperature_vhv.est.csv"), "--report", report_path)
with open(report_path, encoding="utf-8") as f:
    report = json.load(f)
temp = report["temperature"]
if temp["part_updates"] != [2, 2, 2, 2] or temp["updates"] != 8 or temp["updates_failed"] != 0:
    failures.append("temperature updates %s, expected two on each part, none failed" % temp)
if temp["read_errors"] != 0:
    failures.append("%d temperature reads failed on a trace with every temp_c" % temp["read_errors"])
incomplete = report["firmware"]["incomplete_samples"]
if not 1 <= incomplete <= 16:
    failures.append("%d samples with a reading missing for 8 updates (1..16 expected)" % incomplete)
missing_windows = set()
for k, row in enumerate(vhv_rows):
    parts = [w.split(":")[1] for w in row["why"].split("+") if w.startswith("missing:")]
    if parts:
        missing_windows.add(k)
        crossing = any(k * 100 - 100 <= r <= k * 100 + 199 for r in (2000, 4000))
        if not crossing:
            failures.append("window %d (t_ms %s) has missing readings away from a crossing"
                            % (k, row["t_ms"]))
named = {w.split(":")[1] for row in vhv_rows for w in row["why"].split("+")
         if w.startswith("missing:")}
if named != {"A", "B", "C", "D"}:
    failures.append("the windows name missing parts %s, expected A..D" % sorted(named))
print("VHV reruns: %s; %d samples with a reading missing, in windows %s"
      % (temp["part_updates"], incomplete, sorted(missing_windows)))

if failures:
    sys.exit("\n".join(failures))
print("temperature: %d windows, each the trace's last-row temp_c; empty for a gap and without "
      "the column" % len(rows))
